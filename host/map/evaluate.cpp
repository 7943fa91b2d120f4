#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>

#include <boost/compute/buffer.hpp>

#include "map/kernel_index.hpp"
#include "map/split_float.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "runtime/cl_check.hpp"

namespace bc = boost::compute;

namespace potmap {

namespace {

template <class T>
void upload(bc::command_queue& q, bc::buffer& b, const std::vector<T>& v) {
  if (v.empty()) return;
  detail::cl_call("clEnqueueWriteBuffer",
                  [&] { q.enqueue_write_buffer(b, 0, v.size() * sizeof(T), v.data()); });
}

// A device buffer that only grows.
struct GrowBuffer {
  bc::buffer buf;
  std::size_t bytes = 0;
  /// The buffer, grown to hold v, with v written to its start.
  template <class T>
  bc::buffer& put(bc::context& ctx, bc::command_queue& q, const std::vector<T>& v) {
    bc::buffer& b = get(ctx, v.size() * sizeof(T));
    upload(q, b, v);
    return b;
  }
  bc::buffer& get(bc::context& ctx, std::size_t need) {
    need = std::max<std::size_t>(need, 64);
    if (need > bytes) {
      bytes = need + need / 4;
      buf = detail::cl_call("clCreateBuffer", [&] { return bc::buffer(ctx, bytes); });
    }
    return buf;
  }
};

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
    std::snprintf(buf, sizeof buf, "-DDIM=%d -DVEC=%d -DTAU=%#.9gf -cl-denorms-are-zero", map.dim,
                  vec, opt.tau);
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
  void run_grid(const GridSpec& grid, float* mean, float* var, float* prob);
  void build_cells();
  // Per-cell kernel lists for evaluate_device (built on first use).
  bool cells_built = false;
  double cell_size = 0;
  double cell_lo[3] = {0, 0, 0};
  cl_uint cell_n[3] = {1, 1, 1};
  bc::buffer cell_start_buf, cell_list_buf;
  GrowBuffer g_col_hi, g_col_lo, g_row_hi, g_row_lo, g_row_out, g_start, g_list;
};

// Grid tiles: TILE_X columns by TILE_Y rows; a work-item owns 16 columns by kRows rows.
namespace {
constexpr std::size_t kTileX = 64, kTileY = 64, kRows = 8;
}  // namespace

void MapEvaluator::Impl::run_grid(const GridSpec& grid, float* out_m, float* out_v, float* out_p) {
  last_pairs = 0;
  const int dim = map.dim;
  if (grid.dim != dim)
    throw ArgumentError("MapEvaluator::evaluate_grid: grid is " + std::to_string(grid.dim) +
                        "D but the map is " + std::to_string(dim) + "D");
  if (!(grid.resolution > 0) || !std::isfinite(grid.resolution))
    throw ArgumentError("MapEvaluator::evaluate_grid: resolution must be positive, got " +
                        std::to_string(grid.resolution));
  const std::size_t nx = grid.count[0], ny = grid.count[1], nz = dim == 3 ? grid.count[2] : 1;
  if (nx == 0 || ny == 0 || nz == 0) return;
  const double res = grid.resolution;

  // Columns, padded to whole tiles by repeating the last one.
  const std::size_t ntx = (nx + kTileX - 1) / kTileX;
  std::vector<float> chi(ntx * kTileX), clo(ntx * kTileX);
  for (std::size_t i = 0; i < chi.size(); ++i)
    detail::split(grid.origin[0] + (std::min(i, nx - 1) + 0.5) * res - anchor[0], chi[i], clo[i]);

  // Row blocks: 2D, kTileY consecutive y rows; 3D, 8 y by 8 z so tiles stay compact.
  const std::size_t by = dim == 3 ? 8 : kTileY, bz = dim == 3 ? kTileY / 8 : 1;
  const std::size_t nby = (ny + by - 1) / by, nbz = (nz + bz - 1) / bz;
  const std::size_t nblocks = nby * nbz;
  const std::size_t blocks_per_launch =
      std::max<std::size_t>(1, opt.cells_per_launch / (kTileY * ntx * kTileX));

  auto& cx = ctx->context();
  auto& q = ctx->queue();
  bc::buffer& b_chi = g_col_hi.put(cx, q, chi);
  bc::buffer& b_clo = g_col_lo.put(cx, q, clo);
  char defs[200];
  std::snprintf(defs, sizeof defs,
                "-DDIM=%d -DROWS=%zu -DTILE_X=%zu -DTILE_Y=%zu -DTAU=%#.9gf -cl-denorms-are-zero",
                dim, kRows, kTileX, kTileY, opt.tau);
  bc::kernel kern = ctx->kernel("map/raster", "map_raster", defs);
  const float bm = map.has_bias ? static_cast<float>(map.bias_mean) : 0.f;
  const float bv = map.has_bias ? static_cast<float>(map.bias_var) : 0.f;
  const double xlo = grid.origin[0] + 0.5 * res, xhi = grid.origin[0] + (nx - 0.5) * res;

  std::vector<float> host_m, host_v, host_p;
  for (std::size_t b0 = 0; b0 < nblocks; b0 += blocks_per_launch) {
    const std::size_t b1 = std::min(nblocks, b0 + blocks_per_launch);
    const std::size_t nb = b1 - b0, nslots = nb * kTileY;
    // Row slots of this launch: coordinates, and the (j, k) each real slot stands for.
    std::vector<float> rhi(nslots * (dim - 1)), rlo(nslots * (dim - 1));
    std::vector<int> rout(nslots, -1);
    std::vector<std::size_t> slot_row(nslots, 0);      // flattened output row j + ny * k
    std::vector<std::array<double, 4>> block_box(nb);  // ylo, yhi, zlo, zhi
    for (std::size_t bi = 0; bi < nb; ++bi) {
      const std::size_t blk = b0 + bi, bjy = blk % nby, bkz = blk / nby;
      std::size_t last_real = 0;
      for (std::size_t r = 0; r < kTileY; ++r) {
        std::size_t j = bjy * by + r % by, k = bkz * bz + r / by;
        const bool real = j < ny && k < nz;
        const std::size_t s = bi * kTileY + r;
        if (real) last_real = s;
        j = std::min(j, ny - 1);
        k = std::min(k, nz - 1);
        detail::split(grid.origin[1] + (j + 0.5) * res - anchor[1], rhi[s], rlo[s]);
        if (dim == 3)
          detail::split(grid.origin[2] + (k + 0.5) * res - anchor[2], rhi[nslots + s],
                        rlo[nslots + s]);
        if (real) {
          rout[s] = static_cast<int>(s * nx);
          slot_row[s] = j + ny * k;
        }
      }
      (void)last_real;
      const std::size_t j0 = bjy * by, j1 = std::min(ny, j0 + by) - 1;
      const std::size_t k0 = bkz * bz, k1 = std::min(nz, k0 + bz) - 1;
      block_box[bi] = {grid.origin[1] + (j0 + 0.5) * res, grid.origin[1] + (j1 + 0.5) * res,
                       grid.origin[2] + (k0 + 0.5) * res, grid.origin[2] + (k1 + 0.5) * res};
    }
    // Kernel list of every tile.
    const std::size_t ntiles = nb * ntx;
    std::vector<std::vector<std::uint32_t>> lists(ntiles);
    const long long nt = static_cast<long long>(ntiles);
#pragma omp parallel for schedule(dynamic, 4)
    for (long long t = 0; t < nt; ++t) {
      const std::size_t bi = t / ntx, tx = t % ntx;
      const double lo[3] = {std::max(xlo, grid.origin[0] + (tx * kTileX + 0.5) * res),
                            block_box[bi][0], block_box[bi][2]};
      const double hi[3] = {std::min(xhi, grid.origin[0] + ((tx + 1) * kTileX - 0.5) * res),
                            block_box[bi][1], block_box[bi][3]};
      index.query_box(lo, hi, lists[t]);
    }
    std::vector<std::uint32_t> start(ntiles + 1, 0);
    for (std::size_t t = 0; t < ntiles; ++t) start[t + 1] = start[t] + lists[t].size();
    std::vector<std::uint32_t> flat(std::max<std::size_t>(start[ntiles], 1));
    for (std::size_t t = 0; t < ntiles; ++t)
      std::copy(lists[t].begin(), lists[t].end(), flat.begin() + start[t]);
    last_pairs += static_cast<std::size_t>(start[ntiles]) * kTileX * kTileY;

    const std::size_t cells = nslots * nx;
    bc::buffer& b_rhi = g_row_hi.put(cx, q, rhi);
    bc::buffer& b_rlo = g_row_lo.put(cx, q, rlo);
    bc::buffer& b_rout = g_row_out.put(cx, q, rout);
    bc::buffer& b_start = g_start.put(cx, q, start);
    bc::buffer& b_list = g_list.put(cx, q, flat);
    bc::buffer& b_m = out_mean.get(cx, cells * 4);
    bc::buffer& b_v = out_var.get(cx, cells * 4);
    bc::buffer& b_p = out_prob.get(cx, cells * 4);
    detail::cl_call("clSetKernelArg(map_raster)", [&] {
      kern.set_args(kpos_hi, kpos_lo, kpar, b_chi, b_clo, static_cast<cl_uint>(nx), b_rhi, b_rlo,
                    static_cast<cl_uint>(nslots), b_rout, b_start, b_list, bm, bv, b_m, b_v, b_p);
    });
    const std::size_t global[2] = {ntx * (kTileX / 16), nb * (kTileY / kRows)};
    const std::size_t local[2] = {kTileX / 16, kTileY / kRows};
    detail::cl_call("clEnqueueNDRangeKernel(map_raster)",
                    [&] { q.enqueue_nd_range_kernel(kern, 2, nullptr, global, local); });
    // 2D launches cover consecutive whole rows: read straight into the caller's array.
    const bool contiguous = dim == 2;
    const std::size_t first_row = b0 * kTileY, real_rows = std::min(ny, b1 * kTileY) - first_row;
    auto fetch = [&](bc::buffer& b, std::vector<float>& host, float* dst) {
      if (!dst) return;
      if (contiguous) {
        detail::cl_call("clEnqueueReadBuffer", [&] {
          q.enqueue_read_buffer(b, 0, real_rows * nx * 4, dst + first_row * nx);
        });
        return;
      }
      host.resize(cells);
      detail::cl_call("clEnqueueReadBuffer",
                      [&] { q.enqueue_read_buffer(b, 0, cells * 4, host.data()); });
      for (std::size_t s = 0; s < nslots; ++s)
        if (rout[s] >= 0) std::copy_n(host.data() + s * nx, nx, dst + slot_row[s] * nx);
    };
    fetch(b_m, host_m, out_m);
    fetch(b_v, host_v, out_v);
    fetch(b_p, host_p, out_p);
  }
}

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
      std::int64_t t =
          std::clamp<std::int64_t>(static_cast<std::int64_t>((p[d] - lo[d]) / tile), 0, nt[d] - 1);
      code |= spread(static_cast<std::uint64_t>(t)) << d;
    }
    key[j] = code;
  }
  std::uint64_t max_key = 0;
  for (std::uint64_t k : key) max_key = std::max(max_key, k);
  const std::vector<std::uint32_t> perm = radix_order(key, max_key);

  // 3. Chunks of consecutive sorted points, padded with the chunk's last point.
  const std::size_t nchunks = (nf + chunk - 1) / chunk;
  const std::size_t padded = nchunks * chunk;
  std::vector<float> qh(padded * dim), ql(padded * dim);
  std::vector<int> ord(padded, -1);
  const long long npad = static_cast<long long>(padded);
