#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>

#include <boost/compute/buffer.hpp>

#include "cl_check.hpp"
#include "kernel_index.hpp"
#include "potmap/error.hpp"
#include "potmap/evaluate.hpp"
#include "split_float.hpp"

namespace bc = boost::compute;

namespace potmap {

namespace {

// Points per device launch: bounds the memory of the chunk lists (about 500 entries a chunk).
constexpr std::size_t kPointsPerBatch = std::size_t(1) << 21;

// A device buffer that only grows.
struct GrowBuffer {
  bc::buffer buf;
  std::size_t bytes = 0;
  bc::buffer& get(bc::context& ctx, std::size_t need) {
    need = std::max<std::size_t>(need, 64);
    if (need > bytes) {
      bytes = need + need / 4;
      buf = detail::cl_call("clCreateBuffer", [&] { return bc::buffer(ctx, bytes); });
    }
    return buf;
  }
};

template <class T>
void upload(bc::command_queue& q, bc::buffer& b, const std::vector<T>& v) {
  if (v.empty()) return;
  detail::cl_call("clEnqueueWriteBuffer",
                  [&] { q.enqueue_write_buffer(b, 0, v.size() * sizeof(T), v.data()); });
}

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

}  // namespace

struct MapEvaluator::Impl {
  Context* ctx;
  KernelMap map;  // own copy: the index points into it
  EvalOptions opt;
  detail::KernelIndex index;
  double anchor[3] = {0, 0, 0};
  int vec = 16, wg = 8;
  std::string defines;
  bc::buffer kpos_hi, kpos_lo, kpar;
  GrowBuffer q_hi, q_lo, chunk_start, list, order, out_mean, out_var, out_prob;
  std::size_t last_pairs = 0;

  Impl(Context& c, const KernelMap& m, const EvalOptions& o) : ctx(&c), map(m), opt(o) {
    map.validate();
    if (!(opt.tau > 0) || !std::isfinite(opt.tau))
      throw ArgumentError("EvalOptions::tau must be positive, got " + std::to_string(opt.tau));
    index = detail::KernelIndex(map, opt.tau);
    double lo[3], hi[3];
    map.bounds(lo, hi);
    for (int d = 0; d < map.dim; ++d) anchor[d] = std::round(0.5 * (lo[d] + hi[d]));
    // CPU devices (PoCL) want wide explicit vectors; GPUs want many light work-items.
    if (!ctx->info().is_cpu) {
      vec = 4;
      wg = 64;
    }
    char buf[160];
    std::snprintf(buf, sizeof buf, "-DDIM=%d -DVEC=%d -DTAU=%.9ef", map.dim, vec, opt.tau);
    defines = buf;

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
    auto& cx = ctx->context();
    kpos_hi = detail::cl_call("clCreateBuffer", [&] { return bc::buffer(cx, hi_f.size() * 4); });
    kpos_lo = detail::cl_call("clCreateBuffer", [&] { return bc::buffer(cx, lo_f.size() * 4); });
    kpar = detail::cl_call("clCreateBuffer", [&] { return bc::buffer(cx, par.size() * 4); });
    upload(ctx->queue(), kpos_hi, hi_f);
    upload(ctx->queue(), kpos_lo, lo_f);
    upload(ctx->queue(), kpar, par);
  }

