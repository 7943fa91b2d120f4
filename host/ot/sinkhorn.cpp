#include "potmap/ot/sinkhorn.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include "../../kernels/common/sinkhorn_launch.h"
#include "potmap/error.hpp"
#include "potmap/runtime/tuning.hpp"
#include "runtime/cl_check.hpp"
#include "runtime/device_buffers.hpp"

namespace bc = boost::compute;

namespace potmap {

namespace {

// The launch table is shared with the kernels (kernels/common/sinkhorn_launch.h): 32-bit fields
// only, so that both sides lay it out alike.
static_assert(sizeof(SinkhornLaunchInts) == 10 * sizeof(cl_int), "launch table: padding");
static_assert(sizeof(SinkhornLaunchParams) == 13 * sizeof(cl_float), "launch table: padding");
static_assert(sizeof(SinkhornLaunchStats) == 4 * sizeof(cl_float), "launch table: padding");

std::string at(std::size_t p) {
  return "Sinkhorn problem " + std::to_string(p) + ": ";
}

void check_points(const Eigen::MatrixXd& pts, const char* what, std::size_t p) {
  for (Eigen::Index i = 0; i < pts.rows(); ++i)
    for (Eigen::Index d = 0; d < pts.cols(); ++d)
      if (!std::isfinite(pts(i, d)))
        throw InputError(at(p) + what + " point " + std::to_string(i) + " is not finite (" +
                         std::to_string(pts(i, d)) + ")");
}

void check_weights(const Eigen::VectorXd& w, Eigen::Index n, const char* what, std::size_t p) {
  if (w.size() == 0) return;
  if (w.size() != n)
    throw ArgumentError(at(p) + what + " weights have " + std::to_string(w.size()) +
                        " entries for " + std::to_string(n) + " points");
  for (Eigen::Index i = 0; i < n; ++i)
    if (!(w(i) > 0) || !std::isfinite(w(i)))
      throw ArgumentError(at(p) + what + " weight " + std::to_string(i) +
                          " must be positive and finite");
  if (std::abs(w.sum() - 1) > 1e-6)
    throw ArgumentError(at(p) + what + " weights must sum to 1, got " + std::to_string(w.sum()));
}

void validate(const SinkhornProblem& q, std::size_t p) {
  if (q.source.rows() == 0) throw ArgumentError(at(p) + "empty source point set");
  if (q.target.rows() == 0) throw ArgumentError(at(p) + "empty target point set");
  const auto dim = q.source.cols();
  if (dim != 2 && dim != 3)
    throw ArgumentError(at(p) + "points must be 2D or 3D, got " + std::to_string(dim));
  if (q.target.cols() != dim) throw ArgumentError(at(p) + "source and target dimensions differ");
  if (q.extra_points.rows() > 0 && q.extra_points.cols() != dim)
    throw ArgumentError(at(p) + "extra points have the wrong dimension");
  check_points(q.source, "source", p);
  check_points(q.target, "target", p);
  check_points(q.extra_points, "extra", p);
  check_weights(q.source_weights, q.source.rows(), "source", p);
  check_weights(q.target_weights, q.target.rows(), "target", p);
  if (!(q.epsilon > 0) || !std::isfinite(q.epsilon))
    throw ArgumentError(at(p) + "epsilon must be positive, got " + std::to_string(q.epsilon));
  if (!(q.tolerance > 0)) throw ArgumentError(at(p) + "tolerance must be positive");
  if (q.max_iterations < 1) throw ArgumentError(at(p) + "max_iterations must be >= 1");
  if (!(q.scale > 0) || !std::isfinite(q.scale))
    throw ArgumentError(at(p) + "scale must be positive, got " + std::to_string(q.scale));
  if (!std::isfinite(q.angle) || !q.centre.allFinite())
    throw ArgumentError(at(p) + "angle and centre must be finite");
}

// Everything a launch needs besides the points; duals come back for the host batch.
struct Launch {
  SinkhornDeviceResult result;
  bc::buffer fh, gh, loga, logb;
  std::vector<bc::buffer> inputs;  // the problem table, parameters and work buffers
  std::vector<bc::buffer> scratch;
  std::vector<SinkhornLaunchInts> ints;
  bool weights_double = false;  // loga, logb hold doubles
  // loga, logb as uploaded, widened: the host batch undoes the duals' log-weight convention
  // with them instead of reading the buffers back.
  std::vector<double> host_loga, host_logb;
  int vw = 16;
  bool dbl = false;
};

// Where each problem of a launch lies: offsets and counts of its points in the batch's
// buffers, and its parameters.
struct LaunchProblems {
  const std::vector<int>& soff;
  const std::vector<int>& scnt;
  const std::vector<int>& toff;
  const std::vector<int>& tcnt;
  const std::vector<const SinkhornProblem*>& par;
};

// The launch table (kernels/common/sinkhorn_launch.h) and the totals it implies.
struct LaunchTable {
  std::vector<SinkhornLaunchInts> ints;
  std::vector<SinkhornLaunchParams> params;
  std::size_t sslots = 0, tslots = 0;  // padded source and target slots of all problems
  long plan = 0;                       // coupling entries of all problems
  long kelems = 0;                     // kernel-matrix entries of the largest problem
};

// Stage 1: slots padded to the vector width `vw`, coupling offsets, parameters.
LaunchTable launch_table(const LaunchProblems& lp, const SinkhornOptions& opt, int vw,
                         std::vector<long>& coupling_offset) {
  const std::size_t np = lp.par.size();
  LaunchTable t;
  t.ints.resize(np);
  t.params.resize(np);
  coupling_offset.assign(np, -1);
  for (std::size_t p = 0; p < np; ++p) {
    const SinkhornProblem& pr = *lp.par[p];
    const int n = lp.scnt[p], m = lp.tcnt[p];
    const int npad = (n + vw - 1) / vw * vw, mpad = (m + vw - 1) / vw * vw;
    SinkhornLaunchInts& I = t.ints[p];
    I.src = lp.soff[p];
    I.n = n;
    I.src_slot = static_cast<int>(t.sslots);
    I.npad = npad;
    I.tgt = lp.toff[p];
    I.m = m;
    I.tgt_slot = static_cast<int>(t.tslots);
    I.mpad = mpad;
    I.plan = -1;
    if (opt.want_coupling) {
      I.plan = static_cast<int>(t.plan);
      coupling_offset[p] = t.plan;
      t.plan += static_cast<long>(n) * m;
    }
    I.max_it = pr.max_iterations;
    if (opt.stabilised)
      t.kelems = std::max(t.kelems,
                          2 * std::max(static_cast<long>(n) * mpad, static_cast<long>(m) * npad));
    SinkhornLaunchParams& P = t.params[p];
    P.eps = static_cast<float>(pr.epsilon);
    P.tol = static_cast<float>(pr.tolerance);
    P.cos_angle = static_cast<float>(std::cos(pr.angle));
    P.sin_angle = static_cast<float>(std::sin(pr.angle));
    P.cx = static_cast<float>(pr.centre.x());
    P.cy = static_cast<float>(pr.centre.y());
    P.cz = static_cast<float>(pr.centre.z());
    P.scale = static_cast<float>(pr.scale);
    P.normalise = pr.normalise_cost ? 1.f : 0.f;
    P.eps0 = static_cast<float>(opt.epsilon_start);
    P.decay = static_cast<float>(opt.epsilon_decay);
    P.check = static_cast<float>(std::max(opt.check_every, 1));
    P.omega = static_cast<float>(opt.overrelaxation);
    t.sslots += npad;
    t.tslots += mpad;
  }
  if (t.plan > std::numeric_limits<int>::max() || t.kelems > std::numeric_limits<int>::max())
    throw ArgumentError("Sinkhorn batch: couplings too large for one launch");
  return t;
}

// Log weights per padded slot, uniform when `w` is empty, -1e30 on pads.
template <class R>
void fill_logw(std::vector<R>& out, std::size_t slot, int count, int pad,
               const Eigen::VectorXd* w) {
  const R pad_value = std::is_same<R, double>::value ? R(-1e300) : R(-1e30f);
  const bool given = w && w->size() > 0;
  const R uniform = static_cast<R>(-std::log(static_cast<double>(count)));
  for (int i = 0; i < pad; ++i) {
    if (i >= count)
      out[slot + i] = pad_value;
    else
      out[slot + i] = given ? static_cast<R>(std::log((*w)(i))) : uniform;
  }
}

// Stage 2: the source and target log weights of every problem, as reals of type A.
template <class A>
void upload_log_weights(Context& ctx, const LaunchTable& t, const LaunchProblems& lp, Launch& L) {
  std::vector<A> a(std::max<std::size_t>(t.sslots, 1)), b(std::max<std::size_t>(t.tslots, 1));
  for (std::size_t p = 0; p < lp.par.size(); ++p) {
    const SinkhornLaunchInts& I = t.ints[p];
    fill_logw(a, I.src_slot, I.n, I.npad, &lp.par[p]->source_weights);
    fill_logw(b, I.tgt_slot, I.m, I.mpad, &lp.par[p]->target_weights);
  }
  L.loga = detail::to_device(ctx, a, "Sinkhorn: source log weights");
  L.logb = detail::to_device(ctx, b, "Sinkhorn: target log weights");
  L.host_loga.assign(a.begin(), a.end());
  L.host_logb.assign(b.begin(), b.end());
}

// Stage 3, stabilised scheme only: the persistent work-groups' scratch (K, absorbed duals,
// two generations of log-scalings, the scalings, two generations of the row scalings in ACC,
// the row weights a, and the work counter) as kernel arguments from `next`. Returns how many
// work-groups run: a few per compute unit, each with its own K (see the kernel).
template <class R>
std::size_t bind_stabilised_scratch(Context& ctx, const LaunchTable& t, std::size_t acc,
                                    bc::kernel& k, const char* name, cl_uint next, Launch& L) {
  const std::size_t np = t.ints.size();
  const std::size_t per_cu =
      static_cast<std::size_t>(ctx.tuning().sinkhorn.groups_per_compute_unit);
  const std::size_t groups =
      std::min<std::size_t>(np, per_cu * std::max<std::size_t>(ctx.info().compute_units, 1));
  const std::size_t kbytes = groups * static_cast<std::size_t>(t.kelems) * sizeof(R);
  if (kbytes > ctx.info().max_alloc_bytes && ctx.info().max_alloc_bytes > 0)
    throw ArgumentError("Sinkhorn batch: kernel matrices of " + std::to_string(kbytes) +
                        " bytes exceed the device's largest buffer; use the log-domain scheme");
  const std::size_t ss = t.sslots, ts = t.tslots;
  const std::size_t bytes[] = {kbytes,   ss * acc, ts * acc,     2 * ss * acc, 2 * ts * acc,
                               ss * acc, ts * acc, 2 * ss * acc, ss * acc};
  for (std::size_t b : bytes) {
    L.scratch.push_back(detail::device_buffer(ctx.context(), b, "Sinkhorn: stabilised scratch"));
    detail::set_kernel_arg(k, name, next++, L.scratch.back());
  }
  L.scratch.push_back(detail::to_device(ctx, std::vector<int>{0}, "Sinkhorn: work counter"));
  detail::set_kernel_args_from(k, name, next, L.scratch.back(), static_cast<cl_int>(np),
                               static_cast<cl_long>(t.kelems));
  return groups;
}

template <class R>
Launch launch_typed(Context& ctx, int dim, const bc::buffer& source, const bc::buffer& target,
                    std::size_t source_points, const LaunchProblems& lp,
                    const SinkhornOptions& opt) {
  auto& cx = ctx.context();
  Launch L;
  L.dbl = std::is_same<R, double>::value;
  L.vw = L.dbl ? 8 : 16;  // the kernels' VW (kernels/common/sinkhorn_common.cl)
  const std::size_t np = lp.par.size();
  const LaunchTable t = launch_table(lp, opt, L.vw, L.result.coupling_offset);
  // Sums, scalings and log marginals of the stabilised scheme in double where the device has
  // it: log(1/67) rounded to float moves exp of it by up to 2.4e-7, so sum a and sum b differ
  // by about that much and no plan meets both marginals to the 1e-7 tolerance (measured: the
  // error stalled at 3e-7 on 67 x 50 problems).
  // SinkhornOptions::double_sums false: the caller's tolerances are loose enough for float.
  const bool acc_double = L.dbl || (opt.stabilised && ctx.info().has_fp64 && opt.double_sums);
  const std::size_t acc = acc_double ? sizeof(double) : sizeof(float);
  L.weights_double = acc_double;
  if (acc_double)
    upload_log_weights<double>(ctx, t, lp, L);
  else
    upload_log_weights<float>(ctx, t, lp, L);
  L.ints = t.ints;
  // Held by the Launch (`inputs`) until it is waited for: the kernel reads them after this
  // returns, and the caller works meanwhile.
  const bc::buffer ib = detail::to_device(ctx, t.ints, "Sinkhorn: problem table");
  const bc::buffer pb = detail::to_device(ctx, t.params, "Sinkhorn: problem parameters");
  const bc::buffer sx =
      detail::device_buffer(cx, t.sslots * dim * sizeof(R), "Sinkhorn: scaled source points");
  const bc::buffer tx =
      detail::device_buffer(cx, t.tslots * dim * sizeof(R), "Sinkhorn: scaled target points");
  L.fh = detail::device_buffer(cx, t.sslots * sizeof(R), "Sinkhorn: source duals");
  L.gh = detail::device_buffer(cx, t.tslots * sizeof(R), "Sinkhorn: target duals");
  const bc::buffer fn =
      detail::device_buffer(cx, t.sslots * sizeof(R), "Sinkhorn: next source duals");
  L.inputs = {ib, pb, sx, tx, fn};
  L.result.stats =
      detail::device_buffer(cx, np * sizeof(SinkhornLaunchStats), "Sinkhorn: statistics");
  L.result.coupling = detail::device_buffer(cx, static_cast<std::size_t>(t.plan) * sizeof(float),
                                            "Sinkhorn: couplings");
  L.result.barycentric =
      detail::device_buffer(cx, opt.want_barycentric ? source_points * dim * sizeof(float) : 0,
                            "Sinkhorn: barycentric images");

  int wg = opt.work_group > 0 ? opt.work_group : ctx.tuning().sinkhorn.work_group;
  // PoCL 3.1 quirk: its kernel compiler aborts the process building the log-domain kernel
  // (sinkhorn_solve) with WG 1 or 2 (assertion "Incoming edges to non-entry block!" in
  // ParallelRegion::Verify); the stabilised kernel builds and runs. PoCL's CPU device's tuned
  // sinkhorn.work_group is 1 (default_tuning), so the log-domain scheme takes 4 there, its value
  // before that tuning. An explicit SinkhornOptions::work_group is used as given.
  if (!opt.stabilised && opt.work_group <= 0 && wg < 4 && is_pocl_cpu(ctx.info())) wg = 4;
  if (wg & (wg - 1)) throw ArgumentError("SinkhornOptions::work_group must be a power of two");
  char defs[128];
  std::snprintf(defs, sizeof defs, "-DDIM=%d -DWG=%d -DUSE_DOUBLE=%d -DACC_DOUBLE=%d", dim, wg,
                L.dbl ? 1 : 0, acc_double ? 1 : 0);
  const char* name = opt.stabilised ? "sinkhorn_stab_solve" : "sinkhorn_solve";
  KernelLease lease =
      ctx.lend_kernel(opt.stabilised ? "ot/sinkhorn_stab" : "ot/sinkhorn", name, defs);
  bc::kernel& k = *lease;
  std::size_t groups = np;
  const cl_int want_bary = opt.want_barycentric ? 1 : 0;
  if (opt.stabilised) {
    detail::set_kernel_args(k, name, source, target, ib, pb, L.loga, L.logb, sx, tx, L.fh, L.gh,
                            L.result.stats, L.result.coupling, L.result.barycentric, want_bary);
    groups = bind_stabilised_scratch<R>(ctx, t, acc, k, name, 14, L);
  } else {
    detail::set_kernel_args(k, name, source, target, ib, pb, L.loga, L.logb, sx, tx, L.fh, L.gh, fn,
                            L.result.stats, L.result.coupling, L.result.barycentric, want_bary);
  }
  detail::enqueue_1d(ctx.queue(), k, name, groups * static_cast<std::size_t>(wg), wg);
  return L;
}

Launch launch(Context& ctx, int dim, const bc::buffer& source, const bc::buffer& target,
              std::size_t source_points, const std::vector<int>& soff, const std::vector<int>& scnt,
              const std::vector<int>& toff, const std::vector<int>& tcnt,
              const std::vector<const SinkhornProblem*>& par, const SinkhornOptions& opt) {
  if (opt.use_double && !ctx.info().has_fp64)
    throw ArgumentError("SinkhornOptions::use_double: the device has no cl_khr_fp64");
  if (!(opt.epsilon_decay > 0 && opt.epsilon_decay < 1))
    throw ArgumentError("SinkhornOptions::epsilon_decay must be in (0, 1)");
  if (opt.overrelaxation != 0 && !(opt.overrelaxation >= 1 && opt.overrelaxation < 2))
    throw ArgumentError("SinkhornOptions::overrelaxation must be 0 (adaptive) or in [1, 2), got " +
                        std::to_string(opt.overrelaxation));
  const LaunchProblems lp{soff, scnt, toff, tcnt, par};
  if (opt.use_double) return launch_typed<double>(ctx, dim, source, target, source_points, lp, opt);
  return launch_typed<float>(ctx, dim, source, target, source_points, lp, opt);
}

}  // namespace

std::size_t SinkhornBatch::add(SinkhornProblem problem) {
  validate(problem, problems_.size());
  const int dim = static_cast<int>(problem.source.cols());
  if (dim_ != 0 && dim != dim_)
    throw ArgumentError(at(problems_.size()) + "dimension differs from the batch's");
  dim_ = dim;
  problems_.push_back(std::move(problem));
  return problems_.size() - 1;
}

namespace {

// The launch order of problems [first, first + np) of `all`: the largest first (padded source
// times target points, ties in batch order). The device's work-groups take problems in launch
// order as they free up, so a large problem taken last would run alone while the other cores
// idle (POT's transport: five 200 x 200 plans among small ones, 0.94x the time largest first).
// Each problem is solved alone, so the order changes no result.
std::vector<std::size_t> largest_first(const std::vector<SinkhornProblem>& all, std::size_t first,
                                       std::size_t np) {
  std::vector<std::size_t> order(np);
  std::vector<long> size(np);
  for (std::size_t p = 0; p < np; ++p) {
    order[p] = first + p;
    const SinkhornProblem& pr = all[first + p];
    size[p] = long(pr.source.rows() + 15) / 16 * (long(pr.target.rows() + 15) / 16);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return size[a - first] > size[b - first]; });
  return order;
}

// One launch over problems [first, first + np) of `all`, queued with its reads: the host is
// free until finish_chunk(). Destroyed unfinished, it waits for the queue first (`reads` is
// declared last, so it goes first), so nothing the device still writes is freed under it.
struct ChunkRun {
  std::size_t first = 0, np = 0;
  // Problem p of the launch is the order[p]-th of the batch; its result goes to order[p].
  std::vector<std::size_t> order;
  std::vector<int> soff, scnt, toff, tcnt;
  std::size_t source_points = 0;
  bc::buffer source, target;  // the points, read by the launch
  Launch L;
  std::vector<SinkhornLaunchStats> stats;
  std::vector<float> fh32, gh32, plan, bary;
  std::vector<double> fh64, gh64;
  std::unique_ptr<detail::BatchedReads> reads;
};

std::unique_ptr<ChunkRun> start_chunk(Context& ctx, const std::vector<SinkhornProblem>& all,
                                      std::size_t first, std::size_t np, int dim,
                                      const SinkhornOptions& opt) {
  auto c = std::make_unique<ChunkRun>();
  c->first = first;
  c->np = np;
  c->order = largest_first(all, first, np);
  c->soff.resize(np);
  c->scnt.resize(np);
  c->toff.resize(np);
  c->tcnt.resize(np);
  std::vector<const SinkhornProblem*> par(np);
  // Offsets first, then the points written in place (a ranking launch packs a few hundred
  // problems: element-wise appends were a tenth of its host time).
  std::size_t ns = 0, nt = 0;
  for (std::size_t p = 0; p < np; ++p) {
    const auto& pr = all[c->order[p]];
    par[p] = &pr;
    c->soff[p] = static_cast<int>(ns);
    c->toff[p] = static_cast<int>(nt);
    c->scnt[p] = static_cast<int>(pr.source.rows());
    c->tcnt[p] = static_cast<int>(pr.target.rows());
    ns += static_cast<std::size_t>(pr.source.rows());
    nt += static_cast<std::size_t>(pr.target.rows());
  }
  std::vector<float> src(ns * dim), tgt(nt * dim);
  auto pack = [dim](const Eigen::MatrixXd& pts, float* out) {
    for (Eigen::Index i = 0; i < pts.rows(); ++i)
      for (int d = 0; d < dim; ++d) out[i * dim + d] = static_cast<float>(pts(i, d));
  };
  for (std::size_t p = 0; p < np; ++p) {
    pack(par[p]->source, src.data() + std::size_t(c->soff[p]) * dim);
    pack(par[p]->target, tgt.data() + std::size_t(c->toff[p]) * dim);
  }
  c->source_points = src.size() / dim;
  c->source = detail::to_device(ctx, src, "Sinkhorn: source points");
  c->target = detail::to_device(ctx, tgt, "Sinkhorn: target points");
  c->L = launch(ctx, dim, c->source, c->target, c->source_points, c->soff, c->scnt, c->toff,
                c->tcnt, par, opt);

  // Every buffer the caller asked for, read in one wait (detail::BatchedReads).
  Launch& L = c->L;
  const SinkhornLaunchInts& last = L.ints[np - 1];
  const std::size_t sslots = last.src_slot + last.npad, tslots = last.tgt_slot + last.mpad;
  c->stats.resize(np);
  c->reads = std::make_unique<detail::BatchedReads>(ctx.queue());
  detail::BatchedReads& reads = *c->reads;
  reads.read(L.result.stats, c->stats);
  if (opt.want_duals) {
    if (L.dbl) {
      c->fh64.resize(sslots);
      c->gh64.resize(tslots);
      reads.read(L.fh, c->fh64);
      reads.read(L.gh, c->gh64);
    } else {
      c->fh32.resize(sslots);
      c->gh32.resize(tslots);
      reads.read(L.fh, c->fh32);
      reads.read(L.gh, c->gh32);
    }
  }
  if (opt.want_coupling) {
    const long total =
        L.result.coupling_offset[np - 1] + static_cast<long>(c->scnt[np - 1]) * c->tcnt[np - 1];
    c->plan.resize(static_cast<std::size_t>(total));
    reads.read(L.result.coupling, c->plan);
  }
  if (opt.want_barycentric) {
    c->bary.resize(src.size());
    reads.read(L.result.barycentric, c->bary);
  }
  // Submitted now, not at the wait: the device works while the caller does.
  detail::cl_call("clFlush", [&] { ctx.queue().flush(); });
  return c;
}

// Waits for a started chunk and unpacks its results, in batch order.
std::vector<SinkhornResult> finish_chunk(ChunkRun& c, const std::vector<SinkhornProblem>& all,
                                         int dim, const SinkhornOptions& opt) {
  c.reads->wait();
  const Launch& L = c.L;
  auto fh = [&](std::size_t i) { return L.dbl ? c.fh64[i] : double(c.fh32[i]); };
  auto gh = [&](std::size_t j) { return L.dbl ? c.gh64[j] : double(c.gh32[j]); };
  const std::vector<double>&la = L.host_loga, &lb = L.host_logb;

  std::vector<SinkhornResult> out(c.np);
  for (std::size_t p = 0; p < c.np; ++p) {
    auto& r = out[c.order[p] - c.first];
    const auto& pr = all[c.order[p]];
    r.cost = c.stats[p].cost;
    r.iterations = static_cast<int>(c.stats[p].iterations);
    r.marginal_error = c.stats[p].marginal_error;
    r.converged = c.stats[p].converged != 0;
    const int n = c.scnt[p], m = c.tcnt[p];
    const int ss = L.ints[p].src_slot, ts = L.ints[p].tgt_slot;
    if (opt.want_duals) {
      r.f.resize(n);
      r.g.resize(m);
      for (int i = 0; i < n; ++i) r.f(i) = (fh(ss + i) - la[ss + i]) * pr.epsilon;
      for (int j = 0; j < m; ++j) r.g(j) = (gh(ts + j) - lb[ts + j]) * pr.epsilon;
    }
    if (opt.want_coupling)  // the device writes the plan column by column, as Eigen keeps it
      r.coupling =
          Eigen::Map<const Eigen::MatrixXf>(c.plan.data() + L.result.coupling_offset[p], n, m)
              .cast<double>();
    if (opt.want_barycentric) {
      r.barycentric.resize(n, dim);
      for (int i = 0; i < n; ++i)
        for (int d = 0; d < dim; ++d) r.barycentric(i, d) = c.bary[(c.soff[p] + i) * dim + d];
      r.extra_mapped = out_of_sample_map(pr, r.barycentric, pr.extra_points);
    }
  }
  return out;
}

// The end of the launch that starts at problem `first`: at most about chunk_slots padded
// points (source and target) each. The device scratch (duals, scalings, transformed points:
// about 100 bytes a slot) grows with a launch, and a scan ranked against thousands of atoms
// holds 10^5 problems (measured with 2000 atoms: 2.1 GB resident in one launch). Results do
// not depend on the chunking.
std::size_t chunk_end(const std::vector<SinkhornProblem>& all, std::size_t first,
                      std::size_t chunk_slots) {
  std::size_t end = first, slots = 0;
  while (end < all.size() && (end == first || slots < chunk_slots)) {
    slots += static_cast<std::size_t>(all[end].source.rows() + 16) +
             static_cast<std::size_t>(all[end].target.rows() + 16);
    ++end;
  }
  return end;
}

}  // namespace