#pragma omp parallel for schedule(static)
  for (long long s = 0; s < npad; ++s) {
    const std::size_t j = perm[std::min<std::size_t>(s, nf - 1)];
    const double* p = pts + std::size_t(finite[j]) * dim;
    for (int d = 0; d < dim; ++d)
      detail::split(p[d] - anchor[d], qh[d * padded + s], ql[d * padded + s]);
    if (static_cast<std::size_t>(s) < nf) ord[s] = static_cast<int>(finite[j]);
  }

  // 4. Kernel list of each chunk: every kernel whose cut-off reaches the chunk's bounding box.
  //    The index is asked once per group of chunks (neighbours in Morton order); each chunk then
  //    filters the group's candidates, which costs far less than one index walk per chunk.
  std::vector<std::array<double, 6>> box(nchunks);
  const long long nc = static_cast<long long>(nchunks);
#pragma omp parallel for schedule(static)
  for (long long c = 0; c < nc; ++c) {
    std::array<double, 6>& bx = box[c];
    for (int d = 0; d < 3; ++d) {
      bx[d] = d < dim ? std::numeric_limits<double>::infinity() : 0.0;
      bx[3 + d] = d < dim ? -std::numeric_limits<double>::infinity() : 0.0;
    }
    const std::size_t s0 = c * chunk, s1 = std::min(nf, s0 + chunk);
    for (std::size_t s = s0; s < s1; ++s) {
      const double* p = pts + std::size_t(finite[perm[s]]) * dim;
      for (int d = 0; d < dim; ++d) {
        bx[d] = std::min(bx[d], p[d]);
        bx[3 + d] = std::max(bx[3 + d], p[d]);
      }
    }
  }
  constexpr std::size_t kGroup = 16;
  const long long ngroups = static_cast<long long>((nchunks + kGroup - 1) / kGroup);
  std::vector<std::vector<std::uint32_t>> lists(nchunks);
  const double* kp = map.position.data();
  const double* kg = map.gamma.data();
  const double tau = opt.tau;
