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

// kpos_hi/kpos_lo, kpar: the evaluator's kernels (positions relative to its anchor, split hi +
//   lo; gamma, weight mean, weight variance).
// block_hi/block_lo: each block's lower corner relative to the anchor, 3 floats a block.
// list_start[b]..list_start[b+1]: the slice of list[] holding block b's kernels.
// Outputs (any may be null): 4096 floats a block, voxel (i, j, k) at i + 16 (j + 16 k).
__kernel void map_blocks(__global const float* kpos_hi, __global const float* kpos_lo,
                         __global const float4* kpar, __global const float* block_hi,
                         __global const float* block_lo, const float voxel,
                         __global const uint* list_start, __global const uint* list,
                         const float bias_mean, const float bias_var, __global float* out_var,
                         __global float* out_prob, __global float* out_support) {
  const uint b = get_group_id(0), lid = get_local_id(0);
  const uint j0 = (lid % ITEMS_Y) * YR, k0 = (lid / ITEMS_Y) * ZR;
  const float16 lane = (float16)(0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f, 7.5f, 8.5f, 9.5f,
                                 10.5f, 11.5f, 12.5f, 13.5f, 14.5f, 15.5f) *
                       voxel;
  // Offsets of the item's rows and levels from the block's corner.
  const float2 oy = ((float2)(0.5f, 1.5f) + (float)j0) * voxel;
  const float4 oz = ((float4)(0.5f, 1.5f, 2.5f, 3.5f) + (float)k0) * voxel;
  const float bx_hi = block_hi[3 * b], bx_lo = block_lo[3 * b];
  const float by_hi = block_hi[3 * b + 1], by_lo = block_lo[3 * b + 1];
  const float bz_hi = block_hi[3 * b + 2], bz_lo = block_lo[3 * b + 2];

  float16 m[YR * ZR], v[YR * ZR], s[YR * ZR];
  for (int r = 0; r < YR * ZR; ++r) m[r] = v[r] = s[r] = (float16)(0.0f);

  const uint end = list_start[b + 1];
  for (uint e = list_start[b]; e < end; ++e) {
    const uint k = list[e];
    const float4 par = kpar[k];
    const float g = par.x;
    // The block's corner less the kernel's centre, per axis.
    const float cx = (bx_hi - kpos_hi[3 * k]) + (bx_lo - kpos_lo[3 * k]);
    const float cy = (by_hi - kpos_hi[3 * k + 1]) + (by_lo - kpos_lo[3 * k + 1]);
    const float cz = (bz_hi - kpos_hi[3 * k + 2]) + (bz_lo - kpos_lo[3 * k + 2]);
    // Distance from the kernel to the item's box of voxel centres.
    const float gx = fmax(fmax(cx + lane.s0, -(cx + lane.sf)), 0.0f);
    const float gy = fmax(fmax(cy + oy.s0, -(cy + oy.s1)), 0.0f);
    const float gz = fmax(fmax(cz + oz.s0, -(cz + oz.s3)), 0.0f);
    if (g * (gx * gx + gy * gy + gz * gz) > TAU) continue;
    const float16 dx = cx + lane;
    const float16 ex = exp(-g * dx * dx);
    const float16 ex2 = ex * ex;
    const float2 dy = cy + oy;
    const float4 dz = cz + oz;
    const float2 ey = exp(-g * dy * dy);
    const float4 ez = exp(-g * dz * dz);
    const float eyz[YR * ZR] = {ey.s0 * ez.s0, ey.s0 * ez.s1, ey.s0 * ez.s2, ey.s0 * ez.s3,
                                ey.s1 * ez.s0, ey.s1 * ez.s1, ey.s1 * ez.s2, ey.s1 * ez.s3};
    for (int r = 0; r < YR * ZR; ++r) {
      const float f = eyz[r], f2 = f * f;
      m[r] = fma((float16)(par.y * f), ex, m[r]);
      v[r] = fma((float16)(par.z * f2), ex2, v[r]);
      s[r] = fma((float16)(f2), ex2, s[r]);
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
