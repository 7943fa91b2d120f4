// Batched Sinkhorn, stabilised kernel-matrix scheme: K_ij = exp(al_i + be_j - k C_ij) is stored
// per problem and the iterations are scalings u = a / (K v), v = b / (K^T u): a multiply-add per
// entry instead of an exp. The scalings are kept as logarithms (lu, lv) and absorbed into the
// log-domain duals (al, be), with K rebuilt, only when one leaves [-ABSORB, ABSORB] or epsilon
// changes, so the fixed point is the log-domain one. Layout and most arguments as sinkhorn.cl
// (its header explains the padding; the per-problem tables are in common/sinkhorn_launch.h).
//
// Precision: K and the float copies of the scalings used in the products are single precision;
// the duals, the log-scalings and every sum (K v, K^T u, the marginal error) are accumulated in
// ACC (double where the device has it). Summing a 1500-entry row in float lanes alone leaves
// about 2e-7 of rounding noise in the 1-norm marginal error, above the 1e-7 tolerance.
//
// Over-relaxation: u <- u^(1-w) (a / K v)^w (same for v), w in [1, 2), has the same fixed point
// and, with w near its optimum 2 / (1 + sqrt(1 - eta^2)), needs the square root of the
// iterations. eta^2 is the contraction factor of plain Sinkhorn; it is estimated from the
// observed decay of the marginal error lambda with the current w (Young's relation for two-block
// over-relaxation: (lambda + w - 1)^2 = lambda w^2 eta^2), and w only grows unless the error
// grows, so a noisy estimate cannot run away.
//
// Barriers: every one is reached by all work-items unconditionally; conditional phases are
// loops whose trip count is zero when skipped (PoCL 3.1 miscompiled barriers inside a uniform
// `if` after a loop that some work-items skip, see tests/pocl_quirks_test.cpp).

#include "../common/sinkhorn_common.cl"

#ifndef ABSORB
#define ABSORB 25
#endif

static ACC hmax_acc(ACCV v) {
  ACC r = 0;
  for (int q = 0; q < VW; ++q) r = fmax(r, ((ACC*)&v)[q]);
  return r;
}
// Smallest row or column sum taken as is; below, it is clamped so that the scaling becomes
// large, which triggers an absorption that rebuilds K around the new duals.
#define TINY_SUM ((ACC)1e-30)

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

// 1, or 1 / max C over the real pairs when the problem asks for a normalised cost. `scratch`
// holds WG values.
static REAL cost_normaliser(__global const REAL* SX, const int npad, const int n,
                            __global const REAL* TX, const int mpad, const int m,
                            __global const SinkhornLaunchParams* P, __local ACC* scratch) {
  const int lid = get_local_id(0);
  const int rows = P->normalise != 0 ? n : 0;
  __global const REAL* sz = SX + (DIM == 3 ? 2 * npad : 0);
  __global const REAL* tz = TX + (DIM == 3 ? 2 * mpad : 0);
  REAL mx = 0;
  for (int i = lid; i < rows; i += WG) {
    REALV vm = (REALV)(0);
    int j = 0;
    for (; j + VW <= m; j += VW) {
      vm = fmax(vm, dist2v(SX[i], SX[npad + i], sz[i], TX, TX + mpad, tz, j));
    }
    for (int q = 0; q < VW; ++q) mx = fmax(mx, ((REAL*)&vm)[q]);
    for (; j < m; ++j) mx = fmax(mx, dist2(SX[i], SX[npad + i], sz[i], TX[j], TX[mpad + j], tz[j]));
  }
  scratch[lid] = mx;
  barrier(CLK_LOCAL_MEM_FENCE);
  ACC all = 0;
  for (int l = 0; l < WG; ++l) all = fmax(all, scratch[l]);
  barrier(CLK_LOCAL_MEM_FENCE);
  return all > 0 ? (REAL)(1 / all) : (REAL)1;
}

static ACC hsum_acc(ACCV v) {
#if VW == 8
  return ((v.s0 + v.s1) + (v.s2 + v.s3)) + ((v.s4 + v.s5) + (v.s6 + v.s7));
#else
  return ((v.s0 + v.s1) + (v.s2 + v.s3)) + ((v.s4 + v.s5) + (v.s6 + v.s7)) +
         (((v.s8 + v.s9) + (v.sa + v.sb)) + ((v.sc + v.sd) + (v.se + v.sf)));
#endif
}

