#pragma once
// Device-specific launch choices, one plain struct per routine, so that a tuner can fill them
// and a reader finds every vector width, work-group size and chunk size in one place. The
// defaults are what each routine used before it had a tuning: wide vectors and small
// work-groups on CPU devices (PoCL vectorises explicit vector types and runs a work-group as a
// loop), many light work-items on GPUs. default_tuning() picks them per device; a Context holds
// the tuning its routines read: the device's tuning file from `potmap tune` when there is one
// (tuning_file.hpp), else these defaults, then ContextOptions::tuning or POTMAP_TUNING override
// fields.
//
// Results depend on a tuning only through the order of floating-point sums (work-group
// reductions), never on what is computed.

#include <cstddef>
#include <string>
#include <vector>

#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct DeviceInfo;

/// MapEvaluator's batch path (kernels/map/evaluate.cl) and device path (evaluate_cells.cl).
struct MapEvalTuning {
  /// Queries a work-item holds in vector registers (4, 8 or 16). CPU 16: PoCL keeps a float16
  /// in one AVX-512 or two AVX registers; GPU 4: more work-items, fewer registers each.
  int vector_width = 16;
  /// Work-items per work-group of the batch kernel (a power of two). CPU 8, GPU 64.
  int work_group = 8;
  /// Work-items per work-group of the device-buffer kernel. CPU 16, GPU 128.
  int cells_work_group = 16;
  /// Chunks (vector_width x work_group queries each) that share one kernel-index query on the
  /// host (default 16): fewer index walks, each chunk then filters the group's candidates.
  int chunks_per_query = 16;
};

/// MapEvaluator::evaluate_grid (kernels/map/raster.cl).
struct RasterTuning {
  /// Grid rows a work-item owns (4, 8 or 16; default 8 on every device): rows share the
  /// kernel loads of their 16 columns, more rows hold more accumulators in registers.
  int rows_per_item = 8;
  /// Tile edge, cells (16, 32 or 64; default 64 on every device): a work-group covers one tile
  /// of `tile` columns by `tile` rows (3D: 8 y rows by tile / 8 z rows) and every tile has its
  /// own list of the kernels that reach it. Smaller tiles list fewer far kernels per cell but
  /// build and walk more lists. At most 64 and a divisor of it, because rasterize() cuts its
  /// bands and TiledRasterOptions::tile_cells its tiles on multiples of 64 rows: with any of
  /// these tiles every cell is still computed by the same tile whatever the band.
  int tile = 64;
};

/// The batched Sinkhorn solver (kernels/ot/sinkhorn*.cl).
struct SinkhornTuning {
  /// Work-items per problem (a power of two); SinkhornOptions::work_group > 0 overrides it.
  /// CPU 4: a work-group is a loop on PoCL, and small groups keep every core busy with whole
  /// problems; 2 on PoCL's CPU device (see default_tuning); GPU 64.
  int work_group = 4;
  /// Resident work-groups per compute unit in the stabilised scheme, each with its own kernel
  /// matrix (default 4): enough to hide a group's barriers, few enough to bound the scratch.
  int groups_per_compute_unit = 4;
  /// Padded points (source and target) per launch at the most (default 2^18): the device
  /// scratch grows with the launch (about 100 bytes a slot). Results do not depend on it.
  std::size_t chunk_slots = std::size_t{1} << 18;
};

/// The BHM and ABHM learners (kernels/learn/).
struct LearnTuning {
  int bhm_work_group = 64;   ///< work-items per work-group of bhm_update.cl (default 64)
  int abhm_work_group = 64;  ///< work-items per work-group of abhm_grad.cl (default 64)
};

/// Every routine's tuning for one device.
struct Tuning {
  MapEvalTuning map_eval;
  RasterTuning raster;
  SinkhornTuning sinkhorn;
  LearnTuning learn;
};

/// The platform name PoCL reports (CL_PLATFORM_NAME), which keys its CPU device's tuning.
inline constexpr const char* kPoclPlatform = "Portable Computing Language";

/// True for PoCL's CPU device: platform kPoclPlatform and a CPU device type. PoCL's other
/// devices (its CUDA or remote drivers) are not, nor is any other platform's CPU device.
bool is_pocl_cpu(const DeviceInfo& device);

/// The built-in choices for `device`: the defaults above on a CPU, GPU values where it is not a
/// CPU, and on PoCL's CPU device (is_pocl_cpu) the CPU values with the fields below changed.
///
/// PoCL's CPU device (sinkhorn.work_group 1): PoCL runs a work-group on one core as loops over
/// its work-items, one loop per stretch between barriers, so a group's work-items add no
/// parallelism there, only loop overhead and the work-group reductions' barrier steps; the
/// cores are kept busy by the many problems of a launch instead, and each work-item already
/// works in 16-wide vectors. With one work-item a problem's strided loops and reductions are
/// plain loops (POT's coarse ranking, hundreds of problems of a few dozen points a side, runs
/// 1.14x faster than with 2, its transport 1.06x; docs/tuning.md). The log-domain scheme
/// (SinkhornOptions::stabilised = false) keeps 4 there: PoCL 3.1's compiler cannot build its
/// kernel with 1 or 2 work-items (host/ot/sinkhorn.cpp).
/// Only PoCL was measured: another CPU driver (Intel's vectorises across the work-items of a
/// group) compiles a work-group differently, so it keeps the generic CPU values until it is
/// measured (`potmap tune` writes a tuning file for it). The raster's tile stays 64 on PoCL
/// too: smaller tiles won the raster kernel alone, not a whole raster job (docs/tuning.md).
///
/// A device's tuning file (tuning_file.hpp), POTMAP_TUNING and ContextOptions::tuning apply
/// after these, as for every other device.
Tuning default_tuning(const DeviceInfo& device);

/// `base` with the fields named in `spec` replaced: `routine.field=value` pairs separated by
/// commas or white space, e.g. "sinkhorn.work_group=8, map_eval.vector_width=8". Routines and
/// fields are the struct members above (map_eval, raster, sinkhorn, learn). Throws
/// ArgumentError naming the pair for an unknown name, a value that is not a whole number, or
/// one the routine cannot run with (see validate_tuning).
Tuning parse_tuning(const std::string& spec, Tuning base);

/// Throws ArgumentError naming the field and value if a kernel cannot be built or launched
/// with `t` (vector widths and rows outside 4/8/16, work-groups not a power of two, zeros).
void validate_tuning(const Tuning& t);

/// The tuning as `routine.field=value` pairs, one per field, in the order of the structs: what
/// parse_tuning reads, for logs and benchmark records.
std::string to_string(const Tuning& t);

}  // namespace potmap
POTMAP_CXX_API_END
