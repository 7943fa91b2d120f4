// MapEvaluator: construction, the public calls, and the batch path over host points
// (kernels/map/evaluate.cl). The grid path is in evaluate_grid.cpp, the device path in
// evaluate_cells.cpp.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>

#include "map/evaluator_impl.hpp"
#include "map/split_float.hpp"
#include "potmap/error.hpp"
#include "runtime/host_team.hpp"

namespace bc = boost::compute;

namespace potmap {

namespace detail {

KernelLists flatten(const std::vector<std::vector<std::uint32_t>>& lists) {
  const std::size_t n = lists.size();
  KernelLists out;
  out.start.assign(n + 1, 0);
  for (std::size_t t = 0; t < n; ++t) out.start[t + 1] = out.start[t] + lists[t].size();
  out.flat.resize(std::max<std::size_t>(out.start[n], 1));
  for (std::size_t t = 0; t < n; ++t)
    std::copy(lists[t].begin(), lists[t].end(), out.flat.begin() + out.start[t]);
  return out;
}

}  // namespace detail

namespace {

// Interleaves the low 21 bits of x, y, z (Morton order keeps nearby tiles nearby in memory).
std::uint64_t spread(std::uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffull;
  v = (v | v << 16) & 0x1f0000ff0000ffull;
  v = (v | v << 8) & 0x100f00f00f00f00full;
  v = (v | v << 4) & 0x10c30c30c30c30c3ull;
  v = (v | v << 2) & 0x1249249249249249ull;
  return v;
}

// Stable LSD radix sort of indices by key, 11 bits a pass; only the passes max_key needs.
std::vector<std::uint32_t> radix_order(const std::vector<std::uint64_t>& key,
                                       std::uint64_t max_key) {
  const std::size_t n = key.size();
  std::vector<std::uint32_t> a(n), b(n);
  std::iota(a.begin(), a.end(), 0u);
  for (int shift = 0; shift < 64 && (max_key >> shift) != 0; shift += 11) {
    std::size_t count[2049] = {0};
    for (std::uint32_t i : a) ++count[((key[i] >> shift) & 2047) + 1];
    for (int d = 0; d < 2048; ++d) count[d + 1] += count[d];
    for (std::uint32_t i : a) b[count[(key[i] >> shift) & 2047]++] = i;
    a.swap(b);
  }
  return a;
}

// The finite points of a batch (indices into it) and their bounding box.
struct FinitePoints {
  std::vector<std::uint32_t> index;
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
};

// Stage 1: finite points only; the others get NaN in every output asked for.
FinitePoints keep_finite(const double* pts, std::size_t n, int dim, float* out_m, float* out_v,
                         float* out_p) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  FinitePoints f;
  f.index.reserve(n);
  for (int d = 0; d < dim; ++d) {
    f.lo[d] = std::numeric_limits<double>::infinity();
    f.hi[d] = -f.lo[d];
  }
  for (std::size_t i = 0; i < n; ++i) {
    bool ok = true;
    for (int d = 0; d < dim; ++d) ok = ok && std::isfinite(pts[i * dim + d]);
    if (!ok) {
      if (out_m) out_m[i] = nan;
      if (out_v) out_v[i] = nan;
      if (out_p) out_p[i] = nan;
      continue;
    }
    f.index.push_back(static_cast<std::uint32_t>(i));
    for (int d = 0; d < dim; ++d) {
      f.lo[d] = std::min(f.lo[d], pts[i * dim + d]);
      f.hi[d] = std::max(f.hi[d], pts[i * dim + d]);
    }
  }
  return f;
}

// Stage 2: the finite points bucketed into tiles holding about one chunk each, tiles in Morton
// order, so that consecutive points (one chunk) are close together and share one short kernel
// list. Returns positions into f.index.
std::vector<std::uint32_t> morton_order(const double* pts, int dim, const FinitePoints& f,
                                        std::size_t chunk) {
  const std::size_t nf = f.index.size();
  double volume = 1;
  for (int d = 0; d < dim; ++d) volume *= std::max(f.hi[d] - f.lo[d], 1e-3);
  double tile = std::pow(volume * chunk / nf, 1.0 / dim);
  tile = std::clamp(tile, 0.05, 1e6);
  std::int64_t nt[3] = {1, 1, 1};
  for (int d = 0; d < dim; ++d) {
    nt[d] = static_cast<std::int64_t>((f.hi[d] - f.lo[d]) / tile) + 1;
    nt[d] = std::min<std::int64_t>(nt[d], 1 << 20);
  }
  std::vector<std::uint64_t> key(nf);
  for (std::size_t j = 0; j < nf; ++j) {
    const double* p = pts + std::size_t(f.index[j]) * dim;
    std::uint64_t code = 0;
    for (int d = 0; d < dim; ++d) {
      std::int64_t t = std::clamp<std::int64_t>(static_cast<std::int64_t>((p[d] - f.lo[d]) / tile),
                                                0, nt[d] - 1);
      code |= spread(static_cast<std::uint64_t>(t)) << d;
    }
    key[j] = code;
  }
  std::uint64_t max_key = 0;
  for (std::uint64_t k : key) max_key = std::max(max_key, k);
  return radix_order(key, max_key);
}

// Queries of a batch as the kernel reads them: coordinates structure-of-arrays relative to the
// anchor (hi + lo floats), padded to whole chunks, and each slot's index in the caller's order
// (-1 on pads).
struct PackedQueries {
  std::size_t padded = 0;
  std::vector<float> hi, lo;
  std::vector<int> order;
};

// Stage 3: chunks of consecutive sorted points, padded with the chunk's last point.
PackedQueries pack_chunks(Context* ctx, const double* pts, int dim, const double* anchor,
                          const FinitePoints& f, const std::vector<std::uint32_t>& perm,
                          std::size_t chunk) {
  const std::size_t nf = f.index.size();
  PackedQueries q;
  q.padded = (nf + chunk - 1) / chunk * chunk;
  const std::size_t padded = q.padded;
  q.hi.resize(padded * dim);
  q.lo.resize(padded * dim);
  q.order.assign(padded, -1);
  const long long npad = static_cast<long long>(padded);
  // On the context's host team, in ranges of slots: OpenMP's idle workers spin for
  // milliseconds after a region, on the cores the device's workers need next.
  constexpr long long kRange = 4096;
  detail::for_each_item(ctx, std::size_t((npad + kRange - 1) / kRange), [&](std::size_t r) {
    const long long s1 = std::min(npad, (long long)(r + 1) * kRange);
    for (long long s = (long long)r * kRange; s < s1; ++s) {
      const std::size_t j = perm[std::min<std::size_t>(s, nf - 1)];
      const double* p = pts + std::size_t(f.index[j]) * dim;
      for (int d = 0; d < dim; ++d)
        detail::split(p[d] - anchor[d], q.hi[d * padded + s], q.lo[d * padded + s]);
      if (static_cast<std::size_t>(s) < nf) q.order[s] = static_cast<int>(f.index[j]);
    }
  });
  return q;
}

// Stage 4a: the bounding box of each chunk's points (lo[3], hi[3]; unused axes 0).
std::vector<std::array<double, 6>> chunk_boxes(Context* ctx, const double* pts, int dim,
                                               const FinitePoints& f,
                                               const std::vector<std::uint32_t>& perm,
                                               std::size_t chunk, std::size_t nchunks) {
  const std::size_t nf = f.index.size();
  std::vector<std::array<double, 6>> box(nchunks);
  detail::for_each_item(ctx, nchunks, [&](std::size_t c) {
    std::array<double, 6>& bx = box[c];
    for (int d = 0; d < 3; ++d) {
      bx[d] = d < dim ? std::numeric_limits<double>::infinity() : 0.0;
      bx[3 + d] = d < dim ? -std::numeric_limits<double>::infinity() : 0.0;
    }
    const std::size_t s0 = c * chunk, s1 = std::min(nf, s0 + chunk);
    for (std::size_t s = s0; s < s1; ++s) {
      const double* p = pts + std::size_t(f.index[perm[s]]) * dim;
      for (int d = 0; d < dim; ++d) {
        bx[d] = std::min(bx[d], p[d]);
        bx[3 + d] = std::max(bx[3 + d], p[d]);
      }
    }
  });
  return box;
}

// Stage 4b: the kernel list of each chunk: every kernel whose cut-off reaches the chunk's
// box. The index is asked once per group of `group` chunks (neighbours in Morton order); each
// chunk then filters the group's candidates, which costs far less than one index walk per
// chunk.
std::vector<std::vector<std::uint32_t>> chunk_kernel_lists(
    Context* ctx, const KernelMap& map, const detail::KernelIndex& index, double tau,
    const std::vector<std::array<double, 6>>& box, std::size_t group) {
  const int dim = map.dim;
  const std::size_t nchunks = box.size();
  const long long ngroups = static_cast<long long>((nchunks + group - 1) / group);
  std::vector<std::vector<std::uint32_t>> lists(nchunks);
  const double* kp = map.position.data();
  const double* kg = map.gamma.data();
  detail::for_each_item(ctx, std::size_t(ngroups), [&](std::size_t gi) {
    const std::size_t c0 = gi * group, c1 = std::min(nchunks, c0 + group);
    double glo[3] = {0, 0, 0}, ghi[3] = {0, 0, 0};
    for (int d = 0; d < dim; ++d) {
      glo[d] = box[c0][d];
      ghi[d] = box[c0][3 + d];
      for (std::size_t c = c0 + 1; c < c1; ++c) {
        glo[d] = std::min(glo[d], box[c][d]);
        ghi[d] = std::max(ghi[d], box[c][3 + d]);
      }
    }
    std::vector<std::uint32_t> cand;
    index.query_box(glo, ghi, cand);
    for (std::size_t c = c0; c < c1; ++c) {
      std::vector<std::uint32_t>& out = lists[c];
      out.reserve(cand.size());
      for (std::uint32_t k : cand) {
        double d2 = 0;
        for (int d = 0; d < dim; ++d) {
          const double p = kp[k * dim + d];
          const double q = std::clamp(p, box[c][d], box[c][3 + d]);
          d2 += (p - q) * (p - q);
        }
        if (kg[k] * d2 <= tau) out.push_back(k);
      }
    }
  });
  return lists;
}

}  // namespace