struct SinkhornRun::State {
  Context* ctx = nullptr;
  const std::vector<SinkhornProblem>* problems = nullptr;
  int dim = 0;
  SinkhornOptions options;
  std::unique_ptr<ChunkRun> first;  // the launch in flight; the later ones start at wait()
};

SinkhornRun::SinkhornRun() = default;
SinkhornRun::SinkhornRun(SinkhornRun&&) noexcept = default;
SinkhornRun& SinkhornRun::operator=(SinkhornRun&&) noexcept = default;
SinkhornRun::~SinkhornRun() = default;

std::vector<SinkhornResult> SinkhornRun::wait() {
  if (!state_) throw ArgumentError("SinkhornRun::wait: nothing started, or already waited for");
  const std::unique_ptr<State> st = std::move(state_);
  const std::vector<SinkhornProblem>& all = *st->problems;
  std::vector<SinkhornResult> out;
  out.reserve(all.size());
  std::unique_ptr<ChunkRun> run = std::move(st->first);
  const std::size_t chunk_slots = st->ctx->tuning().sinkhorn.chunk_slots;  // SinkhornTuning
  while (run) {
    for (auto& r : finish_chunk(*run, all, st->dim, st->options)) out.push_back(std::move(r));
    const std::size_t first = run->first + run->np;
    run.reset();  // one launch's device scratch at a time
    if (first < all.size())
      run = start_chunk(*st->ctx, all, first, chunk_end(all, first, chunk_slots) - first, st->dim,
                        st->options);
  }
  return out;
}

