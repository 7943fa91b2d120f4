// MapEvaluator's grid path (kernels/map/raster.cl): the grid is cut into tiles of
// RasterTuning::tile columns by as many row slots, each with one kernel list; a work-item owns 16
// columns by RasterTuning::rows_per_item rows. Launches hold whole blocks of rows, as many as
// EvalOptions::cells_per_launch allows.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "map/evaluator_impl.hpp"
#include "map/split_float.hpp"
#include "potmap/error.hpp"

namespace bc = boost::compute;

namespace potmap {

namespace {

// Launches of fewer tiles build their kernel lists on the calling thread (tile_kernel_lists).
constexpr long long kParallelListTiles = 256;

// The grid's shape as the raster path cuts it into tiles of `tile` columns by `tile` row slots:
// 2D row blocks are `tile` consecutive y rows; 3D ones 8 y by tile / 8 z, so tiles stay compact.
struct GridBlocks {
  int dim = 2;
  std::size_t tile = 64;
  std::size_t nx = 0, ny = 0, nz = 1;
  std::size_t ntx = 0;         // column tiles
  std::size_t by = 0, bz = 0;  // rows of a block along y and z
  std::size_t nby = 0, nblocks = 0;
};

GridBlocks cut_grid(const GridSpec& grid, std::size_t tile) {
  GridBlocks g;
  g.dim = grid.dim;
  g.tile = tile;
  g.nx = grid.count[0];
  g.ny = grid.count[1];
  g.nz = g.dim == 3 ? grid.count[2] : 1;
  g.ntx = (g.nx + tile - 1) / tile;
  g.by = g.dim == 3 ? 8 : tile;
  g.bz = g.dim == 3 ? tile / 8 : 1;
  g.nby = (g.ny + g.by - 1) / g.by;
  g.nblocks = g.nby * ((g.nz + g.bz - 1) / g.bz);
  return g;
}

void check_grid(const GridSpec& grid, int dim) {
  if (grid.dim != dim)
    throw ArgumentError("MapEvaluator::evaluate_grid: grid is " + std::to_string(grid.dim) +
                        "D but the map is " + std::to_string(dim) + "D");
  if (!(grid.resolution > 0) || !std::isfinite(grid.resolution))
    throw ArgumentError("MapEvaluator::evaluate_grid: resolution must be positive, got " +
                        std::to_string(grid.resolution));
}

// Column coordinates relative to the anchor, padded to whole tiles by repeating the last one.
void column_coordinates(const GridSpec& grid, const GridBlocks& g, const double* anchor,
                        std::vector<float>& hi, std::vector<float>& lo) {
  hi.resize(g.ntx * g.tile);
  lo.resize(g.ntx * g.tile);
  for (std::size_t i = 0; i < hi.size(); ++i)
    detail::split(grid.origin[0] + (std::min(i, g.nx - 1) + 0.5) * grid.resolution - anchor[0],
                  hi[i], lo[i]);
}

// The row slots of one launch (blocks [b0, b0 + nb)): coordinates (y, then z in 3D), the output
// offset of each real slot (-1 on pads), the flattened output row j + ny * k it stands for, and
// each block's box (ylo, yhi, zlo, zhi).
struct RowSlots {
  std::size_t count = 0;
  std::vector<float> hi, lo;
  std::vector<int> out;
  std::vector<std::size_t> row;
  std::vector<std::array<double, 4>> box;
};

RowSlots row_slots(const GridSpec& grid, const GridBlocks& g, const double* anchor, std::size_t b0,
                   std::size_t nb) {
  const double res = grid.resolution;
  RowSlots r;
  r.count = nb * g.tile;
  const std::size_t nslots = r.count;
  r.hi.resize(nslots * (g.dim - 1));
  r.lo.resize(nslots * (g.dim - 1));
  r.out.assign(nslots, -1);
  r.row.assign(nslots, 0);
  r.box.resize(nb);
  for (std::size_t bi = 0; bi < nb; ++bi) {
    const std::size_t blk = b0 + bi, bjy = blk % g.nby, bkz = blk / g.nby;
    for (std::size_t s_in = 0; s_in < g.tile; ++s_in) {
      std::size_t j = bjy * g.by + s_in % g.by, k = bkz * g.bz + s_in / g.by;
      const bool real = j < g.ny && k < g.nz;
      const std::size_t s = bi * g.tile + s_in;
      j = std::min(j, g.ny - 1);
      k = std::min(k, g.nz - 1);
      detail::split(grid.origin[1] + (j + 0.5) * res - anchor[1], r.hi[s], r.lo[s]);
      if (g.dim == 3)
        detail::split(grid.origin[2] + (k + 0.5) * res - anchor[2], r.hi[nslots + s],
                      r.lo[nslots + s]);
      if (real) {
        r.out[s] = static_cast<int>(s * g.nx);
        r.row[s] = j + g.ny * k;
      }
    }
    const std::size_t j0 = bjy * g.by, j1 = std::min(g.ny, j0 + g.by) - 1;
    const std::size_t k0 = bkz * g.bz, k1 = std::min(g.nz, k0 + g.bz) - 1;
    r.box[bi] = {grid.origin[1] + (j0 + 0.5) * res, grid.origin[1] + (j1 + 0.5) * res,
                 grid.origin[2] + (k0 + 0.5) * res, grid.origin[2] + (k1 + 0.5) * res};
  }
  return r;
}

// The kernel list of every tile of one launch (tile t: block t / ntx, column tile t % ntx).
std::vector<std::vector<std::uint32_t>> tile_kernel_lists(const GridSpec& grid, const GridBlocks& g,
                                                          const detail::KernelIndex& index,
                                                          const RowSlots& rows) {
  const double res = grid.resolution;
  const double xlo = grid.origin[0] + 0.5 * res, xhi = grid.origin[0] + (g.nx - 0.5) * res;
  const std::size_t ntiles = rows.box.size() * g.ntx;
  std::vector<std::vector<std::uint32_t>> lists(ntiles);
  const long long nt = static_cast<long long>(ntiles);
  // In parallel only for launches of many tiles: after a parallel region OpenMP's workers spin
  // for milliseconds (OMP_WAIT_POLICY unset), taking a core from the device's threads (PoCL's
  // CPU device) while the kernel runs; a raster job of small tiles would pay that every tile.
#pragma omp parallel for schedule(dynamic, 4) if (nt >= kParallelListTiles)
  for (long long t = 0; t < nt; ++t) {
    const std::size_t bi = t / g.ntx, tx = t % g.ntx;
    const double lo[3] = {std::max(xlo, grid.origin[0] + (tx * g.tile + 0.5) * res),
                          rows.box[bi][0], rows.box[bi][2]};
    const double hi[3] = {std::min(xhi, grid.origin[0] + ((tx + 1) * g.tile - 0.5) * res),
                          rows.box[bi][1], rows.box[bi][3]};
    index.query_box(lo, hi, lists[t]);
  }
  return lists;
}

}  // namespace

void MapEvaluator::Impl::run_grid(const GridSpec& grid, float* out_m, float* out_v, float* out_p) {
  last_pairs = 0;
  check_grid(grid, map.dim);
  const std::size_t tile = static_cast<std::size_t>(raster_tile);
  const GridBlocks g = cut_grid(grid, tile);
  if (g.nx == 0 || g.ny == 0 || g.nz == 0) return;
  const std::size_t rows_per_item = static_cast<std::size_t>(raster_rows);
  const std::size_t blocks_per_launch =
      std::max<std::size_t>(1, opt.cells_per_launch / (tile * g.ntx * tile));

  auto& cx = ctx->context();
  auto& q = ctx->queue();
  std::vector<float> chi, clo;
  column_coordinates(grid, g, anchor, chi, clo);
  detail::BatchedReads drain(q);  // the columns' queued writes read chi and clo until it ends
  bc::buffer& b_chi = g_col_hi.put(cx, q, chi);
  bc::buffer& b_clo = g_col_lo.put(cx, q, clo);
  char defs[200];
  std::snprintf(defs, sizeof defs,
                "-DDIM=%d -DROWS=%zu -DTILE_X=%zu -DTILE_Y=%zu -DTAU=%#.9gf -cl-denorms-are-zero",
                g.dim, rows_per_item, tile, tile, opt.tau);
  KernelLease lease = ctx->lend_kernel("map/raster", "map_raster", defs);
  bc::kernel& kern = *lease;

  std::vector<float> host[3];  // 3D: each output's rows before they are placed
  for (std::size_t b0 = 0; b0 < g.nblocks; b0 += blocks_per_launch) {
    const std::size_t b1 = std::min(g.nblocks, b0 + blocks_per_launch);
    const RowSlots rows = row_slots(grid, g, anchor, b0, b1 - b0);
    const detail::KernelLists lists = detail::flatten(tile_kernel_lists(grid, g, index, rows));
    last_pairs += static_cast<std::size_t>(lists.start.back()) * tile * tile;

    const std::size_t cells = rows.count * g.nx;
    detail::BatchedReads reads(q);  // after rows and lists: see its comment
    bc::buffer& b_rhi = g_row_hi.put(cx, q, rows.hi);
    bc::buffer& b_rlo = g_row_lo.put(cx, q, rows.lo);
    bc::buffer& b_rout = g_row_out.put(cx, q, rows.out);
    bc::buffer& b_start = g_start.put(cx, q, lists.start);
    bc::buffer& b_list = g_list.put(cx, q, lists.flat);
    bc::buffer& b_m = out_mean.get(cx, cells * 4);
    bc::buffer& b_v = out_var.get(cx, cells * 4);
    bc::buffer& b_p = out_prob.get(cx, cells * 4);
    detail::set_kernel_args(kern, "map_raster", kpos_hi, kpos_lo, kpar, b_chi, b_clo,
                            static_cast<cl_uint>(g.nx), b_rhi, b_rlo,
                            static_cast<cl_uint>(rows.count), b_rout, b_start, b_list, bias_mean,
                            bias_var, b_m, b_v, b_p);
    const std::size_t global[2] = {g.ntx * (tile / 16), (b1 - b0) * (tile / rows_per_item)};
    const std::size_t local[2] = {tile / 16, tile / rows_per_item};
    detail::enqueue_2d(q, kern, "map_raster", global, local);
    // 2D launches cover consecutive whole rows: read straight into the caller's array.
    const std::size_t first_row = b0 * tile, real_rows = std::min(g.ny, b1 * tile) - first_row;
    float* const dsts[3] = {out_m, out_v, out_p};
    bc::buffer* const bufs[3] = {&b_m, &b_v, &b_p};
    for (int o = 0; o < 3; ++o) {
      if (!dsts[o]) continue;
      if (g.dim == 2) {
        reads.bytes(*bufs[o], real_rows * g.nx * 4, dsts[o] + first_row * g.nx);
        continue;
      }
      host[o].resize(cells);
      reads.read(*bufs[o], host[o]);
    }
    reads.wait();
    for (int o = 0; o < 3 && g.dim != 2; ++o)
      if (dsts[o])
        for (std::size_t s = 0; s < rows.count; ++s)
          if (rows.out[s] >= 0)
            std::copy_n(host[o].data() + s * g.nx, g.nx, dsts[o] + rows.row[s] * g.nx);
  }
}

}  // namespace potmap
