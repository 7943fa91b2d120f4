// Sums over samples of the BHM update (SPEC section 3), using kernel locality: the host lists,
// for every kernel, the samples within its cut-off and, for every sample, the kernels within
// reach, so each work-item only visits pairs that contribute.
//
// Positions arrive relative to an anchor near the data and split into two floats (hi + lo), so
// differences keep float's relative precision in large world frames.

#ifndef DIM
#define DIM 2
#endif

inline float sq_dist(__global const float* ahi, __global const float* alo, uint a,
                     __global const float* bhi, __global const float* blo, uint b) {
  float d2 = 0.0f;
  for (int d = 0; d < DIM; ++d) {
    const float t = (ahi[a * DIM + d] - bhi[b * DIM + d]) + (alo[a * DIM + d] - blo[b * DIM + d]);
    d2 = fma(t, t, d2);
  }
  return d2;
}

// One work-item per kernel: sum_n lambda_n phi_nk^2 and sum_n (y_n - 1/2) phi_nk.
__kernel void bhm_accumulate(__global const float* khi, __global const float* klo,
                             __global const float* kgamma, __global const float* shi,
                             __global const float* slo, __global const float* sy,
                             __global const float* slambda, __global const uint* kstart,
                             __global const uint* klist, uint nkernels,
                             __global float* out_a, __global float* out_b) {
  const uint k = get_global_id(0);
  if (k >= nkernels) return;
  const float g = kgamma[k];
  float a = 0.0f, b = 0.0f;
  for (uint j = kstart[k]; j < kstart[k + 1]; ++j) {
    const uint i = klist[j];
    const float phi = exp(-g * sq_dist(khi, klo, k, shi, slo, i));
    a = fma(slambda[i] * phi, phi, a);
    b = fma(sy[i], phi, b);
  }
  out_a[k] = a;
  out_b[k] = b;
}

// One work-item per sample: the M-step, xi^2 = s2 + mu^2, returned as lambda(xi).
__kernel void bhm_lambda(__global const float* khi, __global const float* klo,
                         __global const float* kgamma, __global const float* kmean,
                         __global const float* kvar, __global const float* shi,
                         __global const float* slo, __global const uint* sstart,
                         __global const uint* slist, uint nsamples, float bias_mean,
                         float bias_var, __global float* out_lambda) {
  const uint i = get_global_id(0);
  if (i >= nsamples) return;
  float mu = bias_mean, s2 = bias_var;
  for (uint j = sstart[i]; j < sstart[i + 1]; ++j) {
    const uint k = slist[j];
    const float phi = exp(-kgamma[k] * sq_dist(khi, klo, k, shi, slo, i));
    mu = fma(kmean[k], phi, mu);
    s2 = fma(kvar[k] * phi, phi, s2);
  }
  const float xi = sqrt(s2 + mu * mu);
  // lambda(0) = 1/8; below 1e-3 the series is exact in float where the formula cancels.
  out_lambda[i] = xi < 1e-3f ? 0.125f - xi * xi / 96.0f : (1.0f / (1.0f + exp(-xi)) - 0.5f) / (2.0f * xi);
}
