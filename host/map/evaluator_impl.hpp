#pragma once
// MapEvaluator's state, shared by its paths, one file each: host points in batches
// (evaluate.cpp, kernels/map/evaluate.cl), grids (evaluate_grid.cpp, kernels/map/raster.cl),
// height bands (evaluate_band.cpp, kernels/map/raster.cl then kernels/map/band_max.cl) and
// points already on the device (evaluate_cells.cpp, kernels/map/evaluate_cells.cl), and a 3D
// map's voxel blocks (evaluate_blocks.cpp, kernels/map/blocks.cl).

#include <boost/compute/buffer.hpp>
#include <string>

#include "map/kernel_index.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/runtime/tuning.hpp"
#include "runtime/device_buffers.hpp"

namespace potmap {

struct MapEvaluator::Impl {
  Context* ctx;
  KernelMap map;  // own copy: the index points into it
  EvalOptions opt;
  MapEvalTuning tuning;
  int raster_rows;  // RasterTuning::rows_per_item
  int raster_tile;  // RasterTuning::tile
  detail::KernelIndex index;
  // Kernel positions are sent relative to this whole-metre anchor near the map's centre, split
  // into float hi + lo parts, so that float arithmetic on the device keeps micrometres.
  double anchor[3] = {0, 0, 0};
  std::string defines;  // batch kernel's build options
  boost::compute::buffer kpos_hi, kpos_lo, kpar;
  float bias_mean = 0, bias_var = 0;  // 0 when the map has no bias
  std::size_t last_pairs = 0;

  // Batch path.
  detail::GrowBuffer q_hi{"evaluator: query points (hi)"}, q_lo{"evaluator: query points (lo)"},
      chunk_start{"evaluator: chunk list starts"}, list{"evaluator: chunk kernel lists"},
      order{"evaluator: query order"}, out_mean{"evaluator: mean output"},
      out_var{"evaluator: variance output"}, out_prob{"evaluator: probability output"};
  // Grid path (outputs share the batch path's buffers); rasters come through here.
  detail::GrowBuffer g_col_hi{"evaluator: grid columns (hi)"},
      g_col_lo{"evaluator: grid columns (lo)"}, g_row_hi{"evaluator: grid rows (hi)"},
      g_row_lo{"evaluator: grid rows (lo)"}, g_row_out{"evaluator: grid row outputs"},
      g_start{"evaluator: grid list starts"}, g_list{"evaluator: grid kernel lists"};
  // Band path (its levels go through the grid path's buffers first).
  detail::GrowBuffer b_level_slot{"evaluator: band level slots"},
      b_band_mean{"evaluator: band mean output"}, b_band_var{"evaluator: band variance output"},
      b_band_prob{"evaluator: band probability output"};
  // Block path: each block's kernels as entries (corner less centre, gamma, weight).
  detail::GrowBuffer blk_x{"evaluator: block entries (x)"}, blk_y{"evaluator: block entries (y)"},
      blk_z{"evaluator: block entries (z)"}, blk_g{"evaluator: block entries (gamma)"},
      blk_wm{"evaluator: block entries (weight mean)"},
      blk_wv{"evaluator: block entries (weight variance)"};
  // Device path: per-cell kernel lists, built on first use.
  bool cells_built = false;
  double cell_size = 0;
  double cell_lo[3] = {0, 0, 0};
  cl_uint cell_n[3] = {1, 1, 1};
  boost::compute::buffer cell_start_buf, cell_list_buf;

  Impl(Context& c, const KernelMap& m, const EvalOptions& o);

  void run_batch(const double* pts, std::size_t n, float* mean, float* var, float* prob);
  void run_grid(const GridSpec& grid, float* mean, float* var, float* prob);
  void run_band(const GridSpec& columns, const std::vector<double>& levels, float* mean, float* var,
                float* prob);
  void run_blocks(const VoxelBlocks& blocks, float* var, float* prob, float* support);
  void build_cells();
};

namespace detail {

/// A CSR table of per-item kernel lists: start (items + 1 offsets) and the flat list (at least
/// one entry, so that its buffer is never empty).
struct KernelLists {
  std::vector<std::uint32_t> start, flat;
};
/// Flattens per-item lists into CSR form.
KernelLists flatten(const std::vector<std::vector<std::uint32_t>>& lists);

}  // namespace detail

}  // namespace potmap
