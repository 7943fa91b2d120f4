#pragma once
// wavemap (github.com/ethz-asl/wavemap) as a peer of the experiments: its hashed chunked wavelet
// octree updated by its projective integrator for LIDARs (spherical projection, continuous beam
// measurement model), keyframe by keyframe. Compiled only when CMake is given
// -DPOTMAP_WAVEMAP_DIR=<wavemap's install prefix> (POTMAP_WITH_WAVEMAP is then defined for
// whoever links potmap::experiments); without it nothing here is built or linked.
//
// This header holds no wavemap or Eigen type: wavemap compiles with -march=native, so its
// translation unit must share no inline Eigen code with the rest of potmap.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "potmap/data/scan.hpp"
#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// The sensor's field of view and the range image wavemap projects a keyframe into, degrees in
/// the sensor frame (x forward, z up; azimuth atan2(y, x), elevation above the xy plane).
struct WavemapProjection {
  double azimuth_min = -180, azimuth_max = 180;
  double elevation_min = -17, elevation_max = 17;
  int azimuth_cells = 1024;  ///< pixels across the azimuth range
  int elevation_cells = 64;  ///< pixels across the elevation range
};

/// wavemap's settings. The defaults are those of its Ouster OS1 configuration
/// (interfaces/ros1/wavemap_ros/config/wavemap_ouster_os1.yaml) on the map its documentation
/// recommends (hashed_chunked_wavelet_octree with its integrator).
struct WavemapOptions {
  double cell = 0.2;       ///< min_cell_width, metres (> 0)
  double min_range = 1.0;  ///< metres: cells closer to the sensor are not updated
  /// Metres: wavemap updates no cell farther from the sensor; a return beyond it is a free
  /// beam up to it. 0 (default): each scan's max_range (the experiments' cut).
  double max_range = 0;
  double angle_sigma_deg = 0.05;  ///< continuous_beam: the beam's angular spread, degrees
  /// continuous_beam: range noise, metres; 0 (default): max(cell / 2, 0.05), the value its
  /// configurations recommend.
  double range_sigma = 0;
  double scaling_free = 0.2;      ///< continuous_beam's weight of free updates
  double scaling_occupied = 0.4;  ///< continuous_beam's weight of occupied updates
  /// Threads of wavemap's integrator; 0 (default): its own default (one per core).
  int threads = 0;
};

/// A wavemap occupancy map.
class WavemapGrid {
 public:
  /// Throws ArgumentError for settings wavemap's own checks refuse (a cell or range not
  /// positive, an empty field of view, no pixels).
  WavemapGrid(const WavemapOptions& options, const WavemapProjection& projection);
  ~WavemapGrid();
  WavemapGrid(WavemapGrid&&) noexcept;
  WavemapGrid& operator=(WavemapGrid&&) noexcept;

  /// Integrates every beam of a 3D `scan` (world frame, as read): the returns as the
  /// pointcloud's points in the sensor frame, each no-return beam as a point past the maximum
  /// range along its direction, which wavemap takes as free space up to that range. Then the
  /// map's log-odds are clamped to its bounds (wavemap's threshold operation).
  void insert(const Scan& scan);
  /// Ends a run of inserts: prunes the map (lossless) so that memory_bytes() is what it holds.
  void finish();

  /// Occupancy probability at n points (3n coordinates, world frame): the logistic of the
  /// log-odds of the finest cell that holds the point (wavemap's nearest-neighbour lookup);
  /// 0.5 where no beam reached.
  void probability(const double* points, std::size_t n, double* prob) const;
  /// 1 where the map's log-odds differ from the prior (|l| >= 1e-3, wavemap's own test of an
  /// observed cell), else 0.
  void observed(const double* points, std::size_t n, std::uint8_t* observed) const;

  std::size_t memory_bytes() const;  ///< wavemap's getMemoryUsage() of the map
  std::size_t cells() const;         ///< nodes the map holds (its size())

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The field of view of `scans` (3D, world frame): every beam's azimuth and elevation in its
/// sensor's frame, their extremes widened by half a pixel of `pitch_deg` (azimuth, elevation);
/// an azimuth span over 350 degrees is the whole circle. The pixel counts cover the span at
/// that pitch. Throws ArgumentError for 2D scans or no beam.
WavemapProjection wavemap_projection(const std::vector<Scan>& scans, double azimuth_pitch_deg,
                                     double elevation_pitch_deg);

}  // namespace potmap
POTMAP_CXX_API_END