// sum_i K_ij u_i for the VW columns starting at j, rows streamed, in ACC: K is widened, the
// scalings stay in ACC. With float scalings (or float lanes for the sums) the 1-norm marginal
// error of 50-point problems stalls at 1e-7 to 5e-7, above the 1e-7 tolerance of the ranking
// setting (measured); widening costs about a third more time per product on PoCL here.
static ACCV col_dot(__global const REAL* K, __global const ACC* u, const int n, const int mpad,
                    const int j) {
  // Four independent chains: one chain waits on the FMA latency every row (measured: the
  // products of small ranking problems ran latency-bound).
  ACCV t0 = (ACCV)(0), t1 = (ACCV)(0), t2 = (ACCV)(0), t3 = (ACCV)(0);
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    __global const REAL* Ki = K + (long)i * mpad + j;
    t0 = fma(TO_ACCV(VLOAD(0, Ki)), (ACCV)(u[i]), t0);
    t1 = fma(TO_ACCV(VLOAD(0, Ki + mpad)), (ACCV)(u[i + 1]), t1);
    t2 = fma(TO_ACCV(VLOAD(0, Ki + 2 * mpad)), (ACCV)(u[i + 2]), t2);
    t3 = fma(TO_ACCV(VLOAD(0, Ki + 3 * mpad)), (ACCV)(u[i + 3]), t3);
  }
  for (; i < n; ++i) t0 = fma(TO_ACCV(VLOAD(0, K + (long)i * mpad + j)), (ACCV)(u[i]), t0);
  return (t0 + t1) + (t2 + t3);
}

// One row of K: exp(al + be_j - k d2_ij), the exponent formed in ACC (the duals reach
// thousands at small epsilon) and rounded once. Entries below REAL's smallest normal number are
// stored as 0 (flush to zero, as GPUs do for float): x86 CPUs take a microcode assist of about a
// hundred cycles for every denormal operand of a product or a conversion, and without a
// flush-to-zero mode (PoCL sets none) a transport's K full of them ran 8x slower on an Intel
// Xeon than on an AMD EPYC (docs/pot-scale.md). What they dropped is below 1e-37 of a K entry of
// 1, far under the plan's float resolution.
#if USE_DOUBLE
#define FLUSH_EXP (-708.0)
#else
#define FLUSH_EXP (-87.0f)
#endif
static void build_row(__global REAL* Ki, const REAL px, const REAL py, const REAL pz,
                      __global const REAL* TX, __global const REAL* tz, const int mpad,
                      __global const ACC* BE, const ACC al, const REAL k) {
  for (int j = 0; j < mpad; j += VW) {
    const REALV d2 = dist2v(px, py, pz, TX, TX + mpad, tz, j);
#if VW == 8
    const ACCV be = vload8(0, BE + j);
#else
    const ACCV be = vload16(0, BE + j);
#endif
    const REALV x = TO_REALV(be + al - TO_ACCV(k * d2));
    VSTORE(select(exp(fmax(x, (REALV)(FLUSH_EXP))), (REALV)(0), isless(x, (REALV)(FLUSH_EXP))), 0,
           Ki + j);
  }
}

// Smallest lane of v, halves against halves (min is exact: any order gives the same value).
static REAL hmin_real(const REALV v) {
#if VW == 16
  const float8 h8 = fmin(v.lo, v.hi);
  const float4 h4 = fmin(h8.lo, h8.hi);
#else
  const double4 h4 = fmin(v.lo, v.hi);
#endif
  const REAL h2a = fmin(h4.s0, h4.s2), h2b = fmin(h4.s1, h4.s3);
  return fmin(h2a, h2b);
}

// min_j |p - q_j|^2 over the cnt real points of a structure-of-arrays buffer of cpad slots,
// whole vectors with the pads' lanes masked to infinity: a scalar tail and a scalar reduction
// were a tenth of a small ranking problem's time on PoCL.
static REAL min_d2(const REAL px, const REAL py, const REAL pz, __global const REAL* qx,
                   __global const REAL* qy, __global const REAL* qz, const int cnt,
                   const int cpad) {
  REALV mn = (REALV)(INFINITY);
  int j = 0;
  for (; j + VW <= cnt; j += VW) mn = fmin(mn, dist2v(px, py, pz, qx, qy, qz, j));
  if (j < cnt) {
    const REALV dx = px - VLOAD(0, qx + j), dy = py - VLOAD(0, qy + j);
    REALV d2 = fma(dx, dx, dy * dy);
#if DIM == 3
    const REALV dz = pz - VLOAD(0, qz + j);
    d2 = fma(dz, dz, d2);
#endif
    mn = fmin(mn, select(d2, (REALV)(INFINITY), isgreaterequal(REAL_LANES, (REALV)(cnt - j))));
  }
  return hmin_real(mn);
}

