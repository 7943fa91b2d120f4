#include "potmap/map/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>

#include "potmap/error.hpp"

namespace potmap {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void check(const std::vector<double>& prob, const std::vector<std::uint8_t>& label) {
  if (prob.size() != label.size())
    throw ArgumentError("score: " + std::to_string(prob.size()) + " probabilities but " +
                        std::to_string(label.size()) + " labels");
  std::size_t bad = 0, first = 0;
  for (std::size_t i = 0; i < prob.size(); ++i)
    if (!(prob[i] >= 0.0 && prob[i] <= 1.0) && bad++ == 0) first = i;
  if (bad) {
    std::ostringstream m;
    m << "score: " << bad << " of " << prob.size()
      << " probabilities are NaN or outside [0, 1]; the first is index " << first << " = "
      << prob[first];
    throw ArgumentError(m.str());
  }
  for (std::size_t i = 0; i < label.size(); ++i)
    if (label[i] > 1)
      throw ArgumentError("score: label " + std::to_string(label[i]) + " at index " +
                          std::to_string(i) + " is not 0 or 1");
}

double accuracy_unchecked(const std::vector<double>& p, const std::vector<std::uint8_t>& y) {
  if (p.empty()) return kNaN;
  std::size_t right = 0;
  for (std::size_t i = 0; i < p.size(); ++i) right += (p[i] >= 0.5) == (y[i] == 1);
  return static_cast<double>(right) / static_cast<double>(p.size());
}

double auc_unchecked(const std::vector<double>& p, const std::vector<std::uint8_t>& y) {
  const std::size_t n = p.size();
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p[a] < p[b]; });
  // Sum of the (1-based, tie-averaged) ranks of the occupied points. Ranks are integers or
  // halves, so the sum is exact in double far beyond any test-set size.
  double rank_sum = 0;
  std::size_t pos = 0;
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i;
    std::size_t pos_in_group = 0;
    while (j < n && p[order[j]] == p[order[i]]) pos_in_group += y[order[j++]];
    const double avg_rank = 0.5 * static_cast<double>(i + 1 + j);
    rank_sum += avg_rank * static_cast<double>(pos_in_group);
    pos += pos_in_group;
    i = j;
  }
  const std::size_t neg = n - pos;
  if (pos == 0 || neg == 0) return kNaN;
  const double np = static_cast<double>(pos), nn = static_cast<double>(neg);
  return (rank_sum - np * (np + 1) / 2) / (np * nn);
}

double nll_unchecked(const std::vector<double>& p, const std::vector<std::uint8_t>& y) {
  if (p.empty()) return kNaN;
  double sum = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double q = std::clamp(p[i], kNllClip, 1.0 - kNllClip);
    sum -= y[i] ? std::log(q) : std::log1p(-q);
  }
  return sum / static_cast<double>(p.size());
}

}  // namespace

Scores score(const std::vector<double>& prob, const std::vector<std::uint8_t>& label) {
  check(prob, label);
  Scores s;
  s.n = prob.size();
  s.acc = accuracy_unchecked(prob, label);
  s.auc = auc_unchecked(prob, label);
  s.nll = nll_unchecked(prob, label);
  return s;
}

Scores score(const std::vector<float>& prob, const std::vector<std::uint8_t>& label) {
  return score(std::vector<double>(prob.begin(), prob.end()), label);
}

double accuracy(const std::vector<double>& prob, const std::vector<std::uint8_t>& label) {
  check(prob, label);
  return accuracy_unchecked(prob, label);
}

double roc_auc(const std::vector<double>& prob, const std::vector<std::uint8_t>& label) {
  check(prob, label);
  return auc_unchecked(prob, label);
}

double mean_nll(const std::vector<double>& prob, const std::vector<std::uint8_t>& label) {
  check(prob, label);
  return nll_unchecked(prob, label);
}

}  // namespace potmap
