#pragma once
// Which places a kernel map knows, for exports to formats with an "unknown" state (ROS maps,
// OctoMap). Decided from the variance, not from the probability, because a place no data
// reached and a place seen half occupied both sit near p = 0.5:
//   support(x) = sum_m phi_m(x)^2                  (how much kernel there is at x)
//   spread(x)  = (s2(x) - b_var) / support(x)      (phi^2-weighted mean weight variance at x)
// A point is unknown when support < min_support (no kernel reaches it) or spread >=
// unknown_variance (the kernels there still hold about their prior: no sample updated them).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct KnownRule {
  /// Support below which a point is unknown (default 0.1: farther than about one kernel reach
  /// from every kernel, phi < 0.32).
  double min_support = 0.1;
  /// Mean weight variance at or above which a point is unknown (default 5: half the joint BHM's
  /// prior variance of 10, the line dictionaries use to drop kernels no sample reached).
  double unknown_variance = 5.0;
};

/// The map's probability at n points (n * map.dim coordinates) and whether each is known.
struct KnownValues {
  std::vector<double> prob;
  std::vector<std::uint8_t> known;  ///< 1 = known under the rule
  std::vector<double> var;          ///< the logit's variance s2 (SPEC section 2)
};

/// known_values() for many batches of points over one map: the map and its support map are
/// uploaded once (`ctx` null: the exact CPU sums). Keeps a pointer to ctx and a copy of the
/// map's kernels.
class KnownEvaluator {
 public:
  KnownEvaluator(Context* ctx, const KernelMap& map, const KnownRule& rule = {});
  ~KnownEvaluator();
  KnownEvaluator(KnownEvaluator&&) noexcept;
  KnownValues values(const std::vector<double>& points);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// `ctx` null: the exact CPU sums (evaluate_exact); else the device evaluator. Throws
/// ArgumentError for min_support < 0 or unknown_variance <= 0.
KnownValues known_values(Context* ctx, const KernelMap& map, const std::vector<double>& points,
                         const KnownRule& rule = {});

/// The rule on one point's values (what known_values applies).
bool is_known(double support, double spread, const KnownRule& rule);

}  // namespace potmap
POTMAP_CXX_API_END
