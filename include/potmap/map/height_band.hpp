#pragma once
// A height band of a 3D map seen from above: per (x, y) column, the largest occupancy
// probability over the heights z_lo to z_hi and the variance (and mean) where it is reached.
// What a planner reads: anything occupied between the ground and a vehicle's roof blocks the
// cell, whatever its height in the band.
//
// The band is sampled at evenly spaced heights that include both ends (height_band_levels);
// the maximum over those samples is what every evaluator here computes, so the device
// (MapEvaluator::evaluate_band_max), the exact reference (evaluate_band_exact) and the
// reduction rule (keep_band_max) agree on the same levels.

#include <cmath>
#include <cstddef>
#include <vector>

#include "potmap/export.h"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/kernel_map.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// The reduction rule, one level at a time: (p, var, mean) replaces the column's best when p is
/// larger, or NaN. A NaN stays (a column with an undefined level is undefined, not free); ties
/// keep the first (lowest) level. `best_mean` may be null. T: float (the device's values) or
/// double (the exact reference).
template <class T>
inline void keep_band_max(T p, T var, T mean, T& best_p, T& best_var, T* best_mean = nullptr) {
  if (std::isnan(best_p) || !(std::isnan(p) || p > best_p)) return;
  best_p = p;
  best_var = var;
  if (best_mean) *best_mean = mean;
}

/// The heights sampled in the band [z_lo, z_hi] (metres, map frame): n = ceil((z_hi - z_lo) /
/// step) + 1 levels evenly spaced from z_lo to z_hi inclusive, so the spacing is at most `step`
/// and both ends are seen. z_lo == z_hi gives the one level. Throws ArgumentError for non-finite
/// values, z_lo > z_hi, step <= 0, or more than 4096 levels.
std::vector<double> height_band_levels(double z_lo, double z_hi, double step);

/// The default spacing of a band's levels for `map` (metres): the standard deviation of its
/// narrowest kernel, 1 / sqrt(2 gamma_max). The map cannot change faster than that along z: a
/// lone kernel's peak, half a step from the nearest level, is seen at exp(-1/8) = 88 % of its
/// weight, and a finer step costs time in proportion (every level is a full slice). Empty map:
/// 0.1 m.
double default_band_step(const KernelMap& map);

/// Reduces `levels` slices of `cells` values each (slice k at offset k * cells) to one per cell
/// by keep_band_max, from the lowest level up. Outputs hold `cells` floats; mean pointers may
/// be null. levels == 0 writes NaN. The CPU reference of the device reduction.
void reduce_band_max(const float* prob, const float* var, const float* mean, std::size_t levels,
                     std::size_t cells, float* out_prob, float* out_var, float* out_mean);

/// Exact reference: the band maximum of a 3D map on the (x, y) cells of `columns` (dim 3;
/// count[2] and origin[2] are ignored), evaluated in double by evaluate_exact at every height
/// of `levels` and reduced by keep_band_max (in double). Outputs: columns.count[0] *
/// columns.count[1] values, x fastest.
MapValuesExact evaluate_band_exact(const KernelMap& map, const GridSpec& columns,
                                   const std::vector<double>& levels);

}  // namespace potmap
POTMAP_CXX_API_END
