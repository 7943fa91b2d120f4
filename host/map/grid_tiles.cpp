#include "map/grid_tiles.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "map/split_float.hpp"
#include "potmap/error.hpp"

namespace potmap::detail {

namespace {

// Launches of fewer tiles build their kernel lists on the calling thread (tile_kernel_lists).
constexpr long long kParallelListTiles = 256;

// The z of level k.
double level_z(const GridSpec& grid, const GridBlocks& g, std::size_t k) {
  return g.z.empty() ? grid.origin[2] + (k + 0.5) * grid.resolution : g.z[k];
}

}  // namespace

GridBlocks cut_grid(const GridSpec& grid, std::size_t tile, std::vector<double> levels) {
  GridBlocks g;
  g.dim = grid.dim;
  g.tile = tile;
  g.nx = grid.count[0];
  g.ny = grid.count[1];
  g.nz = g.dim == 3 ? grid.count[2] : 1;
  if (!levels.empty()) {
    g.nz = levels.size();
    g.z = std::move(levels);
  }
  g.ntx = (g.nx + tile - 1) / tile;
  g.by = g.dim == 3 ? 8 : tile;
  g.bz = g.dim == 3 ? tile / 8 : 1;
  g.nby = (g.ny + g.by - 1) / g.by;
  g.nbz = (g.nz + g.bz - 1) / g.bz;
  g.nblocks = g.nby * g.nbz;
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

void column_coordinates(const GridSpec& grid, const GridBlocks& g, const double* anchor,
                        std::vector<float>& hi, std::vector<float>& lo) {
  hi.resize(g.ntx * g.tile);
  lo.resize(g.ntx * g.tile);
  for (std::size_t i = 0; i < hi.size(); ++i)
    detail::split(grid.origin[0] + (std::min(i, g.nx - 1) + 0.5) * grid.resolution - anchor[0],
                  hi[i], lo[i]);
}

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
    const std::size_t blk = b0 + bi;
    const std::size_t bjy = g.z.empty() ? blk % g.nby : blk / g.nbz;
    const std::size_t bkz = g.z.empty() ? blk / g.nby : blk % g.nbz;
    for (std::size_t s_in = 0; s_in < g.tile; ++s_in) {
      std::size_t j = bjy * g.by + s_in % g.by, k = bkz * g.bz + s_in / g.by;
      const bool real = j < g.ny && k < g.nz;
      const std::size_t s = bi * g.tile + s_in;
      j = std::min(j, g.ny - 1);
      k = std::min(k, g.nz - 1);
      detail::split(grid.origin[1] + (j + 0.5) * res - anchor[1], r.hi[s], r.lo[s]);
      if (g.dim == 3)
        detail::split(level_z(grid, g, k) - anchor[2], r.hi[nslots + s], r.lo[nslots + s]);
      if (real) {
        r.out[s] = static_cast<int>(s * g.nx);
        r.row[s] = j + g.ny * k;
      }
    }
    const std::size_t j0 = bjy * g.by, j1 = std::min(g.ny, j0 + g.by) - 1;
    const std::size_t k0 = bkz * g.bz, k1 = std::min(g.nz, k0 + g.bz) - 1;
    r.box[bi] = {grid.origin[1] + (j0 + 0.5) * res, grid.origin[1] + (j1 + 0.5) * res,
                 std::min(level_z(grid, g, k0), level_z(grid, g, k1)),
                 std::max(level_z(grid, g, k0), level_z(grid, g, k1))};
  }
  return r;
}

std::vector<std::vector<std::uint32_t>> tile_kernel_lists(const GridSpec& grid, const GridBlocks& g,
                                                          const KernelIndex& index,
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

}  // namespace potmap::detail
