// Occupancy map evaluation over cubic blocks of 16 x 16 x 16 voxels (a 3D map's volume, block
// by block: what a drive's OctoMap, point cloud and height band are made of). As in raster.cl,
// a kernel's factor separates along the axes, exp(-g |x-h|^2) = exp(-g dx^2) exp(-g dy^2)
// exp(-g dz^2), so a (kernel, voxel) pair costs multiply-adds instead of an exp.
//
// A work-group is one block. A work-item owns one x row of 16 voxels (a float16) for YR y rows
// by ZR z levels: per listed kernel it takes one float16 exp along x and YR + ZR exps along y
// and z, then three multiply-adds per voxel (the mean, the variance and the support, the sum of
// phi^2 that tells space a kernel reaches from space none does). A work-item skips a kernel
// whose cut-off (gamma d^2 > TAU) misses its whole box of voxels. Each block has its own list
// of the kernels whose cut-off reaches it (built on the host). Sums in float, one term after
// another (p within 1e-6 of the exact double sums on a drive's lattice of kernels,
// tests/evaluate_blocks_test.cpp), where compensation would double the registers an item holds.
// Build with -cl-denorms-are-zero (far voxels give tiny products).

#ifndef TAU
#define TAU 18.0f
#endif
#define SIDE 16
#define YR 2
#define ZR 4
#define ITEMS_Y (SIDE / YR)

#include "../common/map_math.cl"

// Block b's kernels are entries list_start[b]..list_start[b+1] of the list arrays, one float
// each: the block's corner less the kernel's centre on x, y and z (metres, taken in double on
// the host, so any frame keeps its precision), the kernel's gamma and its weight's mean and
// variance. A work-item tests 16 entries at once against its box (vector compares), then
// evaluates the ones whose cut-off reaches it.
// Outputs (any may be null): 4096 floats a block, voxel (i, j, k) at i + 16 (j + 16 k).
__kernel void map_blocks(__global const float* list_x, __global const float* list_y,
                         __global const float* list_z, __global const float* list_g,
                         __global const float* list_wm, __global const float* list_wv,
                         __global const uint* list_start, const float voxel,
                         const float bias_mean, const float bias_var, __global float* out_var,
                         __global float* out_prob, __global float* out_support) {
  const uint b = get_group_id(0), lid = get_local_id(0);
  const uint j0 = (lid % ITEMS_Y) * YR, k0 = (lid / ITEMS_Y) * ZR;
  const float16 lane = (float16)(0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f, 7.5f, 8.5f, 9.5f,
                                 10.5f, 11.5f, 12.5f, 13.5f, 14.5f, 15.5f) *
                       voxel;
  // Offsets of the item's rows and levels from the block's corner, and its box's extent.
  const float2 oy = ((float2)(0.5f, 1.5f) + (float)j0) * voxel;
  const float4 oz = ((float4)(0.5f, 1.5f, 2.5f, 3.5f) + (float)k0) * voxel;
  const float x_lo = lane.s0, x_hi = lane.sf, y_lo = oy.s0, y_hi = oy.s1, z_lo = oz.s0,
              z_hi = oz.s3;

  float16 m[YR * ZR], v[YR * ZR], s[YR * ZR];
  for (int r = 0; r < YR * ZR; ++r) m[r] = v[r] = s[r] = (float16)(0.0f);

  const uint begin = list_start[b], end = list_start[b + 1];
  for (uint e0 = begin; e0 < end; e0 += 16) {
    // Sixteen entries' distances to the box at once (past the end: a far sentinel).
    const uint n = min(16u, end - e0);
    float16 cx, cy, cz, g;
    if (n == 16) {
      cx = vload16(0, list_x + e0);
      cy = vload16(0, list_y + e0);
      cz = vload16(0, list_z + e0);
      g = vload16(0, list_g + e0);
    } else {
      float tx[16], ty[16], tz[16], tg[16];
      for (uint q = 0; q < 16; ++q) {
        tx[q] = q < n ? list_x[e0 + q] : 1e6f;
        ty[q] = q < n ? list_y[e0 + q] : 0.0f;
        tz[q] = q < n ? list_z[e0 + q] : 0.0f;
        tg[q] = q < n ? list_g[e0 + q] : 1.0f;
      }
      cx = vload16(0, tx);
      cy = vload16(0, ty);
      cz = vload16(0, tz);
      g = vload16(0, tg);
    }
    const float16 gx = fmax(fmax(cx + x_lo, -(cx + x_hi)), 0.0f);
    const float16 gy = fmax(fmax(cy + y_lo, -(cy + y_hi)), 0.0f);
    const float16 gz = fmax(fmax(cz + z_lo, -(cz + z_hi)), 0.0f);
    int reach[16];
    vstore16(g * (gx * gx + gy * gy + gz * gz) <= TAU, 0, reach);
    for (uint q = 0; q < n; ++q) {
      if (!reach[q]) continue;
      const uint e = e0 + q;
      const float ge = list_g[e], wm = list_wm[e], wv = list_wv[e];
      const float16 dx = list_x[e] + lane;
      const float16 ex = exp(-ge * dx * dx);
      const float16 ex2 = ex * ex;
      const float2 dy = list_y[e] + oy;
      const float4 dz = list_z[e] + oz;
      const float2 ey = exp(-ge * dy * dy);
      const float4 ez = exp(-ge * dz * dz);
      const float eyz[YR * ZR] = {ey.s0 * ez.s0, ey.s0 * ez.s1, ey.s0 * ez.s2, ey.s0 * ez.s3,
                                  ey.s1 * ez.s0, ey.s1 * ez.s1, ey.s1 * ez.s2, ey.s1 * ez.s3};
      for (int r = 0; r < YR * ZR; ++r) {
        const float f = eyz[r], f2 = f * f;
        m[r] = fma((float16)(wm * f), ex, m[r]);
        v[r] = fma((float16)(wv * f2), ex2, v[r]);
        s[r] = fma((float16)(f2), ex2, s[r]);
      }
    }
  }

  for (int r = 0; r < YR * ZR; ++r) {
    const uint j = j0 + r / ZR, kz = k0 + r % ZR;
    const size_t at = (size_t)b * (SIDE * SIDE * SIDE) + (kz * SIDE + j) * SIDE;
    const float16 var = v[r] + bias_var;
    if (out_var) vstore16(var, 0, out_var + at);
    if (out_prob) vstore16(OCCUPANCY_PROB(m[r] + bias_mean, var), 0, out_prob + at);
    if (out_support) vstore16(s[r], 0, out_support + at);
  }
}
