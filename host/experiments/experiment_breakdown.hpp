#pragma once
// The breakdown of the experiments' held-out scores (score_breakdown.hpp) as text and JSON.

#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include "potmap/experiments/experiment_runner.hpp"

namespace potmap::experiment::runner {

/// One table per (source, target, seed) whose records carry a breakdown: a row per bin (axis,
/// bin, samples), each method's AUC and NLL in columns ("-" where a bin holds one class).
/// Empty when no record has one.
std::string breakdown_text(const std::vector<Record>& records);

/// A record's breakdown as a JSON array of {axis, bin, n, acc, auc, nll} (null where NaN).
nlohmann::json breakdown_json(const std::vector<experiment::BinScores>& breakdown);

}  // namespace potmap::experiment::runner
