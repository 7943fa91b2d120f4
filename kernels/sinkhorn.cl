// Batched log-domain Sinkhorn with an "online" squared Euclidean cost.
//
// One work-group solves one problem from start to finish: problems are independent, so a
// converged problem simply leaves the loop and its core moves on to the next work-group, and no
// host round trip is needed per iteration. The cost is recomputed from the points inside every
// log-sum-exp and never stored, so memory grows with n + m, not n * m.
//
// Scaled duals are kept: fh_i = f_i / eps + log a_i, gh_j = g_j / eps + log b_j, and with
// k = cost_factor / eps every term of a reduction is gh_j - k * |x_i - y_j|^2, a multiply-add.
// The inner loops run over VW columns at a time in explicit vectors (PoCL vectorises those far
// better than scalar work-items, SPEC section 6).
//
// Padding: every problem's points are laid out structure-of-arrays, padded to a multiple of VW;
// padded slots carry a log weight of -PAD_LOGW, so they add exp(-huge) = 0 to every sum and are
// never written as results.

#ifndef DIM
#define DIM 2
#endif
#ifndef WG
#define WG 16
#endif
#ifndef USE_DOUBLE
#define USE_DOUBLE 0
#endif
// The exponential of the inner loops (exp or native_exp; measured in bench/).
#ifndef EXPF
#define EXPF exp
#endif

#if USE_DOUBLE
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
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

// Per-problem integer layout (NI ints per problem).
#define I_SRC 0      // first source point in `src` (points, AoS, DIM floats each)
#define I_N 1        // number of source points
#define I_SSLOT 2    // first slot of this problem in the padded source arrays
#define I_NPAD 3     // padded number of source slots (multiple of VW)
#define I_TGT 4      // first target point in `tgt`
#define I_M 5        // number of target points
#define I_TSLOT 6    // first slot in the padded target arrays
#define I_MPAD 7     // padded number of target slots
#define I_PLAN 8     // first element of the coupling in `plan`, or -1 for none
#define I_MAXIT 9    // iteration limit at the target epsilon
#define I_KOFF 10    // first element of the stored kernel matrix (sinkhorn_stab.cl only)
#define NI 11

// Per-problem real parameters (NP floats per problem).
#define P_EPS 0
#define P_TOL 1
#define P_COS 2
#define P_SIN 3
#define P_CX 4
#define P_CY 5
#define P_CZ 6
#define P_SCALE 7
#define P_NORMALISE 8   // 1: divide the cost by its maximum over the problem
#define P_EPS0 9        // first epsilon of the annealing schedule (<= eps: none)
#define P_DECAY 10      // factor between successive epsilons of the schedule, in (0, 1)
#define P_CHECK 11      // check convergence every this many iterations
#define P_OMEGA 12      // over-relaxation: 0 adaptive, else the fixed factor in [1, 2)
#define NP 13

// Results per problem (NR floats): <P, C>, iterations, marginal error, converged (0/1).
#define NR 4