// The start: one max-plus (epsilon -> 0) iteration from zero duals, al_i = k min_j C_ij, then
// be_j = min_i (k C_ij - al_i): every row and every column of the first K then has an entry
// exactly 1, so no sum underflows whatever epsilon is, and no exp is needed. The marginals
// a, b are left to the scalings (lu, lv start at 0, both generations).
static void start_duals(const int n, const int npad, const int m, const int mpad, const REAL k,
                        __global const REAL* SX, __global const REAL* sz, __global const REAL* TX,
                        __global const REAL* tz, __global const ACC* la, __global ACC* AL,
                        __global ACC* BE, __global ACC* LU, __global ACC* LV, __global ACC* EUG,
                        __global ACC* VF, __global ACC* A) {
  const int lid = get_local_id(0);
  for (int i = lid; i < npad; i += WG)
    AL[i] = i < n ? k * min_d2(SX[i], SX[npad + i], sz[i], TX, TX + mpad, tz, m, mpad)
                  : (ACC)(-PAD_LOGW);
  for (int i = lid; i < npad; i += WG) {
    LU[i] = 0;
    LU[npad + i] = 0;
    EUG[i] = i < n ? 1 : 0;
    EUG[npad + i] = i < n ? 1 : 0;
    A[i] = i < n ? exp((ACC)la[i]) : 0;
  }
  barrier(CLK_GLOBAL_MEM_FENCE);
  for (int j = lid * VW; j < mpad; j += WG * VW) {
    const REALV qx = VLOAD(0, TX + j), qy = VLOAD(0, TX + mpad + j);
#if DIM == 3
    const REALV qz = VLOAD(0, tz + j);
#endif
    REALV mn = (REALV)(INFINITY);
    for (int i = 0; i < n; ++i) {
      REALV dx = qx - SX[i];
      REALV d2 = dx * dx;
      REALV dy = qy - SX[npad + i];
      d2 = fma(dy, dy, d2);
#if DIM == 3
      REALV dz = qz - sz[i];
      d2 = fma(dz, dz, d2);
#endif
      mn = fmin(mn, fma((REALV)(k), d2, (REALV)(-(REAL)AL[i])));
    }
    for (int q = 0; q < VW; ++q) {
      BE[j + q] = j + q < m ? (ACC)((REAL*)&mn)[q] : (ACC)(-PAD_LOGW);
      VF[j + q] = j + q < m ? 1 : 0;
      LV[j + q] = 0;
      LV[mpad + j + q] = 0;
    }
  }
}

// Absorbs the column log-scalings lv (current generation) into the duals be of the first `cnt`
// columns (0: none), the duals rescaled by `ratio` when epsilon changes; the scalings restart
// at 1.
static void absorb_columns(const int cnt, const ACC ratio, __global ACC* BE, __global ACC* LVc,
                           __global const ACC* lb, __global ACC* VF) {
  for (int j = get_local_id(0); j < cnt; j += WG) {
    BE[j] = (BE[j] + LVc[j] - lb[j]) * ratio + lb[j];
    LVc[j] = 0;
    VF[j] = 1;
  }
}

// The same for the rows: lu into al, exp(lu) and the product copy back to 1.
static void absorb_rows(const int cnt, const ACC ratio, __global ACC* AL, __global ACC* LUc,
                        __global const ACC* la, __global ACC* EUGc, __global ACC* UF) {
  for (int i = get_local_id(0); i < cnt; i += WG) {
    AL[i] = (AL[i] + LUc[i] - la[i]) * ratio + la[i];
    LUc[i] = 0;
    EUGc[i] = 1;
    UF[i] = 1;
  }
}