#pragma omp parallel for schedule(dynamic, 1)
  for (long long gi = 0; gi < ngroups; ++gi) {
    const std::size_t c0 = gi * kGroup, c1 = std::min(nchunks, c0 + kGroup);
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
  bc::buffer& b_qh = q_hi.put(cx, q, qh);
  bc::buffer& b_ql = q_lo.put(cx, q, ql);
  bc::buffer& b_start = chunk_start.put(cx, q, start);
  bc::buffer& b_list = list.put(cx, q, flat);
  bc::buffer& b_ord = order.put(cx, q, ord);
  bc::buffer& b_m = out_mean.get(cx, n * 4);
  bc::buffer& b_v = out_var.get(cx, n * 4);
  bc::buffer& b_p = out_prob.get(cx, n * 4);

  bc::kernel k = ctx->kernel("map/evaluate", "map_eval_points", defines);
  const float bm = map.has_bias ? static_cast<float>(map.bias_mean) : 0.f;
  const float bv = map.has_bias ? static_cast<float>(map.bias_var) : 0.f;
  detail::cl_call("clSetKernelArg(map_eval_points)", [&] {
    k.set_args(kpos_hi, kpos_lo, kpar, b_qh, b_ql, static_cast<cl_uint>(padded), b_start, b_list,
               b_ord, bm, bv, b_m, b_v, b_p);
  });
  detail::cl_call("clEnqueueNDRangeKernel(map_eval_points)",
                  [&] { q.enqueue_1d_range_kernel(k, 0, nchunks * wg, wg); });
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

// Cells of a uniform grid over the map grown by the largest reach; each cell lists the kernels
// whose cut-off ball meets it. The cell edge starts at the smallest reach and doubles until the
// lists fit in 16M entries.
void MapEvaluator::Impl::build_cells() {
  const int dim = map.dim;
  const std::size_t m = map.size();
  constexpr double kMaxEntries = 16.0 * (1 << 20);
  std::vector<double> reach(m);
  double rmin = std::numeric_limits<double>::infinity(), rmax = 0;
  for (std::size_t k = 0; k < m; ++k) {
    reach[k] = std::sqrt(opt.tau / map.gamma[k]);
    rmin = std::min(rmin, reach[k]);
    rmax = std::max(rmax, reach[k]);
  }
  double lo[3], hi[3];
  map.bounds(lo, hi);
  double cs = m ? std::max(rmin, 0.25) : 1.0;
  for (;;) {
    double entries = 0, cells = 1;
    for (int d = 0; d < dim; ++d) cells *= std::ceil((hi[d] - lo[d] + 2 * rmax) / cs) + 1;
    for (std::size_t k = 0; k < m; ++k) entries += std::pow(2 * reach[k] / cs + 2, dim);
    if ((entries <= kMaxEntries && cells <= kMaxEntries) || cs > 1e6) break;
    cs *= 2;
  }
  cell_size = cs;
  std::size_t total = 1;
  for (int d = 0; d < 3; ++d) {
    if (d < dim) {
      cell_lo[d] = lo[d] - rmax - anchor[d];
      cell_n[d] = static_cast<cl_uint>(std::ceil((hi[d] - lo[d] + 2 * rmax) / cs) + 1);
    } else {
      cell_lo[d] = 0;
      cell_n[d] = 1;
    }
    total *= cell_n[d];
  }
  std::vector<std::uint32_t> start(total + 1, 0), list;
  // Two passes over every kernel's cells: count, then fill.
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<std::uint32_t> fill;
    if (pass == 1) {
      for (std::size_t c = 0; c < total; ++c) start[c + 1] += start[c];
      list.resize(std::max<std::size_t>(start[total], 1));
      fill.assign(start.begin(), start.end() - 1);
    }
    for (std::size_t k = 0; k < m; ++k) {
      std::int64_t a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
      double h[3] = {0, 0, 0};
      for (int d = 0; d < dim; ++d) {
        h[d] = map.position[k * dim + d] - anchor[d];
        a[d] = std::max<std::int64_t>(0, std::floor((h[d] - reach[k] - cell_lo[d]) / cs));
        b[d] =
            std::min<std::int64_t>(cell_n[d] - 1, std::floor((h[d] + reach[k] - cell_lo[d]) / cs));
      }
      for (std::int64_t z = a[2]; z <= b[2]; ++z)
        for (std::int64_t y = a[1]; y <= b[1]; ++y)
          for (std::int64_t x = a[0]; x <= b[0]; ++x) {
            const std::int64_t c3[3] = {x, y, z};
            double d2 = 0;
            for (int d = 0; d < dim; ++d) {
              const double l = cell_lo[d] + c3[d] * cs, u = l + cs;
              const double o = std::max({l - h[d], 0.0, h[d] - u});
              d2 += o * o;
            }
            if (map.gamma[k] * d2 > opt.tau) continue;
            const std::size_t c = (z * cell_n[1] + y) * cell_n[0] + x;
            if (pass == 0)
              ++start[c + 1];
            else
              list[fill[c]++] = static_cast<std::uint32_t>(k);
          }
    }
  }
  auto& cx = ctx->context();
  cell_start_buf =
      detail::cl_call("clCreateBuffer", [&] { return bc::buffer(cx, start.size() * 4); });
  cell_list_buf =
      detail::cl_call("clCreateBuffer", [&] { return bc::buffer(cx, list.size() * 4); });
  upload(ctx->queue(), cell_start_buf, start);
  upload(ctx->queue(), cell_list_buf, list);
  cells_built = true;
}