MapEvaluator::Impl::Impl(Context& c, const KernelMap& m, const EvalOptions& o)
    : ctx(&c),
      map(m),
      opt(o),
      tuning(c.tuning().map_eval),
      raster_rows(c.tuning().raster.rows_per_item),
      raster_tile(c.tuning().raster.tile) {
  map.validate();
  if (!(opt.tau > 0) || !std::isfinite(opt.tau))
    throw ArgumentError("EvalOptions::tau must be positive, got " + std::to_string(opt.tau));
  opt.tau = std::min(opt.tau, map.cutoff_tau);  // terms past the map's own cut-off are not in it
  index = detail::KernelIndex(map, opt.tau);
  double lo[3], hi[3];
  map.bounds(lo, hi);
  for (int d = 0; d < map.dim; ++d) anchor[d] = std::round(0.5 * (lo[d] + hi[d]));
  char buf[160];
  std::snprintf(buf, sizeof buf, "-DDIM=%d -DVEC=%d -DTAU=%#.9gf -cl-denorms-are-zero", map.dim,
                tuning.vector_width, opt.tau);
  defines = buf;
  bias_mean = map.has_bias ? static_cast<float>(map.bias_mean) : 0.f;
  bias_var = map.has_bias ? static_cast<float>(map.bias_var) : 0.f;

  const std::size_t m_count = std::max<std::size_t>(map.size(), 1);
  std::vector<float> hi_f(m_count * map.dim, 0.f), lo_f(m_count * map.dim, 0.f);
  std::vector<float> par(m_count * 4, 0.f);
  for (std::size_t k = 0; k < map.size(); ++k) {
    for (int d = 0; d < map.dim; ++d)
      detail::split(map.position[k * map.dim + d] - anchor[d], hi_f[k * map.dim + d],
                    lo_f[k * map.dim + d]);
    par[4 * k + 0] = static_cast<float>(map.gamma[k]);
    par[4 * k + 1] = static_cast<float>(map.w_mean[k]);
    par[4 * k + 2] = static_cast<float>(map.w_var[k]);
  }
  kpos_hi = detail::to_device(*ctx, hi_f, "evaluator: kernel positions (hi)");
  kpos_lo = detail::to_device(*ctx, lo_f, "evaluator: kernel positions (lo)");
  kpar = detail::to_device(*ctx, par, "evaluator: kernel parameters");
}