// Transposes the VW x VW tile whose rows are t[0..VW): stage S swaps, in every 2S x 2S block,
// the top-right S x S block with the bottom-left one; the stages together exchange the row and
// column index bit by bit. Each is one two-source shuffle a row, where a scalar copy gathers.
#define TILE_STAGE(S, LO, HI)              \
  for (int r = 0; r < VW; ++r)              \
    if ((r & (S)) == 0) {                   \
      const REALV a = t[r], b = t[r + (S)]; \
      t[r] = LO;                            \
      t[r + (S)] = HI;                      \
    }
static void transpose_tile(REALV* t) {
#if VW == 16
  TILE_STAGE(8, (REALV)(a.lo, b.lo), (REALV)(a.hi, b.hi));
  TILE_STAGE(4, (REALV)(a.s0123, b.s0123, a.s89ab, b.s89ab),
             (REALV)(a.s4567, b.s4567, a.scdef, b.scdef));
  TILE_STAGE(2, (REALV)(a.s01, b.s01, a.s45, b.s45, a.s89, b.s89, a.scd, b.scd),
             (REALV)(a.s23, b.s23, a.s67, b.s67, a.sab, b.sab, a.sef, b.sef));
  TILE_STAGE(1,
             (REALV)(a.s0, b.s0, a.s2, b.s2, a.s4, b.s4, a.s6, b.s6, a.s8, b.s8, a.sa, b.sa, a.sc,
                     b.sc, a.se, b.se),
             (REALV)(a.s1, b.s1, a.s3, b.s3, a.s5, b.s5, a.s7, b.s7, a.s9, b.s9, a.sb, b.sb, a.sd,
                     b.sd, a.sf, b.sf));
#else
  TILE_STAGE(4, (REALV)(a.lo, b.lo), (REALV)(a.hi, b.hi));
  TILE_STAGE(2, (REALV)(a.s01, b.s01, a.s45, b.s45), (REALV)(a.s23, b.s23, a.s67, b.s67));
  TILE_STAGE(1, (REALV)(a.s0, b.s0, a.s2, b.s2, a.s4, b.s4, a.s6, b.s6),
             (REALV)(a.s1, b.s1, a.s3, b.s3, a.s5, b.s5, a.s7, b.s7));
#endif
}
#undef TILE_STAGE

// Rebuilds the first `icnt` rows of K (0: none) around the duals, and K^T from it. K by rows for
// K^T u and its transpose by rows for K v: both products then stream rows with a broadcast
// scalar into VW-wide sums, with no horizontal sum per row.
static void rebuild_kernel(const int icnt, const int jcnt, const int n, const int npad,
                           const int mpad, const REAL k, __global REAL* K, __global REAL* KT,
                           __global const REAL* SX, __global const REAL* sz,
                           __global const REAL* TX, __global const REAL* tz,
                           __global const ACC* AL, __global const ACC* BE) {
  const int lid = get_local_id(0);
  for (int i0 = 0; i0 < icnt; i0 += WG)
    if (i0 + lid < icnt)
      build_row(K + (long)(i0 + lid) * mpad, SX[i0 + lid], SX[npad + i0 + lid], sz[i0 + lid], TX,
                tz, mpad, BE, AL[i0 + lid], k);
  barrier(CLK_GLOBAL_MEM_FENCE);
  // K^T by copying, not by exps again (the exps of the rebuild dominate small problems), a
  // VW x VW tile at a time transposed in registers: a column of K read entry by entry takes
  // each entry from another cache line, and that copy was a seventh of a transport's time
  // (docs/pot-scale.md). Pads of K^T rows (i >= n) must be 0 as build_row leaves them.
  for (int j0 = lid * VW; j0 < jcnt; j0 += WG * VW) {
    const int jn = min(VW, jcnt - j0);
    for (int i0 = 0; i0 < npad; i0 += VW) {
      REALV t[VW];
      for (int r = 0; r < VW; ++r)
        t[r] = i0 + r < n ? VLOAD(0, K + (long)(i0 + r) * mpad + j0) : (REALV)(0);
      transpose_tile(t);
      for (int r = 0; r < jn; ++r) VSTORE(t[r], 0, KT + (long)(j0 + r) * npad + i0);
    }
  }
  barrier(CLK_GLOBAL_MEM_FENCE);
}

