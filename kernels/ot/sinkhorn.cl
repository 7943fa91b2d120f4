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

#include "../common/sinkhorn_common.cl"

#if !USE_DOUBLE && ACC_DOUBLE
#error "sinkhorn.cl sums in REAL: ACC must be REAL (the host sets ACC_DOUBLE only for sinkhorn_stab)"
#endif

// The exponential of the inner loops (exp or native_exp; measured in bench/).
#ifndef EXPF
#define EXPF exp
#endif

// The sum of the lanes of v (sequential in double, pairwise in float).
static REAL hsum_real(const REALV v) {
#if USE_DOUBLE
  return v.s0 + v.s1 + v.s2 + v.s3 + v.s4 + v.s5 + v.s6 + v.s7;
#else
  return ((v.s0 + v.s1) + (v.s2 + v.s3)) + ((v.s4 + v.s5) + (v.s6 + v.s7)) +
         (((v.s8 + v.s9) + (v.sa + v.sb)) + ((v.sc + v.sd) + (v.se + v.sf)));
#endif
}

// Log-sum-exp over all VW-wide column blocks of one row (or column) of the scaled problem:
// lse_j (w_j - k |p - q_j|^2). `shift` is a guess of the result (the previous one); when the
// guess over- or underflows the sum, the row is redone with its true maximum. One exp per term
// in the common case instead of a max pass plus an exp pass.
static REAL row_lse(const REAL px, const REAL py, const REAL pz, __global const REAL* qx,
                    __global const REAL* qy, __global const REAL* qz, __global const REAL* w,
                    const int npad, const REAL k, const REAL shift) {
  REALV acc = (REALV)(0);
  for (int j = 0; j < npad; j += VW) {
    const REALV d2 = dist2v(px, py, pz, qx, qy, qz, j);
    acc += EXPF(fma(-k, d2, VLOAD(0, w + j) - shift));
  }
  REAL s = hsum_real(acc);
  if (s > (REAL)1e-25 && s < (REAL)1e25) return shift + log(s);
  // Guess far off: two passes with the exact maximum.
  REALV mx = (REALV)(-PAD_LOGW);
  for (int j = 0; j < npad; j += VW) {
    const REALV d2 = dist2v(px, py, pz, qx, qy, qz, j);
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
    const REALV d2 = dist2v(px, py, pz, qx, qy, qz, j);
    acc += EXPF(fma(-k, d2, VLOAD(0, w + j) - m));
  }
  s = hsum_real(acc);
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

// 1, or 1 / max C over the real (unpadded) pairs when the problem asks for a normalised cost.
static REAL cost_factor_of(__global const SinkhornLaunchParams* P, const int n, const int npad,
                           const int m, const int mpad, __global const REAL* SX,
                           __global const REAL* sz, __global const REAL* TX,
                           __global const REAL* tz, __local REAL* scratch) {
  REAL cost_factor = 1;
  if (P->normalise != 0) {
    REAL mx = 0;
    for (int i = get_local_id(0); i < n; i += WG) {
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
  return cost_factor;
}

// The f update with over-relaxation w, into FN (F keeps the plan being measured). Returns this
// work-item's part of that plan's 1-norm marginal error, which the row sums give for free.
static REAL update_f(const int n, const int npad, const int mpad, const REAL k, const REAL w,
                     __global const REAL* SX, __global const REAL* sz, __global const REAL* TX,
                     __global const REAL* tz, __global const REAL* G, __global const REAL* la,
                     __global const REAL* F, __global REAL* FN) {
  REAL e = 0;
  for (int i = get_local_id(0); i < n; i += WG) {
    const REAL old = F[i];
    const REAL shift = la[i] - old;  // the previous log-sum-exp of this row
    const REAL lse = row_lse(SX[i], SX[npad + i], sz[i], TX, TX + mpad, tz, G, mpad, k, shift);
    // Row sum of the plan (old f, g) is exp(old + lse).
    e += fabs(exp(old + lse) - exp(la[i]));
    FN[i] = (1 - w) * old + w * (la[i] - lse);
  }
  return e;
}

// The g update with over-relaxation w, in place.
static void update_g(const int m, const int npad, const int mpad, const REAL k, const REAL w,
                     __global const REAL* SX, __global const REAL* sz, __global const REAL* TX,
                     __global const REAL* tz, __global const REAL* F, __global const REAL* lb,
                     __global REAL* G) {
  for (int j = get_local_id(0); j < m; j += WG) {
    const REAL shift = lb[j] - G[j];
    const REAL lse = row_lse(TX[j], TX[mpad + j], tz[j], SX, SX + npad, sz, F, npad, k, shift);
    G[j] = (1 - w) * G[j] + w * (lb[j] - lse);
  }
}

// 1-norm marginal error of the plan (F, G), summed over the work-group.
static REAL plan_error(const int n, const int npad, const int mpad, const REAL k,
                       __global const REAL* SX, __global const REAL* sz, __global const REAL* TX,
                       __global const REAL* tz, __global const REAL* G, __global const REAL* la,
                       __global const REAL* F, __local REAL* scratch) {
  REAL e = 0;
  for (int i = get_local_id(0); i < n; i += WG) {
    const REAL lse =
        row_lse(SX[i], SX[npad + i], sz[i], TX, TX + mpad, tz, G, mpad, k, la[i] - F[i]);
    e += fabs(exp(F[i] + lse) - exp(la[i]));
  }
  return group_sum(e, scratch);
}

// <P, C>, the coupling (when I->plan >= 0) and the barycentric map of the plan (F, G), row by
// row. Returns this work-item's part of the cost; Y: the untransformed target points.
static REAL write_rows(__global const SinkhornLaunchInts* I, const REAL k, const REAL cost_factor,
                       __global const REAL* SX, __global const REAL* sz, __global const REAL* TX,
                       __global const REAL* tz, __global const float* Y, __global const REAL* F,
                       __global const REAL* G, __global float* plan, __global float* bary,
                       const int want_bary) {
  const int n = I->n, npad = I->npad, m = I->m, mpad = I->mpad;
  REAL total = 0;
  const long plan0 = I->plan;
  for (int i = get_local_id(0); i < n; i += WG) {
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
      if (plan0 >= 0) plan[plan0 + (long)j * n + i] = (float)pij;  // column-major
    }
    total += rc * cost_factor;
    if (want_bary) {
      const long o = ((long)I->src + i) * DIM;
      const REAL inv = rs > 0 ? 1 / rs : 0;
      bary[o + 0] = (float)(bx * inv);
      bary[o + 1] = (float)(by * inv);
#if DIM == 3
      bary[o + 2] = (float)(bz * inv);
#endif
    }
  }
  return total;
}

// src, tgt: input points (AoS). loga, logb: log marginals per padded slot (-PAD_LOGW on pads).
// sx, tx: transformed points, structure of arrays, DIM arrays of npad per problem.
// fh, gh, fnew: scaled duals per slot. out: the results per problem.
// plan: dense couplings (row-major n x m per problem) where I->plan >= 0.
// bary: barycentric image of each source point (DIM per source point, AoS, in target units).
__kernel __attribute__((reqd_work_group_size(WG, 1, 1))) void sinkhorn_solve(
    __global const float* src, __global const float* tgt, __global const SinkhornLaunchInts* ints,
    __global const SinkhornLaunchParams* params, __global const REAL* loga,
    __global const REAL* logb, __global REAL* sx, __global REAL* tx, __global REAL* fh,
    __global REAL* gh, __global REAL* fnew, __global SinkhornLaunchStats* out,
    __global float* plan, __global float* bary, const int want_bary) {
  __local REAL scratch[WG];
  const int p = get_group_id(0);
  const int lid = get_local_id(0);
  __global const SinkhornLaunchInts* I = ints + p;
  __global const SinkhornLaunchParams* P = params + p;
  const int n = I->n, npad = I->npad, m = I->m, mpad = I->mpad;
  const int ss = I->src_slot, ts = I->tgt_slot;
  __global REAL* SX = sx + (long)ss * DIM;
  __global REAL* TX = tx + (long)ts * DIM;
  __global const REAL* la = loga + ss;
  __global const REAL* lb = logb + ts;
  __global REAL* F = fh + ss;
  __global REAL* G = gh + ts;
  __global REAL* FN = fnew + ss;
  __global const float* Y = tgt + (long)I->tgt * DIM;  // untransformed, for the barycentric map

  const REAL eps = P->eps, tol = P->tol;
  const int max_it = I->max_it;
  const int check = max((int)P->check, 1);

  // Transform the points once per launch (pads sit at the origin with weight zero); the duals
  // start at f = g = 0, i.e. fh = log a, gh = log b.
  transform_points(src, tgt, I, P, SX, TX);
  for (int i = lid; i < npad; i += WG) F[i] = la[i];
  for (int j = lid; j < mpad; j += WG) G[j] = lb[j];
  barrier(CLK_GLOBAL_MEM_FENCE);

  __global const REAL* sz = SX + (DIM == 3 ? 2 * npad : 0);
  __global const REAL* tz = TX + (DIM == 3 ? 2 * mpad : 0);
  const REAL cost_factor = cost_factor_of(P, n, npad, m, mpad, SX, sz, TX, tz, scratch);

  // Epsilon schedule: eps0, eps0 * decay, ... down to eps, one iteration each, then iterations
  // at eps until converged or max_it. Duals carry over between levels (rescaled to the new eps).
  REAL cur_eps = P->eps0 > eps ? (REAL)P->eps0 : eps;
  const REAL decay = P->decay;
  int it = 0, it_target = 0;
  REAL err = INFINITY;
  int converged = 0;
  // Over-relaxation f <- (1-w) f + w f_sinkhorn at the target epsilon; w adapted as in
  // sinkhorn_stab.cl (adapt_omega), or fixed when P->omega > 0.
  const REAL omega_fixed = P->omega;
  REAL omega = 1.3f, ref_err = -1;
  int mark = 5, win = 5;
  while (1) {
    const REAL k = cost_factor / cur_eps;
    const int at_target = cur_eps <= eps;
    if (at_target && it_target >= max_it) break;
    const int checking = at_target && it_target > 0 && (it_target % check == 0);
    const REAL w = at_target ? (omega_fixed > 0 ? (REAL)omega_fixed : omega) : (REAL)1;
    // The new f goes to FN first so that the plan that was measured (old f, current g) is the
    // one kept if it has converged. The reduction runs on every iteration, outside any branch:
    // barriers under a uniform condition after a loop that some work-items skip (n < WG) gave
    // wrong results on PoCL 3.1 here (cause not narrowed down).
    const REAL e = update_f(n, npad, mpad, k, w, SX, sz, TX, tz, G, la, F, FN);
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
    update_g(m, npad, mpad, k, w, SX, sz, TX, tz, F, lb, G);
    barrier(CLK_GLOBAL_MEM_FENCE);
    ++it;
    if (at_target) {
      ++it_target;
      if (omega_fixed <= 0 && it_target == mark)
        adapt_omega(it_target, total_e, &omega, &ref_err, &win, &mark);
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
  // Error of the final plan when the limit stopped it: measured, not assumed. Unconditional for
  // the same PoCL reason as above; only used when the limit stopped it.
  const REAL k = cost_factor / cur_eps;
  const REAL final_err = plan_error(n, npad, mpad, k, SX, sz, TX, tz, G, la, F, scratch);
  if (!converged) {
    err = final_err;
    // The limit was reached: converged only if the plan handed back meets the tolerance.
    converged = err < tol ? 1 : 0;
  }

  const REAL total = group_sum(
      write_rows(I, k, cost_factor, SX, sz, TX, tz, Y, F, G, plan, bary, want_bary), scratch);
  if (lid == 0) {
    out[p].cost = (float)total;
    out[p].iterations = (float)it;
    out[p].marginal_error = (float)err;
    out[p].converged = (float)converged;
  }
}
