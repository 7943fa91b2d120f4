// MapEvaluator's grid path (kernels/map/raster.cl): the grid is cut into tiles of
// RasterTuning::tile columns by as many row slots, each with one kernel list; a work-item owns 16
// columns by RasterTuning::rows_per_item rows. Launches hold whole blocks of rows, as many as
// EvalOptions::cells_per_launch allows.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "map/evaluator_impl.hpp"
#include "map/grid_tiles.hpp"
#include "map/split_float.hpp"
#include "potmap/error.hpp"

namespace bc = boost::compute;

namespace potmap {

using detail::check_grid;
using detail::column_coordinates;
using detail::cut_grid;
using detail::GridBlocks;
using detail::row_slots;
using detail::RowSlots;
using detail::tile_kernel_lists;

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
