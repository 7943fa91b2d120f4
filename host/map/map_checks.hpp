#pragma once
// The value rules of KernelMap (kernel_map.hpp), as the map readers apply them one value at a
// time, so that their errors can name the line or array element where a value came from.

#include <cmath>

namespace potmap::detail {

enum class MapField { position, gamma, w_mean, w_var, bias_mean, bias_var, cutoff_tau };

/// Why `v` is not acceptable for field `f`, or nullptr if it is.
inline const char* map_value_problem(MapField f, double v) {
  if (!std::isfinite(v)) return "value is not finite";
  if (f == MapField::gamma && !(v > 0)) return "gamma must be > 0";
  if (f == MapField::cutoff_tau && !(v > 0)) return "the cut-off exponent must be > 0";
  if ((f == MapField::w_var || f == MapField::bias_var) && !(v >= 0))
    return "weight variance must be >= 0";
  return nullptr;
}

}  // namespace potmap::detail