bc::event MapEvaluator::evaluate_device(const bc::buffer& points, std::size_t n,
                                        const double* origin, bc::buffer* mean, bc::buffer* var,
                                        bc::buffer* prob, const bc::wait_list& events) {
  Impl& im = *impl_;
  im.last_pairs = 0;
  if (n == 0) return bc::event();
  const int dim = im.map.dim;
  if (!origin) throw ArgumentError("MapEvaluator::evaluate_device: origin is null");
  auto check = [&](const bc::buffer* b, std::size_t bytes, const char* what) {
    if (!b) return;
    if (b->get() == nullptr)
      throw ArgumentError(std::string("MapEvaluator::evaluate_device: ") + what +
                          " is an empty buffer");
    if (b->size() < bytes)
      throw ArgumentError(std::string("MapEvaluator::evaluate_device: ") + what + " holds " +
                          std::to_string(b->size()) + " bytes, needs " + std::to_string(bytes));
    if (b->get_context().get() != im.ctx->context().get())
      throw ArgumentError(std::string("MapEvaluator::evaluate_device: ") + what +
                          " belongs to another OpenCL context");
  };
  check(&points, n * dim * sizeof(float), "points");
  check(mean, n * 4, "mean");
  check(var, n * 4, "var");
  check(prob, n * 4, "prob");
  if (!im.cells_built) im.build_cells();
  float oh[4] = {0, 0, 0, 0}, ol[4] = {0, 0, 0, 0}, clo[4] = {0, 0, 0, 0};
  for (int d = 0; d < dim; ++d) {
    detail::split(origin[d] - im.anchor[d], oh[d], ol[d]);
    clo[d] = static_cast<float>(im.cell_lo[d]);
  }
  // Cells are found in float: a point that rounds into a neighbouring cell lies micrometres
  // from it, so all it can miss are kernels at the very edge of their cut-off.
  bc::kernel k =
      im.ctx->kernel("map/evaluate_cells", "map_eval_cells", "-DDIM=" + std::to_string(dim));
  const float bm = im.map.has_bias ? static_cast<float>(im.map.bias_mean) : 0.f;
  const float bv = im.map.has_bias ? static_cast<float>(im.map.bias_var) : 0.f;
  cl_float4 ohv = {{oh[0], oh[1], oh[2], oh[3]}}, olv = {{ol[0], ol[1], ol[2], ol[3]}};
  cl_float4 clov = {{clo[0], clo[1], clo[2], clo[3]}};
  cl_uint4 cnv = {{im.cell_n[0], im.cell_n[1], im.cell_n[2], 1}};
  const float cs = static_cast<float>(im.cell_size);
  detail::cl_call("clSetKernelArg(map_eval_cells)", [&] {
    k.set_args(im.kpos_hi, im.kpos_lo, im.kpar, points, static_cast<cl_uint>(n), ohv, olv, clov, cs,
               cnv, im.cell_start_buf, im.cell_list_buf, bm, bv);
  });
  // Null outputs are passed as null cl_mem, which the kernel tests for.
  cl_mem outs[3] = {mean ? mean->get() : nullptr, var ? var->get() : nullptr,
                    prob ? prob->get() : nullptr};
  for (int j = 0; j < 3; ++j)
    detail::cl_check(clSetKernelArg(k.get(), 14 + j, sizeof(cl_mem), outs[j] ? &outs[j] : nullptr),
                     "clSetKernelArg(map_eval_cells output)");
  const std::size_t local = im.ctx->info().is_cpu ? 16 : 128;
  const std::size_t global = (n + local - 1) / local * local;
  return detail::cl_call("clEnqueueNDRangeKernel(map_eval_cells)", [&] {
    return im.ctx->queue().enqueue_1d_range_kernel(k, 0, global, local, events);
  });
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

}  // namespace potmap

namespace potmap {

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