// The u update with over-relaxation w, VW rows per step so that the logs and exps run in
// vectors: generation `LUc`/`EUGc` to `LUn`/`EUGn`, and the product copy UF. Returns this
// work-item's lanes of the current plan's marginal error; `bv` receives the largest |lu|.
// Pads read r = 0 and are masked.
static ACCV scale_rows(const int n, const int npad, const int m, const ACC w,
                       __global const REAL* KT, __global const ACC* VF, __global const ACC* LUc,
                       __global ACC* LUn, __global const ACC* EUGc, __global ACC* EUGn,
                       __global const ACC* A, __global const ACC* la, __global ACC* UF,
                       ACCV* bv) {
  ACCV ev = (ACCV)(0);
  for (int i0 = get_local_id(0) * VW; i0 < npad; i0 += WG * VW) {
    const ACCV r = col_dot(KT, VF, m, npad, i0);
    const ACCV lu = ACCLOAD(0, LUc + i0);
    ev += fabs(ACCLOAD(0, EUGc + i0) * r - ACCLOAD(0, A + i0));
    const ACCV lav = ACCLOAD(0, la + i0);
    const ACCV lun = select((ACCV)(0), (1 - w) * lu + w * (lav - log(fmax(r, TINY_SUM))),
                            isless(LANES, (ACCV)(n - i0)));
    const ACCV un = select((ACCV)(0), exp(lun), isless(LANES, (ACCV)(n - i0)));
    ACCSTORE(lun, 0, LUn + i0);
    ACCSTORE(un, 0, EUGn + i0);
    ACCSTORE(un, 0, UF + i0);
    *bv = fmax(*bv, fabs(lun));
  }
  return ev;
}

// The v update, VW columns per step: generation `LVc` to `LVn` and the product copy VF; `bv`
// receives the largest |lv|.
static void scale_columns(const int n, const int m, const int mpad, const ACC w,
                          __global const REAL* K, __global const ACC* UF,
                          __global const ACC* LVc, __global ACC* LVn, __global const ACC* lb,
                          __global ACC* VF, ACCV* bv) {
  for (int j = get_local_id(0) * VW; j < mpad; j += WG * VW) {
    const ACCV cs = col_dot(K, UF, n, mpad, j);
    const ACCV lv = ACCLOAD(0, LVc + j);
    const ACCV lbv = ACCLOAD(0, lb + j);
    const ACCV lvn = select((ACCV)(0), (1 - w) * lv + w * (lbv - log(fmax(cs, TINY_SUM))),
                            isless(LANES, (ACCV)(m - j)));
    ACCSTORE(lvn, 0, LVn + j);
    ACCSTORE(select((ACCV)(0), exp(lvn), isless(LANES, (ACCV)(m - j))), 0, VF + j);
    *bv = fmax(*bv, fabs(lvn));
  }
}

// Sums `e` and takes the largest `b` over the work-group through the scratch rows `re`, `rb`
// (the caller alternates rows, so that none needs a barrier before reuse).
static ACC reduce_sum_max(const ACC e, const ACC b, __local ACC* re, __local ACC* rb, ACC* bmax) {
  const int lid = get_local_id(0);
  re[lid] = e;
  rb[lid] = b;
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  ACC tot = 0;
  *bmax = 0;
  for (int l = 0; l < WG; ++l) {
    tot += re[l];
    *bmax = fmax(*bmax, rb[l]);
  }
  return tot;
}

// 1-norm marginal error of the plan u_i K_ij v_j (EU, EV), summed over the work-group in `red`.
static ACC plan_error(const int n, const int mpad, __global const REAL* K,
                      __global const ACC* EU, __global const ACC* EV, __global const ACC* A,
                      __local ACC* red) {
  const int lid = get_local_id(0);
  ACC e = 0;
  for (int i = lid; i < n; i += WG) {
    ACCV r = (ACCV)(0);
    for (int j = 0; j < mpad; j += VW)
      r = fma(TO_ACCV(VLOAD(0, K + (long)i * mpad + j)), ACCLOAD(0, EV + j), r);
    e += fabs(EU[i] * hsum_acc(r) - A[i]);
  }
  red[lid] = e;
  barrier(CLK_LOCAL_MEM_FENCE);
  ACC tot = 0;
  for (int l = 0; l < WG; ++l) tot += red[l];
  return tot;
}