  void run_batch(const double* pts, std::size_t n, float* mean, float* var, float* prob);
};

void MapEvaluator::Impl::run_batch(const double* pts, std::size_t n, float* out_m, float* out_v,
                                   float* out_p) {
  const int dim = map.dim;
  const std::size_t chunk = static_cast<std::size_t>(vec) * wg;
  const float nan = std::numeric_limits<float>::quiet_NaN();

  // 1. Finite points only; the rest get NaN.
  std::vector<std::uint32_t> finite;
  finite.reserve(n);
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (int d = 0; d < dim; ++d) {
    lo[d] = std::numeric_limits<double>::infinity();
    hi[d] = -lo[d];
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
    finite.push_back(static_cast<std::uint32_t>(i));
    for (int d = 0; d < dim; ++d) {
      lo[d] = std::min(lo[d], pts[i * dim + d]);
      hi[d] = std::max(hi[d], pts[i * dim + d]);
    }
  }
  const std::size_t nf = finite.size();
  if (nf == 0) return;

  // 2. Bucket points into tiles holding about one chunk each, tiles in Morton order, so that
  //    consecutive points (one chunk) are close together and share one short kernel list.
  double volume = 1;
  for (int d = 0; d < dim; ++d) volume *= std::max(hi[d] - lo[d], 1e-3);
  double tile = std::pow(volume * chunk / nf, 1.0 / dim);
  tile = std::clamp(tile, 0.05, 1e6);
  std::int64_t nt[3] = {1, 1, 1};
  for (int d = 0; d < dim; ++d) {
    nt[d] = static_cast<std::int64_t>((hi[d] - lo[d]) / tile) + 1;
    nt[d] = std::min<std::int64_t>(nt[d], 1 << 20);
  }
  std::vector<std::uint64_t> key(nf);
  for (std::size_t j = 0; j < nf; ++j) {
    const double* p = pts + std::size_t(finite[j]) * dim;
    std::uint64_t code = 0;
    for (int d = 0; d < dim; ++d) {
      std::int64_t t = std::clamp<std::int64_t>(static_cast<std::int64_t>((p[d] - lo[d]) / tile),
                                                0, nt[d] - 1);
      code |= spread(static_cast<std::uint64_t>(t)) << d;
    }
    key[j] = code;
  }
  std::vector<std::uint32_t> perm(nf);
  std::iota(perm.begin(), perm.end(), 0u);
  std::sort(perm.begin(), perm.end(),
            [&](std::uint32_t a, std::uint32_t b) { return key[a] < key[b]; });

  // 3. Chunks of consecutive sorted points, padded with the chunk's last point.
  const std::size_t nchunks = (nf + chunk - 1) / chunk;
  const std::size_t padded = nchunks * chunk;
  std::vector<float> qh(padded * dim), ql(padded * dim);
  std::vector<int> ord(padded, -1);
  for (std::size_t s = 0; s < padded; ++s) {
    const std::size_t j = perm[std::min(s, nf - 1)];
    const double* p = pts + std::size_t(finite[j]) * dim;
    for (int d = 0; d < dim; ++d) detail::split(p[d] - anchor[d], qh[d * padded + s], ql[d * padded + s]);
    if (s < nf) ord[s] = static_cast<int>(finite[j]);
  }

  // 4. Kernel list of each chunk: every kernel whose cut-off reaches the chunk's bounding box.
  std::vector<std::vector<std::uint32_t>> lists(nchunks);
  const long long nc = static_cast<long long>(nchunks);
#pragma omp parallel for schedule(dynamic, 16)
  for (long long c = 0; c < nc; ++c) {
    double blo[3] = {0, 0, 0}, bhi[3] = {0, 0, 0};
    for (int d = 0; d < dim; ++d) {
      blo[d] = std::numeric_limits<double>::infinity();
      bhi[d] = -blo[d];
    }
    const std::size_t s0 = c * chunk, s1 = std::min(nf, s0 + chunk);
    for (std::size_t s = s0; s < s1; ++s) {
      const double* p = pts + std::size_t(finite[perm[s]]) * dim;
      for (int d = 0; d < dim; ++d) {
        blo[d] = std::min(blo[d], p[d]);
        bhi[d] = std::max(bhi[d], p[d]);
      }
    }
    index.query_box(blo, bhi, lists[c]);
  }
  std::vector<std::uint32_t> start(nchunks + 1, 0);
  for (std::size_t c = 0; c < nchunks; ++c) start[c + 1] = start[c] + lists[c].size();
  std::vector<std::uint32_t> flat(std::max<std::size_t>(start[nchunks], 1));
  for (std::size_t c = 0; c < nchunks; ++c)
    std::copy(lists[c].begin(), lists[c].end(), flat.begin() + start[c]);
  last_pairs += static_cast<std::size_t>(start[nchunks]) * chunk;

  // 5. Upload, run, read back.
  auto& cx = ctx->context();
  auto& q = ctx->queue();
  bc::buffer& b_qh = q_hi.get(cx, qh.size() * 4);
  bc::buffer& b_ql = q_lo.get(cx, ql.size() * 4);
  bc::buffer& b_start = chunk_start.get(cx, start.size() * 4);
  bc::buffer& b_list = list.get(cx, flat.size() * 4);
  bc::buffer& b_ord = order.get(cx, ord.size() * 4);
  bc::buffer& b_m = out_mean.get(cx, n * 4);
  bc::buffer& b_v = out_var.get(cx, n * 4);
  bc::buffer& b_p = out_prob.get(cx, n * 4);
  upload(q, b_qh, qh);
  upload(q, b_ql, ql);
  upload(q, b_start, start);
  upload(q, b_list, flat);
  upload(q, b_ord, ord);

  bc::kernel k = ctx->kernel("map_eval", "map_eval_points", defines);
  const float bm = map.has_bias ? static_cast<float>(map.bias_mean) : 0.f;
  const float bv = map.has_bias ? static_cast<float>(map.bias_var) : 0.f;
  detail::cl_call("clSetKernelArg(map_eval_points)", [&] {
    k.set_args(kpos_hi, kpos_lo, kpar, b_qh, b_ql, static_cast<cl_uint>(padded), b_start, b_list,
               b_ord, bm, bv, b_m, b_v, b_p);
  });
  detail::cl_call("clEnqueueNDRangeKernel(map_eval_points)", [&] {
    q.enqueue_1d_range_kernel(k, 0, nchunks * wg, wg);
  });
  // Outputs were scattered to the caller's order; NaN slots (non-finite points) are untouched
  // on the device, so read only through the host's finite set when any were dropped.
  std::vector<float> tmp(n);
  auto read = [&](bc::buffer& b, float* dst) {
    if (!dst) return;
    detail::cl_call("clEnqueueReadBuffer", [&] { q.enqueue_read_buffer(b, 0, n * 4, tmp.data()); });
    for (std::uint32_t i : finite) dst[i] = tmp[i];
  };
  read(b_m, out_m);
  read(b_v, out_v);
  read(b_p, out_p);
}

MapEvaluator::MapEvaluator(Context& ctx, const KernelMap& map, const EvalOptions& options)
    : impl_(std::make_unique<Impl>(ctx, map, options)) {}
MapEvaluator::~MapEvaluator() = default;
MapEvaluator::MapEvaluator(MapEvaluator&&) noexcept = default;
MapEvaluator& MapEvaluator::operator=(MapEvaluator&&) noexcept = default;

int MapEvaluator::dim() const { return impl_->map.dim; }
std::size_t MapEvaluator::last_pairs() const { return impl_->last_pairs; }

void MapEvaluator::evaluate(const double* points, std::size_t n, float* mean, float* var,
                            float* prob) {
  impl_->last_pairs = 0;
  if (n == 0) return;
  if (!points) throw ArgumentError("MapEvaluator::evaluate: points is null but n > 0");
  const int dim = impl_->map.dim;
  for (std::size_t s = 0; s < n; s += kPointsPerBatch) {
    const std::size_t m = std::min(kPointsPerBatch, n - s);
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

}  // namespace potmap

namespace potmap {

void MapEvaluator::evaluate_grid(const GridSpec& grid, float* mean, float* var, float* prob) {
  if (grid.dim != impl_->map.dim)
    throw ArgumentError("MapEvaluator::evaluate_grid: grid is " + std::to_string(grid.dim) +
                        "D but the map is " + std::to_string(impl_->map.dim) + "D");
  // Row by row through the point path; bounded memory whatever the grid's size.
  const std::size_t nx = grid.count[0], ny = grid.count[1];
  const std::size_t nz = grid.dim == 3 ? grid.count[2] : 1;
  const std::size_t rows_per = std::max<std::size_t>(1, kPointsPerBatch / std::max<std::size_t>(nx, 1));
  std::vector<double> pts;
  impl_->last_pairs = 0;
  std::size_t pairs = 0;
  for (std::size_t k = 0; k < nz; ++k)
    for (std::size_t j0 = 0; j0 < ny; j0 += rows_per) {
      const std::size_t j1 = std::min(ny, j0 + rows_per);
      pts.clear();
      for (std::size_t j = j0; j < j1; ++j)
        for (std::size_t i = 0; i < nx; ++i) {
          pts.push_back(grid.origin[0] + (i + 0.5) * grid.resolution);
          pts.push_back(grid.origin[1] + (j + 0.5) * grid.resolution);
          if (grid.dim == 3) pts.push_back(grid.origin[2] + (k + 0.5) * grid.resolution);
        }
      const std::size_t off = (k * ny + j0) * nx;
      evaluate(pts.data(), (j1 - j0) * nx, mean ? mean + off : nullptr, var ? var + off : nullptr,
               prob ? prob + off : nullptr);
      pairs += impl_->last_pairs;
    }
  impl_->last_pairs = pairs;
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
