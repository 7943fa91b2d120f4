#include "potmap/io/known_cells.hpp"

#include <string>

#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"

namespace potmap {

namespace {

// Probability and variance at the points, on the device or by the exact sum.
void values(Context* ctx, const KernelMap& map, const std::vector<double>& pts,
            std::vector<double>& prob, std::vector<double>& var) {
  const std::size_t n = pts.size() / map.dim;
  prob.assign(n, 0.5);
  var.assign(n, map.has_bias ? map.bias_var : 0.0);
  if (map.empty() && !map.has_bias) return;
  if (ctx) {
    std::vector<float> p(n), v(n);
    MapEvaluator ev(*ctx, map);
    ev.evaluate(pts.data(), n, nullptr, v.data(), p.data());
    prob.assign(p.begin(), p.end());
    var.assign(v.begin(), v.end());
  } else {
    MapValuesExact e = evaluate_exact(map, pts.data(), n);
    prob = std::move(e.prob);
    var = std::move(e.var);
  }
}

}  // namespace

bool is_known(double support, double spread, const KnownRule& rule) {
  return support >= rule.min_support && spread < rule.unknown_variance;
}

KnownValues known_values(Context* ctx, const KernelMap& map, const std::vector<double>& points,
                         const KnownRule& rule) {
  if (!(rule.min_support >= 0) || !(rule.unknown_variance > 0))
    throw ArgumentError("known cells: min_support " + std::to_string(rule.min_support) +
                        " must be >= 0 and unknown_variance " +
                        std::to_string(rule.unknown_variance) + " > 0");
  // The support is the variance of the same kernels with unit weight variance and no bias.
  KernelMap unit = map;
  unit.w_mean.assign(map.size(), 0.0);
  unit.w_var.assign(map.size(), 1.0);
  unit.has_bias = false;
  KnownValues out;
  std::vector<double> var, unused, support;
  values(ctx, map, points, out.prob, var);
  values(ctx, unit, points, unused, support);
  const double bias_var = map.has_bias ? map.bias_var : 0.0;
  out.known.resize(out.prob.size());
  for (std::size_t i = 0; i < out.prob.size(); ++i) {
    const double spread = support[i] > 0 ? (var[i] - bias_var) / support[i] : 0.0;
    out.known[i] = is_known(support[i], spread, rule);
  }
  return out;
}

}  // namespace potmap
