#pragma once
// A procedural LIDAR simulator of urban towns (the paper's Carla towns are the domains POT
// transfers between; they cannot ship with the code, so potmap generates its own).
//
// A town is a street grid whose blocks hold buildings; parked cars, poles and trees line the
// streets. Every obstacle is a vertical prism over a convex polygon (buildings, cars) or a circle
// (poles, tree trunks), between heights z0 and z1, so one ray caster serves 2D (horizontal
// rays) and 3D (rays with elevation, plus the ground plane z = 0). Units: metres, radians.

#include <cstdint>
#include <string>
#include <vector>

#include "potmap/data/scan.hpp"
#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct Obstacle {
  enum Kind { kBuilding, kCar, kPole, kTree } kind = kBuilding;
  std::vector<double> polygon;        ///< convex, counter-clockwise x, y pairs; empty for circles
  double cx = 0, cy = 0, radius = 0;  ///< circle (poles, trunks) when polygon is empty
  double z0 = 0, z1 = 10;             ///< vertical extent, metres
};

/// How a town is generated. Defaults give a small, Carla-Town-1-like grid.
struct TownStyle {
  int blocks_x = 4, blocks_y = 3;  ///< blocks along x and y
  double block = 60;               ///< block side, metres
  double street = 14;              ///< street width between blocks, metres
  double building_fill = 0.8;      ///< fraction of a block's perimeter lined by buildings
  double setback = 2;              ///< metres from curb to building front
  int shape = 0;                   ///< 0 rectangles, 1 L-shapes and courtyards, 2 rotated houses
  double cars_per_100m = 6;        ///< parked cars per 100 m of curb
  double poles_per_100m = 3;       ///< poles per 100 m of curb
  double trees_per_100m = 2;       ///< trees per 100 m of curb
};

class Town {
 public:
  /// Generates a town; the same style and seed give the same town everywhere.
  Town(const std::string& name, const TownStyle& style, std::uint64_t seed);
  /// A built-in town: "town1" (regular terraces, Carla Town 1), "town2" (large L-shaped blocks,
  /// leafy), "town3" (dense rotated houses, many poles). Throws ArgumentError for other names.
  static Town builtin(const std::string& name, std::uint64_t seed = 0);

  const std::string& name() const { return name_; }
  double width() const { return width_; }    ///< metres, x from 0
  double height() const { return height_; }  ///< metres, y from 0
  const std::vector<Obstacle>& obstacles() const { return obs_; }
  /// Centre lines of the streets: intersections are at street_centre(i, j).
  void street_centre(int i, int j, double& x, double& y) const;
  int intersections_x() const { return style_.blocks_x + 1; }
  int intersections_y() const { return style_.blocks_y + 1; }

  /// Ground truth: is (x, y) inside an obstacle (any height)? `extra`: obstacles beside the
  /// town's own, such as the moving vehicles of one scan (Simulation::moving); default none.
  bool occupied(double x, double y, const std::vector<Obstacle>* extra = nullptr) const;
  /// Ground truth in 3D: inside an obstacle's prism, or below the ground (z < 0); `extra` as above.
  bool occupied(double x, double y, double z, const std::vector<Obstacle>* extra = nullptr) const;

  /// Distance (metres) along a ray from (x, y, z) with horizontal heading `yaw` and elevation
  /// `elev` to the first surface, or +inf when nothing lies within max_range. When `ground` is
  /// true the plane z = 0 is a surface. `extra` obstacles (moving vehicles) are tested too.
  double cast(double x, double y, double z, double yaw, double elev, double max_range, bool ground,
              const std::vector<Obstacle>* extra = nullptr) const;

 private:
  void build_grid();
  std::string name_;
  TownStyle style_;
  double width_ = 0, height_ = 0;
  std::vector<Obstacle> obs_;
  double cell_ = 8;
  int gx_ = 0, gy_ = 0;
  std::vector<std::vector<std::uint32_t>> grid_;
};

struct SimOptions {
  std::size_t scans = 100;     ///< number of scans along the route
  double spacing = 1.0;        ///< metres driven between scans
  double max_range = 20;       ///< metres (the paper's Carla LIDAR)
  double step_deg = 1;         ///< horizontal angular step, degrees (360 / step beams per ring)
  bool three_d = false;        ///< multi-beam 3D sensor instead of one horizontal ring
  int channels = 16;           ///< 3D: number of rings
  double elev_min_deg = -15;   ///< 3D: lowest ring, degrees
  double elev_max_deg = 15;    ///< 3D: highest ring, degrees
  double sensor_height = 1.8;  ///< metres above ground
  int moving_vehicles = 0;     ///< other cars driving the streets (dynamic scenes)
  std::uint64_t seed = 0;      ///< route and moving-vehicle seed
};

struct Simulation {
  std::vector<Scan> scans;
  std::vector<double> route;  ///< x, y of the sensor at each scan
  /// The moving vehicles where they were at each scan (empty lists without moving vehicles):
  /// pass moving[i] to Town::occupied for the ground truth of a dynamic scene at scan i.
  std::vector<std::vector<Obstacle>> moving;
};

/// Drives a vehicle along a seeded random route over the street grid and scans at every stop.
/// Beams with nothing within max_range are no-returns. Timestamps are scan index * 0.1 s.
Simulation simulate(const Town& town, const SimOptions& options);

}  // namespace potmap
POTMAP_CXX_API_END

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Writes a top view of the town (buildings dark grey, cars blue, poles and trees green) with
/// the route in red as an 8-bit RGB PNG; `metres_per_pixel` default 0.5.
void write_town_png(const Town& town, const std::vector<double>& route, const std::string& path,
                    double metres_per_pixel = 0.5);

/// Writes simulated scans as a dataset the readers load back:
///   2D: `scans.log`, CARMEN ROBOTLASER1 lines (start angle, field of view, maximum range per
///       line; a no-return beam is written at the maximum range), read by read_carmen.
///   3D: `velodyne/NNNNNN.bin` frames in the sensor frame (N x 4 float32, reflectance 0, read by
///       read_kitti_bin; no-returns are not stored), `poses.txt` (sensor-to-world 3 x 4 per
///       frame) and `calib.txt` with an identity `Tr:`, read by read_kitti_poses.
/// Returns the main file written (scans.log or poses.txt).
std::string write_simulation(const Simulation& sim, const SimOptions& options,
                             const std::string& dir);

}  // namespace potmap
POTMAP_CXX_API_END