// Log-sum-exp over all VW-wide column blocks of one row (or column) of the scaled problem:
// lse_j (w_j - k |p - q_j|^2). `shift` is a guess of the result (the previous one); when the
// guess over- or underflows the sum, the row is redone with its true maximum. One exp per term
// in the common case instead of a max pass plus an exp pass.
static REAL row_lse(const REAL px, const REAL py, const REAL pz, __global const REAL* qx,
                    __global const REAL* qy, __global const REAL* qz, __global const REAL* w,
                    const int npad, const REAL k, const REAL shift) {
  REALV acc = (REALV)(0);
  for (int j = 0; j < npad; j += VW) {
    REALV dx = VLOAD(0, qx + j) - px;
    REALV d2 = dx * dx;
    REALV dy = VLOAD(0, qy + j) - py;
    d2 = fma(dy, dy, d2);
#if DIM == 3
    REALV dz = VLOAD(0, qz + j) - pz;
    d2 = fma(dz, dz, d2);
#endif
    acc += EXPF(fma(-k, d2, VLOAD(0, w + j) - shift));
  }
  REAL s = 0;
#if USE_DOUBLE
  s = acc.s0 + acc.s1 + acc.s2 + acc.s3 + acc.s4 + acc.s5 + acc.s6 + acc.s7;
#else
  s = ((acc.s0 + acc.s1) + (acc.s2 + acc.s3)) + ((acc.s4 + acc.s5) + (acc.s6 + acc.s7)) +
      (((acc.s8 + acc.s9) + (acc.sa + acc.sb)) + ((acc.sc + acc.sd) + (acc.se + acc.sf)));
#endif
  if (s > (REAL)1e-25 && s < (REAL)1e25) return shift + log(s);
  // Guess far off: two passes with the exact maximum.
  REALV mx = (REALV)(-PAD_LOGW);
  for (int j = 0; j < npad; j += VW) {
    REALV dx = VLOAD(0, qx + j) - px;
    REALV d2 = dx * dx;
    REALV dy = VLOAD(0, qy + j) - py;
    d2 = fma(dy, dy, d2);
#if DIM == 3
    REALV dz = VLOAD(0, qz + j) - pz;
    d2 = fma(dz, dz, d2);
#endif
    mx = fmax(mx, fma(-k, d2, VLOAD(0, w + j)));
  }
  REAL m = mx.s0;
#if USE_DOUBLE
  m = fmax(fmax(fmax(mx.s0, mx.s1), fmax(mx.s2, mx.s3)), fmax(fmax(mx.s4, mx.s5), fmax(mx.s6, mx.s7)));
#else
  m = fmax(fmax(fmax(fmax(mx.s0, mx.s1), fmax(mx.s2, mx.s3)),
                fmax(fmax(mx.s4, mx.s5), fmax(mx.s6, mx.s7))),
           fmax(fmax(fmax(mx.s8, mx.s9), fmax(mx.sa, mx.sb)),
                fmax(fmax(mx.sc, mx.sd), fmax(mx.se, mx.sf))));
#endif
  acc = (REALV)(0);
  for (int j = 0; j < npad; j += VW) {
    REALV dx = VLOAD(0, qx + j) - px;
    REALV d2 = dx * dx;
    REALV dy = VLOAD(0, qy + j) - py;
    d2 = fma(dy, dy, d2);
#if DIM == 3
    REALV dz = VLOAD(0, qz + j) - pz;
    d2 = fma(dz, dz, d2);
#endif
    acc += EXPF(fma(-k, d2, VLOAD(0, w + j) - m));
  }
#if USE_DOUBLE
  s = acc.s0 + acc.s1 + acc.s2 + acc.s3 + acc.s4 + acc.s5 + acc.s6 + acc.s7;
#else
  s = ((acc.s0 + acc.s1) + (acc.s2 + acc.s3)) + ((acc.s4 + acc.s5) + (acc.s6 + acc.s7)) +
      (((acc.s8 + acc.s9) + (acc.sa + acc.sb)) + ((acc.sc + acc.sd) + (acc.se + acc.sf)));
#endif
  return m + log(s);
}

// Sum over the work-group; every work-item gets the total. `scratch` holds WG reals.
static REAL group_sum(REAL v, __local REAL* scratch) {
  const int lid = get_local_id(0);
  scratch[lid] = v;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int s = WG / 2; s > 0; s >>= 1) {
    if (lid < s) scratch[lid] += scratch[lid + s];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  REAL r = scratch[0];
  barrier(CLK_LOCAL_MEM_FENCE);
  return r;
}

static REAL group_max(REAL v, __local REAL* scratch) {
  const int lid = get_local_id(0);
  scratch[lid] = v;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int s = WG / 2; s > 0; s >>= 1) {
    if (lid < s) scratch[lid] = fmax(scratch[lid], scratch[lid + s]);
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  REAL r = scratch[0];
  barrier(CLK_LOCAL_MEM_FENCE);
  return r;
}

