// Occupancy map evaluation over cubic blocks of 16 x 16 x 16 voxels (a 3D map's volume, block
// by block: what a drive's OctoMap, point cloud and height band are made of). As in raster.cl,
// a kernel's factor separates along the axes, exp(-g |x-h|^2) = exp(-g dx^2) exp(-g dy^2)
// exp(-g dz^2), so a (kernel, voxel) pair costs multiply-adds instead of an exp.
//
// A work-group is one block. A work-item owns one x row of 16 voxels (a float16) for YR y rows
// by ZR z levels. The block's kernels are taken a chunk at a time: each work-item computes one
// kernel's factor tables along x, y and z (16 exps each: the block's 16 voxel centres on that
// axis) into local memory, then every work-item reads the whole chunk's tables, three
// multiply-adds per voxel and kernel (the mean, the variance and the support, the sum of phi^2
// that tells space a kernel reaches from space none does). The exps are then 48 a kernel and
// block, not 22 for each of the 32 work-items: they were most of the work. A work-item skips a
// kernel whose cut-off (gamma d^2 > TAU) misses its whole box of voxels. Each block has its own
// list of the kernels whose cut-off reaches it (built on the host). Sums in float, one term
// after another in the list's order (p within 1e-6 of the exact double sums on a drive's
// lattice of kernels, tests/evaluate_blocks_test.cpp), where compensation would double the
// registers an item holds. Build with -cl-denorms-are-zero (far voxels give tiny products).

#ifndef TAU
#define TAU 18.0f
#endif
#define SIDE 16
#define YR 2
#define ZR 4
#define ITEMS_Y (SIDE / YR)
#define ITEMS (ITEMS_Y * (SIDE / ZR))  // the work-group: 8 y pairs by 4 z quads
#define CHUNK ITEMS                    // kernels a chunk: one table each work-item (<= 32)

#include "../common/map_math.cl"

// Block b's kernels are entries list_start[b]..list_start[b+1] of the list arrays, one float
// each: the block's corner less the kernel's centre on x, y and z (metres, taken in double on
// the host, so any frame keeps its precision), the kernel's gamma and its weight's mean and
// variance. Outputs (any may be null): 4096 floats a block, voxel (i, j, k) at i + 16 (j + 16 k).
__kernel __attribute__((reqd_work_group_size(ITEMS, 1, 1))) void map_blocks(
    __global const float* list_x, __global const float* list_y, __global const float* list_z,
    __global const float* list_g, __global const float* list_wm, __global const float* list_wv,
    __global const uint* list_start, const float voxel, const float bias_mean, const float bias_var,
    __global float* out_var, __global float* out_prob, __global float* out_support) {
  // The chunk's kernels: their factors at the block's 16 voxel centres along each axis, and
  // what the cull and the sums read.
  __local float tab_x[CHUNK * SIDE], tab_x2[CHUNK * SIDE], tab_y[CHUNK * SIDE], tab_z[CHUNK * SIDE];
  __local float k_x[CHUNK], k_y[CHUNK], k_z[CHUNK], k_g[CHUNK], k_wm[CHUNK], k_wv[CHUNK];
  const uint b = get_group_id(0), lid = get_local_id(0);
  const uint j0 = (lid % ITEMS_Y) * YR, k0 = (lid / ITEMS_Y) * ZR;
  const float16 lane = (float16)(0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f, 7.5f, 8.5f, 9.5f, 10.5f,
                                 11.5f, 12.5f, 13.5f, 14.5f, 15.5f) *
                       voxel;
  // The item's box of voxel centres, from the block's corner.
  const float x_lo = lane.s0, x_hi = lane.sf;
  const float y_lo = (0.5f + (float)j0) * voxel, y_hi = (0.5f + (float)(j0 + YR - 1)) * voxel;
  const float z_lo = (0.5f + (float)k0) * voxel, z_hi = (0.5f + (float)(k0 + ZR - 1)) * voxel;

  float16 m[YR * ZR], v[YR * ZR], s[YR * ZR];
  for (int r = 0; r < YR * ZR; ++r) m[r] = v[r] = s[r] = (float16)(0.0f);

  const uint begin = list_start[b], end = list_start[b + 1];
  for (uint e0 = begin; e0 < end; e0 += CHUNK) {
    const uint n = min((uint)CHUNK, end - e0);
    barrier(CLK_LOCAL_MEM_FENCE);  // every item is done with the chunk before
    if (lid < n) {
      const uint e = e0 + lid;
      const float ge = list_g[e], cx = list_x[e], cy = list_y[e], cz = list_z[e];
      const float16 dx = cx + lane, dy = cy + lane, dz = cz + lane;
      const float16 ex = exp(-ge * dx * dx);
      vstore16(ex, lid, tab_x);
      vstore16(ex * ex, lid, tab_x2);
      vstore16(exp(-ge * dy * dy), lid, tab_y);
      vstore16(exp(-ge * dz * dz), lid, tab_z);
      k_x[lid] = cx;
      k_y[lid] = cy;
      k_z[lid] = cz;
      k_g[lid] = ge;
      k_wm[lid] = list_wm[e];
      k_wv[lid] = list_wv[e];
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    // The chunk's kernels whose cut-off reaches the item's box, as bits; then two rows of
    // voxels at a time over them, their sums in registers (summed in memory across the rows
    // at once, every term was a load and a store in one dependent chain).
    uint reach = 0;
    for (uint q = 0; q < n; ++q) {
      const float cx = k_x[q], cy = k_y[q], cz = k_z[q];
      const float gx = fmax(fmax(cx + x_lo, -(cx + x_hi)), 0.0f);
      const float gy = fmax(fmax(cy + y_lo, -(cy + y_hi)), 0.0f);
      const float gz = fmax(fmax(cz + z_lo, -(cz + z_hi)), 0.0f);
      if (k_g[q] * (gx * gx + gy * gy + gz * gz) <= TAU) reach |= 1u << q;
    }
    // Two rows a pass (two z levels of one y row: one y factor): six independent sums hide the
    // multiply-adds' latency.
    for (int r = 0; r < YR * ZR; r += 2) {
      float16 am = m[r], av = v[r], as = s[r], bm = m[r + 1], bv = v[r + 1], bs = s[r + 1];
      __local const float* ty = tab_y + j0 + r / ZR;
      __local const float* tz = tab_z + k0 + r % ZR;
      for (uint left = reach; left != 0; left &= left - 1) {
        const uint q = ctz(left);
        const float fy = ty[q * SIDE], wm = k_wm[q], wv = k_wv[q];
        const float fa = fy * tz[q * SIDE], fb = fy * tz[q * SIDE + 1];
        const float fa2 = fa * fa, fb2 = fb * fb;
        const float16 ex = vload16(q, tab_x), ex2 = vload16(q, tab_x2);
        am = fma((float16)(wm * fa), ex, am);
        av = fma((float16)(wv * fa2), ex2, av);
        as = fma((float16)(fa2), ex2, as);
        bm = fma((float16)(wm * fb), ex, bm);
        bv = fma((float16)(wv * fb2), ex2, bv);
        bs = fma((float16)(fb2), ex2, bs);
      }
      m[r] = am;
      v[r] = av;
      s[r] = as;
      m[r + 1] = bm;
      v[r + 1] = bv;
      s[r + 1] = bs;
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
