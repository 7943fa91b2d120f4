// Per-sample sums of the ABHM likelihood gradient (SPEC section 3) for one reparameterised
// draw, with kernel locality: the host lists, for every sample, the drawn kernels within the
// cut-off and, for every kernel, the samples it reaches. Two passes so that nothing needs
// atomics: samples first (f_n and d loss / d f_n), then kernels (their gradient sums).
// Positions are float, relative to the batch centre: ABHM works on small areas.

#ifndef DIM
#define DIM 2
#endif

// One work-item per sample: f_n, its log-likelihood and d loss / d f_n = -scale (y - sigmoid f).
__kernel void abhm_forward(__global const float* kpos, __global const float* kgamma,
                           __global const float* kw, __global const float* spos,
                           __global const float* sy, __global const uint* sstart,
                           __global const uint* slist, uint nsamples, float bias, float scale,
                           __global float* out_gf, __global float* out_ll) {
  const uint i = get_global_id(0);
  if (i >= nsamples) return;
  float f = bias;
  for (uint j = sstart[i]; j < sstart[i + 1]; ++j) {
    const uint k = slist[j];
    float d2 = 0.0f;
    for (int d = 0; d < DIM; ++d) {
      const float t = spos[i * DIM + d] - kpos[k * DIM + d];
      d2 = fma(t, t, d2);
    }
    f = fma(kw[k], exp(-kgamma[k] * d2), f);
  }
  const float y = sy[i];
  // log(1 + e^f) without overflow.
  const float l1pe = f > 0.0f ? f + log1p(exp(-f)) : log1p(exp(f));
  out_ll[i] = y * f - l1pe;
  out_gf[i] = -scale * (y - 1.0f / (1.0f + exp(-f)));
}

// One work-item per kernel: d loss / d w, d loss / d gamma and d loss / d h (DIM values).
__kernel void abhm_backward(__global const float* kpos, __global const float* kgamma,
                            __global const float* kw, __global const float* spos,
                            __global const float* gf, __global const uint* kstart,
                            __global const uint* klist, uint nkernels, __global float* out_dw,
                            __global float* out_dg, __global float* out_dh) {
  const uint k = get_global_id(0);
  if (k >= nkernels) return;
  const float g = kgamma[k], w = kw[k];
  float dw = 0.0f, dg = 0.0f, dh[DIM];
  for (int d = 0; d < DIM; ++d) dh[d] = 0.0f;
  for (uint j = kstart[k]; j < kstart[k + 1]; ++j) {
    const uint i = klist[j];
    float diff[DIM], d2 = 0.0f;
    for (int d = 0; d < DIM; ++d) {
      diff[d] = spos[i * DIM + d] - kpos[k * DIM + d];
      d2 = fma(diff[d], diff[d], d2);
    }
    const float t = gf[i] * exp(-g * d2);
    dw += t;
    dg = fma(-t * w, d2, dg);
    for (int d = 0; d < DIM; ++d) dh[d] = fma(2.0f * t * g * w, diff[d], dh[d]);
  }
  out_dw[k] = dw;
  out_dg[k] = dg;
  for (int d = 0; d < DIM; ++d) out_dh[k * DIM + d] = dh[d];
}
