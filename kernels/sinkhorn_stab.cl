// Batched Sinkhorn, stabilised scheme: the kernel matrix K_ij = exp(al_i + be_j - k C_ij) is
// stored per problem and the iterations are plain scalings u = a / (K v), v = b / (K^T u), a
// multiply-add per entry instead of an exp. The duals are absorbed into the log domain (al, be)
// and K rebuilt only when u or v leave [e^-ABSORB, e^ABSORB] or epsilon changes, so the result is
// the log-domain one (same fixed point) at a fraction of the exps. Same layout and arguments as
// sinkhorn.cl (its header comment explains them), plus the K, u and v storage.
//
// Original notes of the log-domain kernel this shares its layout with:
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
#define I_KOFF 10    // first element of this problem's kernel matrix (stabilised solver only)
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
#define NP 12

// Results per problem (NR floats): <P, C>, iterations, marginal error, converged (0/1).
#define NR 4

#ifndef ABSORB
#define ABSORB 25
#endif

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

static REAL dist2(const REAL px, const REAL py, const REAL pz, const REAL qx, const REAL qy,
                  const REAL qz) {
  REAL dx = px - qx, dy = py - qy;
  REAL d2 = dx * dx + dy * dy;
#if DIM == 3
  REAL dz = pz - qz;
  d2 += dz * dz;
#endif
  return d2;
}

// Kernel matrix rows of this work-item: K_ij = exp(AL_i + BE_j - k d2_ij); pads have BE = -big.
static void build_k(__global REAL* K, const int n, const int mpad, __global const REAL* SX,
                    const int npad, __global const REAL* sz, __global const REAL* TX,
                    __global const REAL* tz, __global const REAL* AL, __global const REAL* BE,
                    const REAL k) {
  for (int i = get_local_id(0); i < n; i += WG) {
    const REAL px = SX[i], py = SX[npad + i], pz = sz[i], al = AL[i];
    for (int j = 0; j < mpad; j += VW) {
      REALV dx = VLOAD(0, TX + j) - px;
      REALV d2 = dx * dx;
      REALV dy = VLOAD(0, TX + mpad + j) - py;
      d2 = fma(dy, dy, d2);
#if DIM == 3
      REALV dz = VLOAD(0, tz + j) - pz;
      d2 = fma(dz, dz, d2);
#endif
      VSTORE(exp(fma(-k, d2, VLOAD(0, BE + j) + al)), 0, K + (long)i * mpad + j);
    }
  }
}

static REAL hsum(REALV v) {
#if USE_DOUBLE
  return v.s0 + v.s1 + v.s2 + v.s3 + v.s4 + v.s5 + v.s6 + v.s7;
#else
  return ((v.s0 + v.s1) + (v.s2 + v.s3)) + ((v.s4 + v.s5) + (v.s6 + v.s7)) +
         (((v.s8 + v.s9) + (v.sa + v.sb)) + ((v.sc + v.sd) + (v.se + v.sf)));
#endif
}