// The plan's rows handed back: the coupling (when plan0 >= 0), the barycentric map (when asked),
// and the scaled duals fh = f/eps + log a in the log kernel's convention. Returns this
// work-item's part of the cost <P, C>.
static ACC write_rows(__global const SinkhornLaunchInts* I, __global const SinkhornLaunchParams* P,
                      const REAL cost_factor, __global const REAL* K,
                      __global const REAL* KT, __global const REAL* SX,
                      __global const REAL* sz, __global const REAL* TX, __global const REAL* tz,
                      __global const ACC* EU, __global const ACC* EV, __global const ACC* AL,
                      __global const ACC* LUc, __global float* plan, __global float* bary,
                      const int want_bary, __global REAL* fh) {
  const int n = I->n, npad = I->npad, m = I->m, mpad = I->mpad, ss = I->src_slot;
  ACC total = 0;
  const long plan0 = I->plan;
  const REAL inv_scale = 1 / (REAL)P->scale;
  for (int i = get_local_id(0); i < n; i += WG) {
    ACCV rs = (ACCV)(0), rc = (ACCV)(0), bx = (ACCV)(0), by = (ACCV)(0), bz = (ACCV)(0);
    const ACC ui = EU[i];
    __global const REAL* Ki = K + (long)i * mpad;
    for (int j = 0; j < mpad; j += VW) {
      const REALV qx = VLOAD(0, TX + j), qy = VLOAD(0, TX + mpad + j);
      REALV dx = qx - SX[i];
      REALV d2 = dx * dx;
      REALV dy = qy - SX[npad + i];
      d2 = fma(dy, dy, d2);
#if DIM == 3
      const REALV qz = VLOAD(0, tz + j);
      REALV dz = qz - sz[i];
      d2 = fma(dz, dz, d2);
#endif
      const ACCV pv = ui * TO_ACCV(VLOAD(0, Ki + j)) * ACCLOAD(0, EV + j);
      rs += pv;
      rc = fma(pv, TO_ACCV(d2), rc);
      bx = fma(pv, TO_ACCV(qx), bx);
      by = fma(pv, TO_ACCV(qy), by);
#if DIM == 3
      bz = fma(pv, TO_ACCV(qz), bz);
#endif
    }
    total += hsum_acc(rc) * cost_factor;
    if (want_bary) {
      // Target points are not rotated: TX / scale are the target points in their own units.
      const long o = ((long)I->src + i) * DIM;
      const ACC rsum = hsum_acc(rs);
      const ACC inv = rsum > 0 ? inv_scale / rsum : 0;
      bary[o + 0] = (float)(hsum_acc(bx) * inv);
      bary[o + 1] = (float)(hsum_acc(by) * inv);
#if DIM == 3
      bary[o + 2] = (float)(hsum_acc(bz) * inv);
#endif
    }
    fh[ss + i] = (REAL)(AL[i] + LUc[i]);
  }
  // The plan column by column (host/ot/sinkhorn.cpp reads it as a column-major matrix, and the
  // placement reads a target sample's column), from K's transposed copy, whose row j is K's
  // column j: one contiguous read and write a column, the same products as by rows.
  const int pm = plan0 >= 0 ? m : 0;
  for (int j = get_local_id(0); j < pm; j += WG) {
    __global const REAL* KTj = KT + (long)j * npad;
    __global float* Pj = plan + plan0 + (long)j * n;
    const ACC vj = EV[j];
    for (int i = 0; i < n; ++i) Pj[i] = (float)(EU[i] * KTj[i] * vj);
  }
  return total;
}