void MapEvaluator::Impl::run_batch(const double* pts, std::size_t n, float* out_m, float* out_v,
                                   float* out_p) {
  const int dim = map.dim;
  const std::size_t wg = static_cast<std::size_t>(tuning.work_group);
  const std::size_t chunk = static_cast<std::size_t>(tuning.vector_width) * wg;

  const FinitePoints finite = keep_finite(pts, n, dim, out_m, out_v, out_p);
  if (finite.index.empty()) return;
  const std::vector<std::uint32_t> perm = morton_order(pts, dim, finite, chunk);
  const PackedQueries packed = pack_chunks(ctx, pts, dim, anchor, finite, perm, chunk);
  const std::size_t nchunks = packed.padded / chunk;
  const detail::KernelLists lists = detail::flatten(chunk_kernel_lists(
      ctx, map, index, opt.tau, chunk_boxes(ctx, pts, dim, finite, perm, chunk, nchunks),
      static_cast<std::size_t>(tuning.chunks_per_query)));
  last_pairs += static_cast<std::size_t>(lists.start[nchunks]) * chunk;

  // Stage 5: upload, run, read back.
  auto& cx = ctx->context();
  auto& q = ctx->queue();
  detail::BatchedReads reads(q);  // first: it outlives nothing the queued writes read
  bc::buffer& b_qh = q_hi.put(cx, q, packed.hi);
  bc::buffer& b_ql = q_lo.put(cx, q, packed.lo);
  bc::buffer& b_start = chunk_start.put(cx, q, lists.start);
  bc::buffer& b_list = list.put(cx, q, lists.flat);
  bc::buffer& b_ord = order.put(cx, q, packed.order);
  bc::buffer& b_m = out_mean.get(cx, n * 4);
  bc::buffer& b_v = out_var.get(cx, n * 4);
  bc::buffer& b_p = out_prob.get(cx, n * 4);
  KernelLease k = ctx->lend_kernel("map/evaluate", "map_eval_points", defines);
  detail::launch_1d(q, *k, "map_eval_points", nchunks * wg, wg, kpos_hi, kpos_lo, kpar, b_qh, b_ql,
                    static_cast<cl_uint>(packed.padded), b_start, b_list, b_ord, bias_mean,
                    bias_var, b_m, b_v, b_p);
  // Outputs were scattered to the caller's order; NaN slots (non-finite points) are untouched
  // on the device, so read only through the host's finite set when any were dropped.
  std::vector<float> tmp[3];
  float* const dsts[3] = {out_m, out_v, out_p};
  bc::buffer* const bufs[3] = {&b_m, &b_v, &b_p};
  for (int o = 0; o < 3; ++o) {
    if (!dsts[o]) continue;
    tmp[o].resize(n);
    reads.read(*bufs[o], tmp[o]);
  }
  reads.wait();
  for (int o = 0; o < 3; ++o)
    if (dsts[o])
      for (std::uint32_t i : finite.index) dsts[o][i] = tmp[o][i];
}

