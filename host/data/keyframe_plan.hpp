#pragma once
// What the host prepares for gathering a keyframe (keyframe_samples.cpp, and the device path in
// keyframe_samples_device.cpp): each training beam's segment and generator state, the held-out
// samples, and the voxel keys and fixed-point sums that the device kernel
// (kernels/data/gather_voxels.cl) computes the same way.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "potmap/data/keyframe_samples.hpp"

namespace potmap::data {

// Voxel keys: 21 bits an axis (the voxel's index plus 2^20), z first, the label in the lowest
// bit, so keys sort as aggregate_voxels() orders its voxels. Indices are kept within +-2^19 so
// that no key is all ones (the device table's empty slot).
constexpr int kAxisBits = 21;
constexpr std::int64_t kAxisHalf = std::int64_t(1) << 20;
constexpr std::int64_t kAxisLimit = std::int64_t(1) << 19;
// A sample's place in its voxel: 20 bits an axis, summed in 64 bits (2^44 samples a voxel).
constexpr double kFracOne = 1048576.0;  // 2^20

struct KeyframePlan {
  double origin[3] = {0, 0, 0};
  // Training beams: direction (3 each), length, hit end point (3 each; zeros for a free beam),
  // the generator's state before the beam's first draw, and the draws | hit << 31.
  std::vector<double> dir, len, end;
  std::vector<std::uint64_t> state;
  std::vector<std::uint32_t> draws_hit;
  std::size_t samples = 0;  // training samples: hits and free draws
  double reach = 0;         // the farthest sample from the sensor, metres
  KeyframeSamples out;      // the held-out samples and the counts so far
};

/// Splits and measures the beams as label_scan() does; the held-out beams' samples are drawn
/// into out.test, the training beams are listed for drawing.
KeyframePlan plan_keyframe(const Scan& scan, std::int64_t scan_index, const LabelOptions& o);

/// True when every sample of the plan lies within +-kAxisLimit voxels of the origin.
bool plan_fits_keys(const KeyframePlan& plan, double voxel);

/// One gathered voxel: key, count and the fixed-point sums of its samples' places in it.
struct VoxelSum {
  std::uint64_t key;
  std::uint64_t count;
  std::uint64_t sum[3];
};

/// The voxels, sorted by key in place, as weighted samples of scan `scan_index`.
LabelledPoints voxels_to_samples(std::vector<VoxelSum>& voxels, double voxel,
                                 std::int64_t scan_index);

}  // namespace potmap::data