SinkhornRun SinkhornBatch::start(Context& ctx, const SinkhornOptions& opt) const {
  SinkhornRun r;
  r.state_ = std::make_unique<SinkhornRun::State>();
  SinkhornRun::State& st = *r.state_;
  st.ctx = &ctx;
  st.problems = &problems_;
  st.dim = dim_;
  st.options = opt;
  if (!problems_.empty())
    st.first = start_chunk(ctx, problems_, 0,
                           chunk_end(problems_, 0, ctx.tuning().sinkhorn.chunk_slots), dim_, opt);
  return r;
}

std::vector<SinkhornResult> SinkhornBatch::run(Context& ctx, const SinkhornOptions& opt) const {
  return start(ctx, opt).wait();
}

SinkhornDeviceResult sinkhorn_device(Context& ctx, const SinkhornDeviceBatch& batch,
                                     const SinkhornOptions& options) {
  const std::size_t np = batch.problems;
  if (batch.dim != 2 && batch.dim != 3) throw ArgumentError("SinkhornDeviceBatch: dim 2 or 3");
  if (batch.source_offset.size() != np || batch.source_count.size() != np ||
      batch.target_offset.size() != np || batch.target_count.size() != np ||
      batch.params.size() != np)
    throw ArgumentError("SinkhornDeviceBatch: per-problem vectors must have `problems` entries");
  std::vector<const SinkhornProblem*> par(np);
  std::size_t src_end = 0, tgt_end = 0;
  for (std::size_t p = 0; p < np; ++p) {
    if (batch.source_count[p] < 1) throw ArgumentError(at(p) + "empty source point set");
    if (batch.target_count[p] < 1) throw ArgumentError(at(p) + "empty target point set");
    par[p] = &batch.params[p];
    src_end = std::max<std::size_t>(src_end, batch.source_offset[p] + batch.source_count[p]);
    tgt_end = std::max<std::size_t>(tgt_end, batch.target_offset[p] + batch.target_count[p]);
  }
  if (src_end * batch.dim * sizeof(float) > batch.source.size() ||
      tgt_end * batch.dim * sizeof(float) > batch.target.size())
    throw ArgumentError("SinkhornDeviceBatch: point buffers smaller than the offsets say");
  if (np == 0) return {};
  for (std::size_t p = 0; p < np; ++p) {
    SinkhornProblem check = batch.params[p];
    check.source = Eigen::MatrixXd::Zero(1, batch.dim);
    check.target = Eigen::MatrixXd::Zero(1, batch.dim);
    check.source_weights.resize(0);
    check.target_weights.resize(0);
    check.extra_points.resize(0, batch.dim);
    validate(check, p);
  }
  // Given weights are a host-batch feature: uniform here (documented).
  std::vector<SinkhornProblem> uniform(batch.params.begin(), batch.params.end());
  for (std::size_t p = 0; p < np; ++p) {
    uniform[p].source_weights.resize(0);
    uniform[p].target_weights.resize(0);
    par[p] = &uniform[p];
  }
  Launch L = launch(ctx, batch.dim, batch.source, batch.target, src_end, batch.source_offset,
                    batch.source_count, batch.target_offset, batch.target_count, par, options);
  L.result.working = L.inputs;
  for (const bc::buffer* b : {&L.fh, &L.gh, &L.loga, &L.logb}) L.result.working.push_back(*b);
  L.result.working.insert(L.result.working.end(), L.scratch.begin(), L.scratch.end());
  return std::move(L.result);
}

}  // namespace potmap
