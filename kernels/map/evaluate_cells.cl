// Occupancy map evaluation for points that already live on the device, in any order (the
// embedding entry point: a host mapper hands over its own cl_mem). Nothing is sorted: every
// point finds its cell of a uniform grid over the map, and the cell's list holds every kernel
// whose cut-off reaches the cell. One point per work-item, which suits GPUs; CPUs do better
// with the chunked path of map_eval.cl when the points are on the host.
//
// Points are float, relative to a caller's origin; `offset` = origin - map anchor as hi + lo.
// Each point is moved into the anchor frame as an exact hi + lo pair (Knuth's TwoSum), so that
// differences to kernels keep float's relative precision (see map_eval.cl).

#ifndef DIM
#define DIM 2
#endif

#include "../common/map_math.cl"

// cell_lo: lower corner of the cell grid relative to the anchor; cell_n: cells per axis;
// cell_start/cell_list: CSR lists per cell. Points outside the grid are reached by no kernel.
__kernel void map_eval_cells(__global const float* kpos_hi, __global const float* kpos_lo,
                             __global const float4* kpar, __global const float* points,
                             const uint n, const float4 offset_hi, const float4 offset_lo,
                             const float4 cell_lo, const float cell_size, const uint4 cell_n,
                             __global const uint* cell_start, __global const uint* cell_list,
                             const float bias_mean, const float bias_var,
                             __global float* out_mean, __global float* out_var,
                             __global float* out_prob) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  float q[DIM], ph[DIM], pl[DIM];
  const float ohv[4] = {offset_hi.x, offset_hi.y, offset_hi.z, offset_hi.w};
  const float olv[4] = {offset_lo.x, offset_lo.y, offset_lo.z, offset_lo.w};
  const float clv[4] = {cell_lo.x, cell_lo.y, cell_lo.z, cell_lo.w};
  const uint cnv[4] = {cell_n.x, cell_n.y, cell_n.z, cell_n.w};
  long cell = 0;
  bool inside = true;
  for (int d = DIM - 1; d >= 0; --d) {
    q[d] = points[i * DIM + d];
    const float s = q[d] + ohv[d];
    const float bb = s - q[d];
    ph[d] = s;
    pl[d] = ((q[d] - (s - bb)) + (ohv[d] - bb)) + olv[d];
    const float c = floor((ph[d] - clv[d]) / cell_size);
    inside = inside && c >= 0.0f && c < (float)cnv[d];
    cell = cell * cnv[d] + (long)c;
  }
  float mean_s = 0.0f, mean_c = 0.0f, var_s = 0.0f, var_c = 0.0f;
  if (inside && isfinite(q[0])) {
    const uint begin = cell_start[cell], end = cell_start[cell + 1];
    for (uint e = begin; e < end; ++e) {
      const uint k = cell_list[e];
      const float4 par = kpar[k];
      float d2 = 0.0f;
      for (int d = 0; d < DIM; ++d) {
        const float diff = (ph[d] - kpos_hi[k * DIM + d]) + (pl[d] - kpos_lo[k * DIM + d]);
        d2 = fma(diff, diff, d2);
      }
      const float phi = exp(-par.x * d2);
      // Kahan-Babuska per term: a single point has no vector lanes to amortise blocks over.
      float x = par.y * phi, t = mean_s + x;
      mean_c += fabs(mean_s) >= fabs(x) ? (mean_s - t) + x : (x - t) + mean_s;
      mean_s = t;
      x = par.z * phi * phi;
      t = var_s + x;
      var_c += fabs(var_s) >= fabs(x) ? (var_s - t) + x : (x - t) + var_s;
      var_s = t;
    }
  }
  float nan_if_bad = 0.0f;
  for (int d = 0; d < DIM; ++d) nan_if_bad += isfinite(q[d]) ? 0.0f : NAN;
  const float mean = (mean_s + mean_c) + bias_mean + nan_if_bad;
  const float var = (var_s + var_c) + bias_var + nan_if_bad;
  const float prob = OCCUPANCY_PROB(mean, var);
  if (out_mean) out_mean[i] = mean;
  if (out_var) out_var[i] = var;
  if (out_prob) out_prob[i] = prob;
}
