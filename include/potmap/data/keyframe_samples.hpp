#pragma once
// A 3D keyframe's samples for a learner, gathered per voxel on the OpenCL device: the free-space
// samples along every training beam are drawn, binned into small voxels and counted there in
// one pass over the beams, so the host never holds the keyframe's samples one by one
// (riverside-a at a 40 m cut: 0.5 million samples a keyframe, 0.2 million voxels).
//
// The samples are label_scan()'s, drawn from the same generator (SplitMix64 jumps to each
// beam's first draw, so every beam is drawn on its own work-item), and the voxels are
// aggregate_voxels()'s: the result equals aggregate_voxels(label_scan(...).train) up to the
// position of a voxel's mean, which is summed in fixed point (2^-20 of the voxel's edge, half a
// micrometre at 0.5 m) so that the device's sums do not depend on the order its work-items
// meet: the device and the host reference agree bit for bit.

#include <cstddef>
#include <cstdint>

#include "potmap/data/labelled_points.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

class Context;

struct KeyframeSamples {
  /// The training beams' samples, one weighted sample for each label and voxel (voxels in
  /// raster order z, y, x; free before hits in a voxel), scan index as given.
  LabelledPoints train;
  /// The held-out beams' samples one by one, exactly label_scan()'s `test`.
  LabelledPoints test;
  std::size_t samples = 0;         ///< training samples before gathering
  std::size_t points_dropped = 0;  ///< beams with NaN or Inf end points (label_scan's count)
  bool on_device = false;          ///< the training samples were gathered on the device
};

/// Labels a 3D keyframe as label_scan(scan, scan_index, options) does and gathers its training
/// samples per voxel of edge `voxel` metres (> 0). With a context whose device has the 64-bit
/// atomics and doubles the gathering needs (cl_khr_int64_base_atomics, cl_khr_fp64: GPUs of
/// the last decade and PoCL have both), the free samples are drawn and counted there;
/// otherwise, and for a keyframe reaching farther than 2^19 voxels from the origin (262 km at
/// 0.5 m), on the host by gather_keyframe_reference(), with the same result. Throws
/// ArgumentError for a scan that is not 3D, a voxel that is not positive or bad options, and
/// OpenCLError naming the call when the device fails.
KeyframeSamples gather_keyframe(const Scan& scan, std::int64_t scan_index,
                                const LabelOptions& options, double voxel, Context* ctx);

/// The host reference of gather_keyframe(): the same samples, voxels and fixed-point sums.
KeyframeSamples gather_keyframe_reference(const Scan& scan, std::int64_t scan_index,
                                          const LabelOptions& options, double voxel);

}  // namespace potmap
POTMAP_CXX_API_END
