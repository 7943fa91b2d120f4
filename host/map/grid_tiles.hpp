#pragma once
// The grid path's cutting of a grid into device tiles (kernels/map/raster.cl), shared by
// MapEvaluator's grid path (evaluate_grid.cpp) and its height-band path (evaluate_band.cpp): the
// tiles, the coordinates of their columns and row slots, and each tile's kernel list.

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "map/kernel_index.hpp"
#include "potmap/map/evaluate.hpp"

namespace potmap::detail {

// The grid's shape as the raster path cuts it into tiles of `tile` columns by `tile` row slots:
// 2D row blocks are `tile` consecutive y rows; 3D ones 8 y by tile / 8 z, so tiles stay compact.
struct GridBlocks {
  int dim = 2;
  // Band grids: the z of each level (any spacing) and blocks ordered with z fastest, so that a
  // launch holds every level of its rows. Empty: levels at origin[2] + (k + 0.5) * resolution,
  // y fastest.
  std::vector<double> z;
  std::size_t tile = 64;
  std::size_t nx = 0, ny = 0, nz = 1;
  std::size_t ntx = 0;         // column tiles
  std::size_t by = 0, bz = 0;  // rows of a block along y and z
  std::size_t nby = 0, nbz = 1, nblocks = 0;
};

/// Cuts `grid` into tiles of `tile` columns by `tile` row slots. `levels` (may be empty): the z of
/// each level of a band grid, which then replaces the grid's own z layers.
GridBlocks cut_grid(const GridSpec& grid, std::size_t tile, std::vector<double> levels = {});

/// Throws ArgumentError unless the grid is `dim`-D with a positive resolution.
void check_grid(const GridSpec& grid, int dim);

/// Column coordinates relative to the anchor, padded to whole tiles by repeating the last one.
void column_coordinates(const GridSpec& grid, const GridBlocks& g, const double* anchor,
                        std::vector<float>& hi, std::vector<float>& lo);

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
                   std::size_t nb);

/// The kernel list of every tile of one launch (tile t: block t / ntx, column tile t % ntx).
std::vector<std::vector<std::uint32_t>> tile_kernel_lists(const GridSpec& grid, const GridBlocks& g,
                                                          const KernelIndex& index,
                                                          const RowSlots& rows);

}  // namespace potmap::detail