// Solves problem p with this work-group; K is the work-group's kernel-matrix storage.
static void solve(
    const int p, __global const float* src, __global const float* tgt,
    __global const SinkhornLaunchInts* ints, __global const SinkhornLaunchParams* params,
    __global const ACC* loga, __global const ACC* logb, __global REAL* sx, __global REAL* tx,
    __global REAL* fh, __global REAL* gh, __global SinkhornLaunchStats* out, __global float* plan,
    __global float* bary, const int want_bary, __global REAL* K, __global REAL* KT,
    __global ACC* alb, __global ACC* beb, __global ACC* lub, __global ACC* lvb, __global ACC* ufb,
    __global ACC* vfb, __global ACC* eub, __global ACC* wab, __local ACC (*red_e)[WG],
    __local ACC (*red_b)[WG]) {
  const int lid = get_local_id(0);
  __global const SinkhornLaunchInts* I = ints + p;
  __global const SinkhornLaunchParams* P = params + p;
  const int n = I->n, npad = I->npad, m = I->m, mpad = I->mpad;
  const int ss = I->src_slot, ts = I->tgt_slot;
  __global REAL* SX = sx + (long)ss * DIM;
  __global REAL* TX = tx + (long)ts * DIM;
  __global const ACC* la = loga + ss;  // log marginals in ACC (see host/ot/sinkhorn.cpp)
  __global const ACC* lb = logb + ts;
  __global ACC* AL = alb + ss;
  __global ACC* BE = beb + ts;
  __global ACC* LU = lub + 2 * (long)ss;
  __global ACC* LV = lvb + 2 * (long)ts;
  __global ACC* UF = ufb + ss;
  __global ACC* VF = vfb + ts;
  __global ACC* EUG = eub + 2 * (long)ss;  // exp(lu) of both generations (pads 0)
  __global ACC* A = wab + ss;              // a_i (pads 0)

  const REAL eps = P->eps, tol = P->tol;
  const int max_it = I->max_it;
  const int check = max((int)P->check, 1);
  const ACC omega_fixed = P->omega;

  transform_points(src, tgt, I, P, SX, TX);
  barrier(CLK_GLOBAL_MEM_FENCE);
  __global const REAL* sz = SX + (DIM == 3 ? 2 * npad : 0);
  __global const REAL* tz = TX + (DIM == 3 ? 2 * mpad : 0);
  const REAL cost_factor = cost_normaliser(SX, npad, n, TX, mpad, m, P, &red_e[0][0]);

  REAL cur_eps = P->eps0 > eps ? (REAL)P->eps0 : eps;
  const REAL decay = P->decay;
  start_duals(n, npad, m, mpad, cost_factor / cur_eps, SX, sz, TX, tz, la, AL, BE, LU, LV, EUG, VF,
              A);
  barrier(CLK_GLOBAL_MEM_FENCE);
  // The plan is P_ij = exp(lu_i) K_ij exp(lv_j); al + lu, be + lv are the scaled duals of
  // sinkhorn.cl (f/eps + log a).
  int it = 0, it_target = 0, converged = 0;
  int cur = 0;  // generation of lu, lv holding the current plan
  int rebuild = 1;
  REAL next_eps = cur_eps;
  ACC ratio = 1;
  ACC err = INFINITY, ref_err = -1, omega = 1.3;
  int mark = 5, win = 5, par = 0;
  while (1) {
    // Absorb the scalings into the duals (columns, then rows with their rebuilt K rows). Runs as
    // zero-trip loops when not needed.
    const int jcnt = rebuild ? m : 0, icnt = rebuild ? n : 0;
    absorb_columns(jcnt, ratio, BE, LV + cur * mpad, lb, VF);
    if (rebuild) cur_eps = next_eps;
    const REAL k = cost_factor / cur_eps;
    const int at_target = cur_eps <= eps;
    const int checking = at_target && it_target > 0 && (it_target % check == 0);
    const ACC w = at_target ? (omega_fixed > 0 ? omega_fixed : omega) : (ACC)1;
    barrier(CLK_GLOBAL_MEM_FENCE);
    absorb_rows(icnt, ratio, AL, LU + cur * npad, la, EUG + cur * npad, UF);
    barrier(CLK_GLOBAL_MEM_FENCE);
    rebuild_kernel(icnt, jcnt, n, npad, mpad, k, K, KT, SX, sz, TX, tz, AL, BE);
    // Absorbing does not change the plan, so the limit is tested after it: K is always built.
    if (at_target && it_target >= max_it) break;
    // The error of the plan (lu, lv of generation cur) comes with the u update.
    ACCV bv = (ACCV)(0);
    const int nxt = 1 - cur;
    const ACCV ev = scale_rows(n, npad, m, w, KT, VF, LU + cur * npad, LU + nxt * npad,
                               EUG + cur * npad, EUG + nxt * npad, A, la, UF, &bv);
    barrier(CLK_GLOBAL_MEM_FENCE);
    scale_columns(n, m, mpad, w, K, UF, LV + cur * mpad, LV + nxt * mpad, lb, VF, &bv);
    const ACC big = hmax_acc(bv);
    ACC bmax;
    const ACC tot = reduce_sum_max(hsum_acc(ev), isfinite(big) ? big : (ACC)INFINITY, red_e[par],
                                   red_b[par], &bmax);
    par = 1 - par;  // the other scratch row next time: no barrier needed before reuse
    if (checking) {
      err = tot;
      if (err < tol) {
        converged = 1;
        break;
      }
    }
    cur = nxt;
    ++it;
    if (at_target) {
      ++it_target;
      if (omega_fixed <= 0 && it_target == mark)
        adapt_omega(it_target, tot, &omega, &ref_err, &win, &mark);
    }
    next_eps = at_target ? eps : fmax(cur_eps * decay, eps);
    rebuild = bmax > ABSORB || next_eps != cur_eps;
    ratio = cur_eps / next_eps;
  }
  // The plan handed back is generation `cur`; the spare generation receives its scalings.
  __global ACC* EU = LU + (1 - cur) * npad;
  __global ACC* EV = LV + (1 - cur) * mpad;
  barrier(CLK_GLOBAL_MEM_FENCE);
  for (int i = lid; i < n; i += WG) EU[i] = EUG[cur * npad + i];
  for (int j = lid; j < mpad; j += WG) EV[j] = j < m ? exp(LV[cur * mpad + j]) : 0;
  barrier(CLK_GLOBAL_MEM_FENCE);
  // Its error, measured when the limit stopped it (no rows when it converged: the barrier
  // inside is still reached by every work-item).
  const ACC final_err = plan_error(converged ? 0 : n, mpad, K, EU, EV, A, red_e[par]);
  par = 1 - par;
  if (!converged) {
    err = final_err;
    converged = err < tol ? 1 : 0;
  }

  const ACC total = write_rows(I, P, cost_factor, K, KT, SX, sz, TX, tz, EU, EV, AL, LU + cur * npad,
                               plan, bary, want_bary, fh);
  for (int j = lid; j < m; j += WG) gh[ts + j] = (REAL)(BE[j] + LV[cur * mpad + j]);
  red_e[par][lid] = total;
  barrier(CLK_LOCAL_MEM_FENCE);
  if (lid == 0) {
    ACC tot = 0;
    for (int l = 0; l < WG; ++l) tot += red_e[par][l];
    out[p].cost = (float)tot;
    out[p].iterations = (float)it;
    out[p].marginal_error = (float)err;
    out[p].converged = (float)converged;
  }
}

