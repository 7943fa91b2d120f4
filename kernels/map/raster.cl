// Occupancy map evaluation on a regular grid (SPEC section 2 and the separability note of
// section 6): exp(-g |x-h|^2) = exp(-g dx^2) * exp(-g dy^2) (* exp(-g dz^2)), so a kernel's
// contribution to a block of cells is an outer product of a row of column factors and a column
// of row factors, and each (kernel, cell) pair costs a multiply-add instead of an exp.
//
// A work-group covers one tile: TILE_X columns by TILE_Y rows. A "row" is one (y[, z]) line of
// the grid; the host gives each tile's rows explicitly, which lets 3D tiles be compact in y and z.
// Each work-item owns 16 columns (a float16) by ROWS rows. Every tile has its own list of the
// kernels whose cut-off reaches it (built on the host).
//
// A work-item skips a listed kernel whose cut-off (gamma * d^2 > TAU) excludes its whole block
// of cells; otherwise the kernel contributes to every cell of the block in full, which is closer
// to the exact sum than a per-cell cut. Sums run in blocks of BLOCK kernels in float, block sums added
// with Neumaier's compensated summation (see map_eval.cl). Build with -cl-denorms-are-zero:
// far cells produce tiny products whose denormal arithmetic would otherwise crawl on CPUs.

#ifndef DIM
#define DIM 2
#endif
#ifndef ROWS
#define ROWS 8
#endif
#ifndef TILE_X
#define TILE_X 64
#endif
#ifndef TILE_Y
#define TILE_Y 64
#endif
#ifndef BLOCK
#define BLOCK 16
#endif
#ifndef TAU
#define TAU 18.0f
#endif

#if ROWS == 4
typedef float4 rowv;
#define vloadr vload4
#define vstore_rows(v, p) vstore4(v, 0, p)
#elif ROWS == 8
typedef float8 rowv;
#define vloadr vload8
#define vstore_rows(v, p) vstore8(v, 0, p)
#elif ROWS == 16
typedef float16 rowv;
#define vloadr vload16
#define vstore_rows(v, p) vstore16(v, 0, p)
#else
#error "ROWS must be 4, 8 or 16"
#endif

#include "../common/map_math.cl"

#define NEUMAIER_ADD(s, c, x) NEUMAIER_ADD_T(float16, s, c, x)

