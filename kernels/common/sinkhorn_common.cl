// What kernels/ot/sinkhorn.cl and kernels/ot/sinkhorn_stab.cl share: build defaults, the real and
// vector types, the launch table and the point transform. Included by both (resolved when they
// are embedded, see cmake/EmbedKernels.cmake), never built alone.
//
// Types: REAL holds points, duals and costs (double with -DUSE_DOUBLE=1), REALV is a VW-wide
// vector of them; ACC holds the sums and scalings of the stabilised scheme (double with
// -DACC_DOUBLE=1 where the device has it), ACCV a VW-wide vector of those. Padded slots carry a
// log weight of -PAD_LOGW, so they add exp(-huge) = 0 to every sum.

#ifndef POTMAP_KERNELS_SINKHORN_COMMON_CL
#define POTMAP_KERNELS_SINKHORN_COMMON_CL

#ifndef DIM
#define DIM 2
#endif
#ifndef WG
#define WG 16
#endif
#ifndef USE_DOUBLE
#define USE_DOUBLE 0
#endif
#ifndef ACC_DOUBLE
#define ACC_DOUBLE 0
#endif

#if USE_DOUBLE || ACC_DOUBLE
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif
#if USE_DOUBLE
#define REAL double
#define VW 8
#define REALV double8
#define VLOAD vload8
#define VSTORE vstore8
#define PAD_LOGW 1e300
#else
#define REAL float
#define VW 16
#define REALV float16
#define VLOAD vload16
#define VSTORE vstore16
#define PAD_LOGW 1e30f
#endif
#if USE_DOUBLE || ACC_DOUBLE
#define ACC double
#else
#define ACC float
#endif
#if !USE_DOUBLE && ACC_DOUBLE
#define ACCV double16
#define TO_ACCV(x) convert_double16(x)
#define TO_REALV(x) convert_float16(x)
#else
#define ACCV REALV
#define TO_ACCV(x) (x)
#define TO_REALV(x) (x)
#endif
#if VW == 8
#define ACCLOAD vload8
#define ACCSTORE vstore8
#define LANES ((ACCV)(0, 1, 2, 3, 4, 5, 6, 7))
#define REAL_LANES ((REALV)(0, 1, 2, 3, 4, 5, 6, 7))
#else
#define ACCLOAD vload16
#define ACCSTORE vstore16
#define LANES ((ACCV)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#define REAL_LANES ((REALV)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#endif

#include "sinkhorn_launch.h"

// |p - q_j|^2 for the VW points from j of a structure-of-arrays buffer (qx, qy, qz; qz unread in
// 2D), in one vector.
static REALV dist2v(const REAL px, const REAL py, const REAL pz, __global const REAL* qx,
                    __global const REAL* qy, __global const REAL* qz, const int j) {
  REALV dx = VLOAD(0, qx + j) - px;
  REALV d2 = dx * dx;
  REALV dy = VLOAD(0, qy + j) - py;
  d2 = fma(dy, dy, d2);
#if DIM == 3
  REALV dz = VLOAD(0, qz + j) - pz;
  d2 = fma(dz, dz, d2);
#endif
  return d2;
}

// Point i of a structure-of-arrays buffer of `pad` slots per axis.
static void store_soa(__global REAL* S, const int pad, const int i, const REAL x, const REAL y,
                      const REAL z) {
  S[i] = x;
  S[pad + i] = y;
#if DIM == 3
  S[2 * pad + i] = z;
#endif
}

// Problem I's points from `src` and `tgt` (AoS) into SX and TX, its transformed source and target
// points: rotation about the centre (about the vertical axis in 3D), then the scale on both
// clouds; structure of arrays (DIM arrays of npad, resp. mpad, reals), pads at the origin.
static void transform_points(__global const float* src, __global const float* tgt,
                             __global const SinkhornLaunchInts* I,
                             __global const SinkhornLaunchParams* P, __global REAL* SX,
                             __global REAL* TX) {
  const int n = I->n, npad = I->npad, m = I->m, mpad = I->mpad;
  __global const float* X = src + (long)I->src * DIM;
  __global const float* Y = tgt + (long)I->tgt * DIM;
  const REAL scale = P->scale, c = P->cos_angle, s = P->sin_angle, cx = P->cx, cy = P->cy;
  for (int i = get_local_id(0); i < npad; i += WG) {
    REAL px = 0, py = 0, pz = 0;
    if (i < n) {
      const REAL ux = X[i * DIM + 0] - cx, uy = X[i * DIM + 1] - cy;
      px = scale * (cx + c * ux - s * uy);
      py = scale * (cy + s * ux + c * uy);
#if DIM == 3
      pz = scale * (REAL)X[i * DIM + 2];
#endif
    }
    store_soa(SX, npad, i, px, py, pz);
  }
  for (int j = get_local_id(0); j < mpad; j += WG) {
    REAL qx = 0, qy = 0, qz = 0;
    if (j < m) {
      qx = scale * (REAL)Y[j * DIM + 0];
      qy = scale * (REAL)Y[j * DIM + 1];
#if DIM == 3
      qz = scale * (REAL)Y[j * DIM + 2];
#endif
    }
    store_soa(TX, mpad, j, qx, qy, qz);
  }
}

// Adaptive over-relaxation of both schemes, at the end of each window of `win` iterations at
// the target epsilon: lambda, the observed decay of the error over the window, gives eta^2 by Young's
// relation and the optimal w from it; w only grows unless the error grew.
static void adapt_omega(const int it_target, const ACC tot, ACC* omega, ACC* ref_err, int* win,
                        int* mark) {
  if (*ref_err > 0) {
    const ACC lam = pow(tot / *ref_err, (ACC)1 / *win);
    if (lam < 1) {
      const ACC eta2 = (lam + *omega - 1) * (lam + *omega - 1) / (lam * *omega * *omega);
      const ACC wn = 2 / (1 + sqrt(fmax(1 - eta2, (ACC)1e-9)));
      *omega = fmax(*omega, fmin(wn, (ACC)1.95));
    } else if (tot > 2 * *ref_err) {
      *omega = fmax((ACC)1, (*omega + 1) / 2);
    }
  }
  *ref_err = tot;
  *win = it_target < 20 ? 5 : 20;
  *mark += *win;
}

#endif
