#include "potmap/io/known_cells.hpp"

#include <optional>
#include <string>

#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"

namespace potmap {

struct KnownEvaluator::Impl {
  KernelMap map, unit;
  KnownRule rule;
  std::optional<MapEvaluator> ev, ev_unit;  // on the device; none: the exact CPU sums

  // Probability and variance at the points.
  void values(const KernelMap& m, std::optional<MapEvaluator>& e, const std::vector<double>& pts,
              std::vector<double>& prob, std::vector<double>& var) const {
    const std::size_t n = pts.size() / m.dim;
    prob.assign(n, 0.5);
    var.assign(n, m.has_bias ? m.bias_var : 0.0);
    if (m.empty() && !m.has_bias) return;
    if (e) {
      std::vector<float> p(n), v(n);
      e->evaluate(pts.data(), n, nullptr, v.data(), p.data());
      prob.assign(p.begin(), p.end());
      var.assign(v.begin(), v.end());
    } else {
      MapValuesExact x = evaluate_exact(m, pts.data(), n);
      prob = std::move(x.prob);
      var = std::move(x.var);
    }
  }
};

KnownEvaluator::KnownEvaluator(Context* ctx, const KernelMap& map, const KnownRule& rule)
    : impl_(std::make_unique<Impl>()) {
  if (!(rule.min_support >= 0) || !(rule.unknown_variance > 0))
    throw ArgumentError("known cells: min_support " + std::to_string(rule.min_support) +
                        " must be >= 0 and unknown_variance " +
                        std::to_string(rule.unknown_variance) + " > 0");
  impl_->map = map;
  impl_->rule = rule;
  // The support is the variance of the same kernels with unit weight variance and no bias.
  KernelMap& unit = impl_->unit;
  unit = map;
  unit.w_mean.assign(map.size(), 0.0);
  unit.w_var.assign(map.size(), 1.0);
  unit.has_bias = false;
  if (ctx && !(map.empty() && !map.has_bias)) impl_->ev.emplace(*ctx, impl_->map);
  if (ctx && !unit.empty()) impl_->ev_unit.emplace(*ctx, impl_->unit);
}

KnownEvaluator::~KnownEvaluator() = default;
KnownEvaluator::KnownEvaluator(KnownEvaluator&&) noexcept = default;

KnownValues KnownEvaluator::values(const std::vector<double>& points) {
  const Impl& m = *impl_;
  KnownValues out;
  std::vector<double> unused, support;
  m.values(m.map, impl_->ev, points, out.prob, out.var);
  m.values(m.unit, impl_->ev_unit, points, unused, support);
  const double bias_var = m.map.has_bias ? m.map.bias_var : 0.0;
  out.known.resize(out.prob.size());
  for (std::size_t i = 0; i < out.prob.size(); ++i) {
    const double spread = support[i] > 0 ? (out.var[i] - bias_var) / support[i] : 0.0;
    out.known[i] = is_known(support[i], spread, m.rule);
  }
  return out;
}

bool is_known(double support, double spread, const KnownRule& rule) {
  return support >= rule.min_support && spread < rule.unknown_variance;
}

KnownValues known_values(Context* ctx, const KernelMap& map, const std::vector<double>& points,
                         const KnownRule& rule) {
  return KnownEvaluator(ctx, map, rule).values(points);
}

}  // namespace potmap
