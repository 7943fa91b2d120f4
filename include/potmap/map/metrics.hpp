#pragma once
// Scores of a map on labelled test points (SPEC section 5): accuracy, ROC AUC and mean
// negative log-likelihood.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "potmap/error.hpp"  // the exceptions documented below
#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Probabilities are clipped to [kNllClip, 1 - kNllClip] before the logarithm in mean_nll, so
/// that one confident mistake costs at most -log(1e-6) = 13.8 instead of infinity.
inline constexpr double kNllClip = 1e-6;

/// Scores of one set of predictions.
struct Scores {
  double acc = 0;     ///< fraction of points with (p >= 0.5) == label; in [0, 1]
  double auc = 0;     ///< ROC AUC in [0, 1]; NaN if only one class is present
  double nll = 0;     ///< mean -log p(label), p clipped to [kNllClip, 1 - kNllClip], nats
  std::size_t n = 0;  ///< number of points scored
};

/// Accuracy, AUC and NLL of occupancy probabilities `prob` (in [0, 1]) against `label`
/// (1 = occupied, 0 = free).
///  * accuracy: a point is predicted occupied when p >= 0.5 (p exactly 0.5 counts as occupied);
///  * AUC: the Mann-Whitney statistic with average ranks, so tied probabilities count one half
///    per (occupied, free) pair, exactly; NaN when all labels are equal (AUC undefined);
///  * NLL: mean of -[y log p + (1 - y) log(1 - p)] with p clipped as kNllClip says.
/// Empty input gives NaN for all three and n = 0.
/// Throws ArgumentError if the sizes differ, a label is not 0 or 1, or a probability is NaN or
/// outside [0, 1] (the message gives how many and the first index and value: a NaN usually means
/// a query point with non-finite coordinates).
Scores score(const std::vector<float>& prob, const std::vector<std::uint8_t>& label);
Scores score(const std::vector<double>& prob, const std::vector<std::uint8_t>& label);

/// The three metrics on their own (same rules and errors as score()).
double accuracy(const std::vector<double>& prob, const std::vector<std::uint8_t>& label);
double roc_auc(const std::vector<double>& prob, const std::vector<std::uint8_t>& label);
double mean_nll(const std::vector<double>& prob, const std::vector<std::uint8_t>& label);

}  // namespace potmap
POTMAP_CXX_API_END
