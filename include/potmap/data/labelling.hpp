#pragma once
// Labelled samples from scans (SPEC section 1, paper Sec. II-A) and the beam-level hold-out split.

#include <cstdint>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct LabelOptions {
  /// Free samples per metre of free beam (default 1); every beam gets at least one.
  double free_per_metre = 1.0;
  /// Upper bound on free samples per beam (default 10000), so that a corrupt range (1e300 m in a
  /// log) cannot ask for an unbounded loop.
  long max_free_per_beam = 10000;
  /// Fraction of each scan's beams held out with all their samples (default 0.2). 0 disables.
  double holdout_fraction = 0.2;
  /// Seed of the free-sample positions and of the split (default 0). The same seed, scan index
  /// and scan give the same samples on every platform (no std:: distributions are used).
  std::uint64_t seed = 0;
};

struct LabelledSplit {
  LabelledPoints train;            ///< samples of the beams kept for learning
  LabelledPoints test;             ///< samples of the held-out beams
  std::size_t points_dropped = 0;  ///< NaN or Inf beam end points skipped
};

/// Labels one scan: a beam end point closer than scan.max_range is a hit (y = 1); free samples
/// (y = 0) lie uniformly on the segment from the sensor to the end point, or to max_range for a
/// no-return beam or a point beyond max_range. Every sample carries `scan_index` as its scan t.
/// An empty scan gives empty outputs. Appends to `out` (whose dim must match or be empty).
void label_scan(const Scan& scan, std::int64_t scan_index, const LabelOptions& options,
                LabelledSplit& out);

/// Which beams label_scan holds out for this scan, index and options: one flag per beam, hits
/// first (in scan.hits order), then no-returns (in scan.no_return order); 1 = held out. The same
/// draw label_scan makes, so the two always agree.
std::vector<std::uint8_t> heldout_beams(const Scan& scan, std::int64_t scan_index,
                                        const LabelOptions& options);

/// The scan with only its training beams (`held_out` false, default) or only its held-out beams
/// (`held_out` true) under the split of label_scan; pose, timestamp and max_range unchanged.
/// Methods that consume beams rather than samples (an occupancy grid carving free space along
/// rays) use it so that no held-out beam ever reaches them.
Scan split_beams(const Scan& scan, std::int64_t scan_index, const LabelOptions& options,
                 bool held_out = false);

/// Convenience: labels every scan of a dataset (scan index = position in the vector).
LabelledSplit label_scans(const std::vector<Scan>& scans, const LabelOptions& options = {});

/// The scan with every return farther than `max_range` metres from the sensor (horizontally in
/// 3D) turned into a no-return along the same direction, and max_range lowered to it; free
/// space is then sampled up to max_range along those beams. A scan whose max_range is already
/// at most `max_range` (or `max_range` <= 0) comes back unchanged. The experiments cut real logs
/// (80 m lasers) at the towns' 20 m, the radius POT's sectors are cut with, for every method.
Scan limit_range(const Scan& scan, double max_range);

/// The samples of each scan, label and voxel (edge `voxel` metres, cells of a grid through the
/// origin) gathered into one sample at their weighted mean position, weighing their summed
/// weight (LabelledPoints::weight; unweighted samples weigh 1). Why: a 3D keyframe's free samples
/// crowd the space near the sensor (on a car's Ouster at 0.5 samples a metre, 0.5 m voxels hold
/// 3 free samples on average, within 40 m), and samples that close carry nearly the same
/// features, so a learner that adds n samples of a voxel as one of weight n costs a third as
/// much for the same map up to the features' change across a voxel. Output: voxels in order of
/// scan, then raster order (z, y, x), free before hits; weights as given (zero-weight voxels
/// dropped). Throws ArgumentError for a voxel that is not positive or sizes that disagree.
LabelledPoints aggregate_voxels(const LabelledPoints& samples, double voxel);

/// The 2D slice of a 3D scan: points whose height above the sensor (metres, world z minus
/// sensor z) lies in [z_min, z_max] are projected onto the ground plane; the pose keeps x, y and
/// the yaw of the sensor. Defaults: a band of +-0.1 m around the sensor's height.
Scan slice_2d(const Scan& scan3d, double z_min = -0.1, double z_max = 0.1);

}  // namespace potmap
POTMAP_CXX_API_END