// Arguments 0-13 as sinkhorn_solve (fh, gh receive the scaled duals f/eps + log a at the end).
// kmat: one K (n x mpad) and its transpose (m x npad), kstride reals in all, per work-group, not per problem: the work-groups
// are persistent and take the next problem from `counter` (zeroed by the host) until all
// `problems` are done, so K stays small and hot in cache whatever the batch size, and uneven
// problem sizes balance across the cores. al, be: absorbed duals per slot. lu, lv: log-scalings,
// two generations per slot (the plan whose error was measured is kept). uf, vf: the current
// scalings in REAL for the products (pads 0). eu: exp(lu), two generations. wa: a per slot.
__kernel __attribute__((reqd_work_group_size(WG, 1, 1))) void sinkhorn_stab_solve(
    __global const float* src, __global const float* tgt, __global const SinkhornLaunchInts* ints,
    __global const SinkhornLaunchParams* params, __global const ACC* loga,
    __global const ACC* logb, __global REAL* sx, __global REAL* tx, __global REAL* fh,
    __global REAL* gh, __global SinkhornLaunchStats* out, __global float* plan, __global float* bary, const int want_bary,
    __global REAL* kmat, __global ACC* alb, __global ACC* beb, __global ACC* lub,
    __global ACC* lvb, __global ACC* ufb, __global ACC* vfb, __global ACC* eub,
    __global ACC* wab, __global int* counter, const int problems, const long kstride) {
  __local ACC red_e[2][WG], red_b[2][WG];
  __local int next;
  __global REAL* K = kmat + get_group_id(0) * kstride;
  while (1) {
    if (get_local_id(0) == 0) next = atomic_inc(counter);
    barrier(CLK_LOCAL_MEM_FENCE);
    const int p = next;
    barrier(CLK_LOCAL_MEM_FENCE);
    if (p >= problems) break;
    solve(p, src, tgt, ints, params, loga, logb, sx, tx, fh, gh, out, plan, bary, want_bary, K,
          K + kstride / 2, alb, beb, lub, lvb, ufb, vfb, eub, wab, red_e, red_b);
  }
}
