// MapEvaluator's height-band path: the band's levels are evaluated as the grid path evaluates a
// 3D grid (kernels/map/raster.cl, tiles of 8 y rows by tile / 8 levels), with the blocks of a
// launch holding every level of their rows; kernels/map/band_max.cl then reduces the levels on
// the device, and only the band's cells are read back.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "map/evaluator_impl.hpp"
#include "map/grid_tiles.hpp"
#include "potmap/error.hpp"

namespace bc = boost::compute;

namespace potmap {

namespace {

void check_levels(const std::vector<double>& levels) {
  for (std::size_t k = 0; k < levels.size(); ++k)
    if (!std::isfinite(levels[k]))
      throw ArgumentError("MapEvaluator::evaluate_band_max: level " + std::to_string(k) +
                          " is not finite");
}

// For each output row j0 + r of a launch and level k: the row slot holding it.
std::vector<int> level_slots(const detail::RowSlots& rows, const detail::GridBlocks& g,
                             std::size_t j0, std::size_t nrows) {
  std::vector<int> slot(nrows * g.nz, 0);
  for (std::size_t s = 0; s < rows.count; ++s) {
    if (rows.out[s] < 0) continue;
    const std::size_t j = rows.row[s] % g.ny, k = rows.row[s] / g.ny;
    slot[(j - j0) * g.nz + k] = static_cast<int>(s);
  }
  return slot;
}

}  // namespace

void MapEvaluator::Impl::run_band(const GridSpec& columns, const std::vector<double>& levels,
                                  float* out_m, float* out_v, float* out_p) {
  last_pairs = 0;
  if (map.dim != 3)
    throw ArgumentError("MapEvaluator::evaluate_band_max: the map is " + std::to_string(map.dim) +
                        "D; a height band needs a 3D map");
  GridSpec grid = columns;
  grid.count[2] = 1;
  detail::check_grid(grid, 3);
  check_levels(levels);
  if (levels.empty() || grid.count[0] == 0 || grid.count[1] == 0) return;
  const std::size_t tile = static_cast<std::size_t>(raster_tile);
  const detail::GridBlocks g = detail::cut_grid(grid, tile, levels);
  const std::size_t rows_per_item = static_cast<std::size_t>(raster_rows);
  // Whole y blocks a launch, every level of each.
  const std::size_t yblocks_per_launch =
      std::max<std::size_t>(1, opt.cells_per_launch / (tile * g.ntx * tile * g.nbz));

  auto& cx = ctx->context();
  auto& q = ctx->queue();
  std::vector<float> chi, clo;
  detail::column_coordinates(grid, g, anchor, chi, clo);
  detail::BatchedReads drain(q);  // the columns' queued writes read chi and clo until it ends
  bc::buffer& b_chi = g_col_hi.put(cx, q, chi);
  bc::buffer& b_clo = g_col_lo.put(cx, q, clo);
  char defs[200];
  std::snprintf(defs, sizeof defs,
                "-DDIM=3 -DROWS=%zu -DTILE_X=%zu -DTILE_Y=%zu -DTAU=%#.9gf -cl-denorms-are-zero",
                rows_per_item, tile, tile, opt.tau);
  KernelLease lease = ctx->lend_kernel("map/raster", "map_raster", defs);
  KernelLease reduce = ctx->lend_kernel("map/band_max", "map_band_max", "");

  for (std::size_t yb0 = 0; yb0 < g.nby; yb0 += yblocks_per_launch) {
    const std::size_t yb1 = std::min(g.nby, yb0 + yblocks_per_launch);
    const std::size_t b0 = yb0 * g.nbz, nb = (yb1 - yb0) * g.nbz;
    const detail::RowSlots rows = detail::row_slots(grid, g, anchor, b0, nb);
    const detail::KernelLists lists =
        detail::flatten(detail::tile_kernel_lists(grid, g, index, rows));
    last_pairs += static_cast<std::size_t>(lists.start.back()) * tile * tile;
    const std::size_t j0 = yb0 * g.by, nrows = std::min(g.ny, yb1 * g.by) - j0;
    const std::vector<int> slots = level_slots(rows, g, j0, nrows);

    const std::size_t cells = rows.count * g.nx, band = nrows * g.nx;
    detail::BatchedReads reads(q);  // after rows, lists and slots: see its comment
    bc::buffer& b_rhi = g_row_hi.put(cx, q, rows.hi);
    bc::buffer& b_rlo = g_row_lo.put(cx, q, rows.lo);
    bc::buffer& b_rout = g_row_out.put(cx, q, rows.out);
    bc::buffer& b_start = g_start.put(cx, q, lists.start);
    bc::buffer& b_list = g_list.put(cx, q, lists.flat);
    bc::buffer& b_slot = b_level_slot.put(cx, q, slots);
    bc::buffer& b_m = out_mean.get(cx, cells * 4);
    bc::buffer& b_v = out_var.get(cx, cells * 4);
    bc::buffer& b_p = out_prob.get(cx, cells * 4);
    detail::set_kernel_args(*lease, "map_raster", kpos_hi, kpos_lo, kpar, b_chi, b_clo,
                            static_cast<cl_uint>(g.nx), b_rhi, b_rlo,
                            static_cast<cl_uint>(rows.count), b_rout, b_start, b_list, bias_mean,
                            bias_var, b_m, b_v, b_p);
    const std::size_t global[2] = {g.ntx * (tile / 16), nb * (tile / rows_per_item)};
    const std::size_t local[2] = {tile / 16, tile / rows_per_item};
    detail::enqueue_2d(q, *lease, "map_raster", global, local);

    bc::buffer& o_m = b_band_mean.get(cx, band * 4);
    bc::buffer& o_v = b_band_var.get(cx, band * 4);
    bc::buffer& o_p = b_band_prob.get(cx, band * 4);
    detail::set_kernel_args(*reduce, "map_band_max", b_m, b_v, b_p, static_cast<cl_uint>(g.nx),
                            static_cast<cl_uint>(g.nz), b_slot, o_m, o_v, o_p);
    constexpr std::size_t kGroup = 64;
    const std::size_t rglobal[2] = {(g.nx + kGroup - 1) / kGroup * kGroup, nrows};
    const std::size_t rlocal[2] = {kGroup, 1};
    detail::enqueue_2d(q, *reduce, "map_band_max", rglobal, rlocal);
    // The launch's rows are consecutive: read straight into the caller's arrays.
    float* const dsts[3] = {out_m, out_v, out_p};
    bc::buffer* const bufs[3] = {&o_m, &o_v, &o_p};
    for (int o = 0; o < 3; ++o)
      if (dsts[o]) reads.bytes(*bufs[o], band * 4, dsts[o] + j0 * g.nx);
    reads.wait();
  }
}

void MapEvaluator::evaluate_band_max(const GridSpec& columns, const std::vector<double>& levels,
                                     float* mean, float* var, float* prob) {
  impl_->run_band(columns, levels, mean, var, prob);
}

}  // namespace potmap
