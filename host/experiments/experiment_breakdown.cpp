// The breakdown of the experiments' held-out scores as text and JSON (experiment_breakdown.hpp).
#include "experiment_breakdown.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <tuple>

namespace potmap::experiment::runner {

namespace {

nlohmann::json number_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

// One table: the records of one case and seed, in method order.
std::string case_table(const std::vector<const Record*>& recs) {
  std::ostringstream out;
  char buf[256];
  const Record& first = *recs.front();
  out << "held-out scores by bin, " << (first.source.empty() ? "" : first.source + " -> ")
      << first.target << " seed " << first.seed << " (AUC NLL per method)\n";
  std::snprintf(buf, sizeof buf, "%-10s %-26s %9s", "axis", "bin", "samples");
  out << buf;
  for (const Record* r : recs) {
    std::snprintf(buf, sizeof buf, " %13s", r->method.substr(0, 13).c_str());
    out << buf;
  }
  out << "\n";
  for (std::size_t b = 0; b < first.breakdown.size(); ++b) {
    const experiment::BinScores& row = first.breakdown[b];
    std::snprintf(buf, sizeof buf, "%-10s %-26s %9zu", row.axis.c_str(), row.bin.c_str(),
                  row.scores.n);
    out << buf;
    for (const Record* r : recs) {
      const Scores& s = r->breakdown[b].scores;
      char auc[16];
      std::snprintf(auc, sizeof auc, std::isfinite(s.auc) ? "%.3f" : "-", s.auc);
      std::snprintf(buf, sizeof buf, " %6s %6.3f", auc, s.nll);
      out << buf;
    }
    out << "\n";
  }
  return out.str();
}

}  // namespace

std::string breakdown_text(const std::vector<Record>& records) {
  // Cases in first-seen order; a method's rows only where its bins are the first's (the same
  // test set gives the same bins).
  std::vector<std::tuple<std::string, std::string, std::uint64_t>> cases;
  for (const Record& r : records) {
    if (r.breakdown.empty()) continue;
    const auto key = std::make_tuple(r.source, r.target, r.seed);
    if (std::find(cases.begin(), cases.end(), key) == cases.end()) cases.push_back(key);
  }
  std::string out;
  for (const auto& key : cases) {
    std::vector<const Record*> recs;
    for (const Record& r : records)
      if (!r.breakdown.empty() && std::make_tuple(r.source, r.target, r.seed) == key &&
          (recs.empty() || r.breakdown.size() == recs.front()->breakdown.size()))
        recs.push_back(&r);
    out += case_table(recs);
  }
  return out;
}

nlohmann::json breakdown_json(const std::vector<experiment::BinScores>& breakdown) {
  nlohmann::json out = nlohmann::json::array();
  for (const experiment::BinScores& b : breakdown)
    out.push_back({{"axis", b.axis},
                   {"bin", b.bin},
                   {"n", b.scores.n},
                   {"acc", number_or_null(b.scores.acc)},
                   {"auc", number_or_null(b.scores.auc)},
                   {"nll", number_or_null(b.scores.nll)}});
  return out;
}

}  // namespace potmap::experiment::runner