// col_hi/col_lo: x of every column centre (hi + lo floats, relative to the map anchor), padded
//   to a multiple of TILE_X.
// row_hi/row_lo: y of every row slot, then (3D) z of every row slot at offset n_slots
//   (padding rows repeat a real row). row_out: output offset of each row slot's first cell, -1 for padding.
// tile_rows: first row slot of each row block; tile (tx, b) = group (0, 1) ids.
// list_start[t]..list_start[t+1] slice of list[] for tile t = b * n_tiles_x + tx.
__kernel void map_raster(__global const float* kpos_hi, __global const float* kpos_lo,
                         __global const float4* kpar, __global const float* col_hi,
                         __global const float* col_lo, const uint n_cols,
                         __global const float* row_hi, __global const float* row_lo,
                         const uint n_slots,
                         __global const int* row_out, __global const uint* list_start,
                         __global const uint* list, const float bias_mean, const float bias_var,
                         __global float* out_mean, __global float* out_var,
                         __global float* out_prob) {
  const uint tx = get_group_id(0), b = get_group_id(1);
  const uint tile = b * get_num_groups(0) + tx;
  const uint col0 = tx * TILE_X + get_local_id(0) * 16;
  const uint slot0 = b * TILE_Y + get_local_id(1) * ROWS;

  const float16 cx_hi = vload16(0, col_hi + col0);
  const float16 cx_lo = vload16(0, col_lo + col0);
  // Rows as a vector too, so that their factors cost one vector exp per kernel.
  const rowv ry_hi = vloadr(0, row_hi + slot0), ry_lo = vloadr(0, row_lo + slot0);
#if DIM == 3
  const rowv rz_hi = vloadr(0, row_hi + n_slots + slot0);
  const rowv rz_lo = vloadr(0, row_lo + n_slots + slot0);
#endif

  // The work-item's block of cells, for the cut-off test (float is ample for a cull).
  const float x_min = cx_hi.s0 + cx_lo.s0, x_max = cx_hi.sf + cx_lo.sf;
  const float y_min = min(ry_hi.s0 + ry_lo.s0, ry_hi[ROWS - 1] + ry_lo[ROWS - 1]);
  const float y_max = max(ry_hi.s0 + ry_lo.s0, ry_hi[ROWS - 1] + ry_lo[ROWS - 1]);
#if DIM == 3
  const float z_min = min(rz_hi.s0 + rz_lo.s0, rz_hi[ROWS - 1] + rz_lo[ROWS - 1]);
  const float z_max = max(rz_hi.s0 + rz_lo.s0, rz_hi[ROWS - 1] + rz_lo[ROWS - 1]);
#endif

  float16 mean_s[ROWS], mean_c[ROWS], var_s[ROWS], var_c[ROWS];
  for (int r = 0; r < ROWS; ++r) {
    mean_s[r] = mean_c[r] = var_s[r] = var_c[r] = (float16)(0.0f);
  }

  const uint begin = list_start[tile], end = list_start[tile + 1];
  for (uint e0 = begin; e0 < end; e0 += BLOCK) {
    const uint stop = min(end, e0 + (uint)BLOCK);
    float16 mean_b[ROWS], var_b[ROWS];
    for (int r = 0; r < ROWS; ++r) mean_b[r] = var_b[r] = (float16)(0.0f);
    for (uint e = e0; e < stop; ++e) {
      const uint k = list[e];
      const float4 par = kpar[k];
      const float g = par.x;
      {
        const float kx = kpos_hi[k * DIM] + kpos_lo[k * DIM];
        const float ky = kpos_hi[k * DIM + 1] + kpos_lo[k * DIM + 1];
        const float ox = fmax(fmax(x_min - kx, kx - x_max), 0.0f);
        const float oy = fmax(fmax(y_min - ky, ky - y_max), 0.0f);
        float gap2 = ox * ox + oy * oy;
#if DIM == 3
        const float kz = kpos_hi[k * DIM + 2] + kpos_lo[k * DIM + 2];
        const float oz = fmax(fmax(z_min - kz, kz - z_max), 0.0f);
        gap2 += oz * oz;
#endif
        if (g * gap2 > TAU) continue;
      }
      const float16 dx = (cx_hi - kpos_hi[k * DIM]) + (cx_lo - kpos_lo[k * DIM]);
      const float16 ex = exp(-g * dx * dx);
      const float16 exm = par.y * ex;
      const float16 exv = par.z * (ex * ex);
      const rowv dy = (ry_hi - kpos_hi[k * DIM + 1]) + (ry_lo - kpos_lo[k * DIM + 1]);
      rowv a = dy * dy;
#if DIM == 3
      const rowv dz = (rz_hi - kpos_hi[k * DIM + 2]) + (rz_lo - kpos_lo[k * DIM + 2]);
      a = fma(dz, dz, a);
#endif
      const rowv ey = exp(-g * a);
      const rowv ey2 = ey * ey;
      float eys[ROWS], ey2s[ROWS];
      vstore_rows(ey, eys);
      vstore_rows(ey2, ey2s);
      for (int r = 0; r < ROWS; ++r) {
        mean_b[r] = fma(exm, (float16)(eys[r]), mean_b[r]);
        var_b[r] = fma(exv, (float16)(ey2s[r]), var_b[r]);
      }
    }
    for (int r = 0; r < ROWS; ++r) {
      NEUMAIER_ADD(mean_s[r], mean_c[r], mean_b[r]);
      NEUMAIER_ADD(var_s[r], var_c[r], var_b[r]);
    }
  }

  for (int r = 0; r < ROWS; ++r) {
    const int out = row_out[slot0 + r];
    if (out < 0) continue;
    const float16 mean = (mean_s[r] + mean_c[r]) + bias_mean;
    const float16 var = (var_s[r] + var_c[r]) + bias_var;
    const float16 prob = OCCUPANCY_PROB(mean, var);
    if (col0 + 16 <= n_cols) {
      if (out_mean) vstore16(mean, 0, out_mean + out + col0);
      if (out_var) vstore16(var, 0, out_var + out + col0);
      if (out_prob) vstore16(prob, 0, out_prob + out + col0);
    } else if (col0 < n_cols) {
      float m[16], v[16], p[16];
      vstore16(mean, 0, m);
      vstore16(var, 0, v);
      vstore16(prob, 0, p);
      for (uint i = 0; i < n_cols - col0; ++i) {
        if (out_mean) out_mean[out + col0 + i] = m[i];
        if (out_var) out_var[out + col0 + i] = v[i];
        if (out_prob) out_prob[out + col0 + i] = p[i];
      }
    }
  }
}