// src, tgt: input points (AoS). loga, logb: log marginals per padded slot (-PAD_LOGW on pads).
// sx, tx: transformed points, structure of arrays, DIM arrays of npad per problem.
// fh, gh, fnew: scaled duals per slot. out: NR results per problem.
// plan: dense couplings (row-major n x m per problem) where I_PLAN >= 0.
// bary: barycentric image of each source point (DIM per source point, AoS, in target units).
__kernel __attribute__((reqd_work_group_size(WG, 1, 1))) void sinkhorn_solve(
    __global const float* src, __global const float* tgt, __global const int* ints,
    __global const float* params, __global const REAL* loga, __global const REAL* logb,
    __global REAL* sx, __global REAL* tx, __global REAL* fh, __global REAL* gh,
    __global REAL* fnew, __global float* out, __global float* plan, __global float* bary,
    const int want_bary) {
  __local REAL scratch[WG];
  const int p = get_group_id(0);
  const int lid = get_local_id(0);
  __global const int* I = ints + p * NI;
  __global const float* P = params + p * NP;
  const int n = I[I_N], npad = I[I_NPAD], m = I[I_M], mpad = I[I_MPAD];
  const int ss = I[I_SSLOT], ts = I[I_TSLOT];
  __global const float* X = src + (long)I[I_SRC] * DIM;
  __global const float* Y = tgt + (long)I[I_TGT] * DIM;
  __global REAL* SX = sx + (long)ss * DIM;
  __global REAL* TX = tx + (long)ts * DIM;
  __global const REAL* la = loga + ss;
  __global const REAL* lb = logb + ts;
  __global REAL* F = fh + ss;
  __global REAL* G = gh + ts;
  __global REAL* FN = fnew + ss;

  const REAL eps = P[P_EPS], tol = P[P_TOL], scale = P[P_SCALE];
  const REAL c = P[P_COS], s = P[P_SIN];
  const REAL cx = P[P_CX], cy = P[P_CY], cz = P[P_CZ];
  const int max_it = I[I_MAXIT];
  const int check = max((int)P[P_CHECK], 1);

  // Transform the points once per launch: rotation about the centre (about the vertical axis in
  // 3D), then the scale applied to both clouds. Pads sit at the origin with weight zero.
  for (int i = lid; i < npad; i += WG) {
    REAL px = 0, py = 0, pz = 0;
    if (i < n) {
      const REAL ux = X[i * DIM + 0] - cx, uy = X[i * DIM + 1] - cy;
      px = scale * (cx + c * ux - s * uy);
      py = scale * (cy + s * ux + c * uy);
#if DIM == 3
      pz = scale * (REAL)X[i * DIM + 2];
#endif
    }
    SX[i] = px;
    SX[npad + i] = py;
#if DIM == 3
    SX[2 * npad + i] = pz;
#endif
    F[i] = la[i];
  }
  for (int j = lid; j < mpad; j += WG) {
    REAL qx = 0, qy = 0, qz = 0;
    if (j < m) {
      qx = scale * (REAL)Y[j * DIM + 0];
      qy = scale * (REAL)Y[j * DIM + 1];
#if DIM == 3
      qz = scale * (REAL)Y[j * DIM + 2];
#endif
    }
    TX[j] = qx;
    TX[mpad + j] = qy;
#if DIM == 3
    TX[2 * mpad + j] = qz;
#endif
    G[j] = lb[j];
  }
  barrier(CLK_GLOBAL_MEM_FENCE);

  __global const REAL* sz = SX + (DIM == 3 ? 2 * npad : 0);
  __global const REAL* tz = TX + (DIM == 3 ? 2 * mpad : 0);

  // Cost factor: 1, or 1 / max C over the real (unpadded) pairs.
  REAL cost_factor = 1;
  if (P[P_NORMALISE] != 0) {
    REAL mx = 0;
    for (int i = lid; i < n; i += WG) {
      for (int j = 0; j < m; ++j) {
        REAL dx = SX[i] - TX[j], dy = SX[npad + i] - TX[mpad + j];
        REAL d2 = dx * dx + dy * dy;
#if DIM == 3
        REAL dz = sz[i] - tz[j];
        d2 += dz * dz;
#endif
        mx = fmax(mx, d2);
      }
    }
    mx = group_max(mx, scratch);
    if (mx > 0) cost_factor = 1 / mx;
  }

  // Epsilon schedule: eps0, eps0 * decay, ... down to eps, one iteration each, then iterations
  // at eps until converged or max_it. Duals carry over between levels (rescaled to the new eps).
  REAL cur_eps = P[P_EPS0] > eps ? (REAL)P[P_EPS0] : eps;
  const REAL decay = P[P_DECAY];
  int it = 0, it_target = 0;
  REAL err = INFINITY;
  int converged = 0;
  // Over-relaxation f <- (1-w) f + w f_sinkhorn at the target epsilon; w adapted as in
  // sinkhorn_stab.cl (see there), or fixed when P_OMEGA > 0.
  const REAL omega_fixed = P[P_OMEGA];
  REAL omega = 1.3f, ref_err = -1;
  int mark = 5, win = 5;
  while (1) {
    const REAL k = cost_factor / cur_eps;
    const int at_target = cur_eps <= eps;
    if (at_target && it_target >= max_it) break;
    const int checking = at_target && it_target > 0 && (it_target % check == 0);
    const REAL w = at_target ? (omega_fixed > 0 ? (REAL)omega_fixed : omega) : (REAL)1;
    // f update. The new value goes to FN first so that the plan that was measured (old f,
    // current g) is the one kept if it has converged. The reduction runs on every iteration,
    // outside any branch: barriers under a uniform condition after a loop that some work-items
    // skip (n < WG) gave wrong results on PoCL 3.1 here (cause not narrowed down).
    REAL e = 0;
    for (int i = lid; i < n; i += WG) {
      const REAL old = F[i];
      const REAL shift = la[i] - old;  // the previous log-sum-exp of this row
      const REAL lse = row_lse(SX[i], SX[npad + i], sz[i], TX, TX + mpad, tz, G, mpad, k, shift);
      // Row sum of the plan (old f, g) is exp(old + lse): the error comes for free here.
      e += fabs(exp(old + lse) - exp(la[i]));
      FN[i] = (1 - w) * old + w * (la[i] - lse);
    }
    const REAL total_e = group_sum(e, scratch);
    if (checking) {
      err = total_e;
      if (err < tol) {
        converged = 1;
        break;
      }
    }
    for (int i = lid; i < n; i += WG) F[i] = FN[i];
    barrier(CLK_GLOBAL_MEM_FENCE);
    // g update.
    for (int j = lid; j < m; j += WG) {
      const REAL shift = lb[j] - G[j];
      const REAL lse =
          row_lse(TX[j], TX[mpad + j], tz[j], SX, SX + npad, sz, F, npad, k, shift);
      G[j] = (1 - w) * G[j] + w * (lb[j] - lse);
    }
    barrier(CLK_GLOBAL_MEM_FENCE);
    ++it;
    if (at_target) {
      ++it_target;
      if (omega_fixed <= 0 && it_target == mark) {
        if (ref_err > 0) {
          const REAL lam = pow(total_e / ref_err, (REAL)1 / win);
          if (lam < 1) {
            const REAL eta2 = (lam + omega - 1) * (lam + omega - 1) / (lam * omega * omega);
            omega = fmax(omega, fmin(2 / (1 + sqrt(fmax(1 - eta2, (REAL)1e-9))), (REAL)1.95));
          } else if (total_e > 2 * ref_err) {
            omega = fmax((REAL)1, (omega + 1) / 2);
          }
        }
        ref_err = total_e;
        win = it_target < 20 ? 5 : 20;
        mark += win;
      }
    } else {
      // Next epsilon level: the unscaled duals stay, the scaled ones follow the new epsilon.
      const REAL next = fmax(cur_eps * decay, eps);
      const REAL r = cur_eps / next;
      for (int i = lid; i < n; i += WG) F[i] = (F[i] - la[i]) * r + la[i];
      for (int j = lid; j < m; j += WG) G[j] = (G[j] - lb[j]) * r + lb[j];
      cur_eps = next;
      barrier(CLK_GLOBAL_MEM_FENCE);
    }
  }
  // Error of the final plan when the limit stopped it: measured, not assumed.
  {
    // Unconditional for the same PoCL reason as above; only used when the limit stopped it.
    const REAL k = cost_factor / cur_eps;
    REAL e = 0;
    for (int i = lid; i < n; i += WG) {
      const REAL lse = row_lse(SX[i], SX[npad + i], sz[i], TX, TX + mpad, tz, G, mpad, k,
                               la[i] - F[i]);
      e += fabs(exp(F[i] + lse) - exp(la[i]));
    }
    e = group_sum(e, scratch);
    if (!converged) {
      err = e;
      // The limit was reached: converged only if the plan handed back meets the tolerance.
      converged = err < tol ? 1 : 0;
    }
  }

  // <P, C>, the coupling and the barycentric map, row by row.
  const REAL k = cost_factor / cur_eps;
  REAL total = 0;
  const long plan0 = I[I_PLAN];
  for (int i = lid; i < n; i += WG) {
    REAL rs = 0, rc = 0, bx = 0, by = 0, bz = 0;
    const REAL pxi = SX[i], pyi = SX[npad + i], pzi = sz[i];
    for (int j = 0; j < m; ++j) {
      REAL dx = pxi - TX[j], dy = pyi - TX[mpad + j];
      REAL d2 = dx * dx + dy * dy;
#if DIM == 3
      REAL dz = pzi - tz[j];
      d2 += dz * dz;
#endif
      const REAL pij = exp(F[i] + G[j] - k * d2);
      rs += pij;
      rc += pij * d2;
      bx += pij * Y[j * DIM + 0];
      by += pij * Y[j * DIM + 1];
#if DIM == 3
      bz += pij * Y[j * DIM + 2];
#endif
      if (plan0 >= 0) plan[plan0 + (long)i * m + j] = (float)pij;
    }
    total += rc * cost_factor;
    if (want_bary) {
      const long o = ((long)I[I_SRC] + i) * DIM;
      const REAL inv = rs > 0 ? 1 / rs : 0;
      bary[o + 0] = (float)(bx * inv);
      bary[o + 1] = (float)(by * inv);
#if DIM == 3
      bary[o + 2] = (float)(bz * inv);
#endif
    }
  }
  total = group_sum(total, scratch);
  if (lid == 0) {
    out[p * NR + 0] = (float)total;
    out[p * NR + 1] = (float)it;
    out[p * NR + 2] = (float)err;
    out[p * NR + 3] = (float)converged;
  }
}
