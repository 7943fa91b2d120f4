// Occupancy map evaluation at arbitrary query points (SPEC section 2).
//
// Queries arrive sorted into spatial chunks of CHUNK points; every chunk has its own list of the
// kernels whose cut-off reaches the chunk's bounding box (built on the host). A work-item holds
// VEC queries in vector registers: PoCL vectorises explicit vector types far better than
// scalar work-items (SPEC section 6).
//
// Every kernel in a chunk's list contributes in full to all the chunk's points (the list holds
// the kernels whose cut-off reaches the chunk's box): no per-point cut, which is closer to the
// exact sum. Build with -cl-denorms-are-zero, as tiny terms are common.
//
// Precision: positions travel as two floats (hi + lo) so that coordinate differences keep their
// relative precision in any world frame; sums are taken in blocks of BLOCK kernels in plain
// float and the block sums are added with Neumaier's compensated summation.

#ifndef DIM
#define DIM 2
#endif
#ifndef VEC
#define VEC 16
#endif
#ifndef BLOCK
#define BLOCK 16
#endif
#ifndef TAU
#define TAU 18.0f
#endif

#if VEC == 16
typedef float16 floatv;
typedef int16 intv;
#define vloadv vload16
#define vstorev vstore16
#elif VEC == 8
typedef float8 floatv;
typedef int8 intv;
#define vloadv vload8
#define vstorev vstore8
#elif VEC == 4
typedef float4 floatv;
typedef int4 intv;
#define vloadv vload4
#define vstorev vstore4
#else
#error "VEC must be 4, 8 or 16"
#endif

#include "../common/map_math.cl"

#define NEUMAIER_ADD(s, c, x) NEUMAIER_ADD_T(floatv, s, c, x)

// kpos_hi/kpos_lo: DIM floats per kernel (hi and lo parts of the position relative to the map
// anchor); kpar: gamma, w_mean, w_var, unused, per kernel.
// q_hi/q_lo: DIM arrays of padded length, structure of arrays (q_hi[d * stride + i]).
// chunk_start[c]..chunk_start[c+1]: the slice of list[] that chunk c visits.
// order[i]: where sorted query i goes in the caller's output arrays (-1 for padding).
__kernel void map_eval_points(__global const float* kpos_hi, __global const float* kpos_lo,
                              __global const float4* kpar, __global const float* q_hi,
                              __global const float* q_lo, const uint stride,
                              __global const uint* chunk_start, __global const uint* list,
                              __global const int* order, const float bias_mean,
                              const float bias_var, __global float* out_mean,
                              __global float* out_var, __global float* out_prob) {
  const uint chunk = get_group_id(0);
  const uint first = (chunk * get_local_size(0) + get_local_id(0)) * VEC;

  floatv qh[DIM], ql[DIM];
  for (int d = 0; d < DIM; ++d) {
    qh[d] = vloadv(0, q_hi + d * stride + first);
    ql[d] = vloadv(0, q_lo + d * stride + first);
  }

  floatv mean_s = (floatv)(0.0f), mean_c = (floatv)(0.0f);
  floatv var_s = (floatv)(0.0f), var_c = (floatv)(0.0f);
  const uint begin = chunk_start[chunk], end = chunk_start[chunk + 1];
  for (uint b = begin; b < end; b += BLOCK) {
    const uint stop = min(end, b + (uint)BLOCK);
    floatv mean_b = (floatv)(0.0f), var_b = (floatv)(0.0f);
    for (uint e = b; e < stop; ++e) {
      const uint k = list[e];
      const float4 par = kpar[k];
      floatv d2 = (floatv)(0.0f);
      for (int d = 0; d < DIM; ++d) {
        const floatv diff = (qh[d] - kpos_hi[k * DIM + d]) + (ql[d] - kpos_lo[k * DIM + d]);
        d2 = fma(diff, diff, d2);
      }
      const floatv a = par.x * d2;
      const floatv phi = exp(-a);
      mean_b = fma((floatv)(par.y), phi, mean_b);
      var_b = fma((floatv)(par.z), phi * phi, var_b);
    }
    NEUMAIER_ADD(mean_s, mean_c, mean_b);
    NEUMAIER_ADD(var_s, var_c, var_b);
  }
  const floatv mean = (mean_s + mean_c) + bias_mean;
  const floatv var = (var_s + var_c) + bias_var;
  const floatv prob = OCCUPANCY_PROB(mean, var);

  float m[VEC], v[VEC], p[VEC];
  vstorev(mean, 0, m);
  vstorev(var, 0, v);
  vstorev(prob, 0, p);
  for (int i = 0; i < VEC; ++i) {
    const int dst = order[first + i];
    if (dst < 0) continue;
    if (out_mean) out_mean[dst] = m[i];
    if (out_var) out_var[dst] = v[i];
    if (out_prob) out_prob[dst] = p[i];
  }
}