MapEvaluator::MapEvaluator(Context& ctx, const KernelMap& map, const EvalOptions& options)
    : impl_(std::make_unique<Impl>(ctx, map, options)) {}
MapEvaluator::~MapEvaluator() = default;
MapEvaluator::MapEvaluator(MapEvaluator&&) noexcept = default;
MapEvaluator& MapEvaluator::operator=(MapEvaluator&&) noexcept = default;

int MapEvaluator::dim() const {
  return impl_->map.dim;
}
std::size_t MapEvaluator::last_pairs() const {
  return impl_->last_pairs;
}

void MapEvaluator::evaluate(const double* points, std::size_t n, float* mean, float* var,
                            float* prob) {
  impl_->last_pairs = 0;
  if (n == 0) return;
  if (!points) throw ArgumentError("MapEvaluator::evaluate: points is null but n > 0");
  const int dim = impl_->map.dim;
  const std::size_t batch = std::max<std::size_t>(impl_->opt.points_per_launch, 1);
  for (std::size_t s = 0; s < n; s += batch) {
    const std::size_t m = std::min(batch, n - s);
    impl_->run_batch(points + s * dim, m, mean ? mean + s : nullptr, var ? var + s : nullptr,
                     prob ? prob + s : nullptr);
  }
}

MapValues MapEvaluator::evaluate(const std::vector<double>& points) {
  const int dim = impl_->map.dim;
  if (points.size() % dim != 0)
    throw ArgumentError("MapEvaluator::evaluate: " + std::to_string(points.size()) +
                        " coordinates is not a whole number of " + std::to_string(dim) +
                        "D points");
  const std::size_t n = points.size() / dim;
  MapValues v;
  v.mean.resize(n);
  v.var.resize(n);
  v.prob.resize(n);
  evaluate(points.data(), n, v.mean.data(), v.var.data(), v.prob.data());
  return v;
}

void MapEvaluator::evaluate_grid(const GridSpec& grid, float* mean, float* var, float* prob) {
  impl_->run_grid(grid, mean, var, prob);
}

MapValues MapEvaluator::evaluate_grid(const GridSpec& grid) {
  MapValues v;
  v.mean.resize(grid.cells());
  v.var.resize(grid.cells());
  v.prob.resize(grid.cells());
  evaluate_grid(grid, v.mean.data(), v.var.data(), v.prob.data());
  return v;
}

}  // namespace potmap
