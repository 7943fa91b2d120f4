// Height-band maximum (include/potmap/map/height_band.hpp): per (x, y) cell, the largest
// probability over the band's levels and the variance and mean at that level, reduced on the
// device from the slices map_raster (raster.cl) wrote, so that only the band is read back.
//
// The levels' slices are row slots of the raster launch: slot level_slot[r * n_levels + k] holds
// output row r at level k, its n_cols values at offset slot * n_cols. The rule is
// keep_band_max's: a larger probability or a NaN replaces the best, a NaN stays, ties keep the
// lowest level.

__kernel void map_band_max(__global const float* in_mean, __global const float* in_var,
                           __global const float* in_prob, const uint n_cols, const uint n_levels,
                           __global const int* level_slot, __global float* out_mean,
                           __global float* out_var, __global float* out_prob) {
  const uint i = get_global_id(0), r = get_global_id(1);
  if (i >= n_cols) return;
  __global const int* slots = level_slot + (size_t)r * n_levels;
  size_t at = (size_t)slots[0] * n_cols + i;
  float best = in_prob[at];
  size_t best_at = at;
  for (uint k = 1; k < n_levels; ++k) {
    at = (size_t)slots[k] * n_cols + i;
    const float p = in_prob[at];
    const bool take = !isnan(best) && (isnan(p) || p > best);
    best = take ? p : best;
    best_at = take ? at : best_at;
  }
  const size_t out = (size_t)r * n_cols + i;
  out_prob[out] = best;
  out_var[out] = in_var[best_at];
  out_mean[out] = in_mean[best_at];
}