// Arguments as sinkhorn_solve; fh, gh hold the absorbed duals al, be during the solve and the
// scaled duals (f/eps + log a convention) at the end. kmat: K per problem (n x mpad); ub, vb,
// un: scalings per slot.
__kernel __attribute__((reqd_work_group_size(WG, 1, 1))) void sinkhorn_stab_solve(
    __global const float* src, __global const float* tgt, __global const int* ints,
    __global const float* params, __global const REAL* loga, __global const REAL* logb,
    __global REAL* sx, __global REAL* tx, __global REAL* fh, __global REAL* gh,
    __global REAL* un, __global float* out, __global float* plan, __global float* bary,
    const int want_bary, __global REAL* kmat, __global REAL* ub, __global REAL* vb) {
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
  __global REAL* AL = fh + ss;
  __global REAL* BE = gh + ts;
  __global REAL* U = ub + ss;
  __global REAL* UN = un + ss;
  __global REAL* V = vb + ts;
  __global REAL* K = kmat + (long)I[I_KOFF];

  const REAL eps = P[P_EPS], tol = P[P_TOL], scale = P[P_SCALE];
  const REAL c = P[P_COS], s = P[P_SIN];
  const REAL cx = P[P_CX], cy = P[P_CY], cz = P[P_CZ];
  const int max_it = I[I_MAXIT];
  const int check = max((int)P[P_CHECK], 1);

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
    AL[i] = 0;
    U[i] = 1;
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
    BE[j] = j < m ? 0 : -PAD_LOGW;
    V[j] = j < m ? 1 : 0;
  }
  barrier(CLK_GLOBAL_MEM_FENCE);
  __global const REAL* sz = SX + (DIM == 3 ? 2 * npad : 0);
  __global const REAL* tz = TX + (DIM == 3 ? 2 * mpad : 0);

  REAL cost_factor = 1;
  if (P[P_NORMALISE] != 0) {
    REAL mx = 0;
    for (int i = lid; i < n; i += WG)
      for (int j = 0; j < m; ++j)
        mx = fmax(mx, dist2(SX[i], SX[npad + i], sz[i], TX[j], TX[mpad + j], tz[j]));
    mx = group_max(mx, scratch);
    if (mx > 0) cost_factor = 1 / mx;
  }

  REAL cur_eps = P[P_EPS0] > eps ? (REAL)P[P_EPS0] : eps;
  const REAL decay = P[P_DECAY];
  int it = 0, it_target = 0, converged = 0;
  REAL err = INFINITY;
  build_k(K, n, mpad, SX, npad, sz, TX, tz, AL, BE, cost_factor / cur_eps);
  barrier(CLK_GLOBAL_MEM_FENCE);
  while (1) {
    const int at_target = cur_eps <= eps;
    if (at_target && it_target >= max_it) break;
    const int checking = at_target && it_target > 0 && (it_target % check == 0);
    // u update; the error of the plan (old u, v) comes with it. Reductions run unconditionally
    // (see sinkhorn.cl on PoCL and barriers under conditions).
    REAL e = 0, big = 0;
    for (int i = lid; i < n; i += WG) {
      __global const REAL* Ki = K + (long)i * mpad;
      REALV acc = (REALV)(0);
      for (int j = 0; j < mpad; j += VW) acc = fma(VLOAD(0, Ki + j), VLOAD(0, V + j), acc);
      const REAL r = hsum(acc);
      const REAL a = exp(la[i]);
      e += fabs(U[i] * r - a);
      const REAL u = a / r;
      UN[i] = u;
      big = fmax(big, fabs(log(u)));
    }
    e = group_sum(e, scratch);
    if (checking) {
      err = e;
      if (err < tol) {
        converged = 1;
        break;
      }
    }
    for (int i = lid; i < n; i += WG) U[i] = UN[i];
    barrier(CLK_GLOBAL_MEM_FENCE);
    // v update, VW columns per step, rows streamed: K^T u without a transposed copy.
    for (int j = lid * VW; j < mpad; j += WG * VW) {
      REALV acc = (REALV)(0);
      for (int i = 0; i < n; ++i) acc = fma(VLOAD(0, K + (long)i * mpad + j), (REALV)(U[i]), acc);
      for (int q = 0; q < VW && j + q < m; ++q) {
        REAL cs = ((REAL*)&acc)[q];
        const REAL v = exp(lb[j + q]) / cs;
        V[j + q] = v;
        big = fmax(big, fabs(log(v)));
      }
    }
    barrier(CLK_GLOBAL_MEM_FENCE);
    ++it;
    if (at_target) ++it_target;
    big = group_max(isfinite(big) ? big : (REAL)INFINITY, scratch);
    const REAL next = at_target ? eps : fmax(cur_eps * decay, eps);
    if (big > ABSORB || next != cur_eps) {
      // Absorb the scalings into the log-domain duals, move to the next epsilon, rebuild K.
      const REAL r = cur_eps / next;
      for (int i = lid; i < n; i += WG) {
        AL[i] = (AL[i] + log(U[i])) * r;
        U[i] = 1;
      }
      for (int j = lid; j < m; j += WG) {
        BE[j] = (BE[j] + log(V[j])) * r;
        V[j] = 1;
      }
      cur_eps = next;
      barrier(CLK_GLOBAL_MEM_FENCE);
      build_k(K, n, mpad, SX, npad, sz, TX, tz, AL, BE, cost_factor / cur_eps);
      barrier(CLK_GLOBAL_MEM_FENCE);
    }
  }
  {
    REAL e = 0;
    for (int i = lid; i < n; i += WG) {
      __global const REAL* Ki = K + (long)i * mpad;
      REALV acc = (REALV)(0);
      for (int j = 0; j < mpad; j += VW) acc = fma(VLOAD(0, Ki + j), VLOAD(0, V + j), acc);
      e += fabs(U[i] * hsum(acc) - exp(la[i]));
    }
    e = group_sum(e, scratch);
    if (!converged) {
      err = e;
      converged = err < tol ? 1 : 0;
    }
  }

  const REAL k = cost_factor / cur_eps;
  REAL total = 0;
  const long plan0 = I[I_PLAN];
  for (int i = lid; i < n; i += WG) {
    REAL rs = 0, rc = 0, bx = 0, by = 0, bz = 0;
    for (int j = 0; j < m; ++j) {
      const REAL d2 = dist2(SX[i], SX[npad + i], sz[i], TX[j], TX[mpad + j], tz[j]);
      const REAL pij = U[i] * K[(long)i * mpad + j] * V[j];
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
  // Scaled duals in the log kernel's convention for the host: fh = f/eps + log a.
  barrier(CLK_GLOBAL_MEM_FENCE);
  for (int i = lid; i < n; i += WG) AL[i] = AL[i] + log(U[i]);
  for (int j = lid; j < m; j += WG) BE[j] = BE[j] + log(V[j]);
  if (lid == 0) {
    out[p * NR + 0] = (float)total;
    out[p * NR + 1] = (float)it;
    out[p * NR + 2] = (float)err;
    out[p * NR + 3] = (float)converged;
  }
}
