#pragma once
// A small built-in scene for demos and tests when no real data is at hand: a 2D yard with
// rectangular buildings, a kernel map fitted to it by hand (kernels on a grid, positive weights
// on obstacles, negative in free space, shrinking variance near the boundary), and labelled test
// points drawn from the ground truth. Deterministic for a given seed.

#include <cstdint>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct SyntheticScene {
  KernelMap map;          ///< 2D kernel map over the scene
  LabelledPoints test;    ///< labelled points: half on obstacles, half free
  double bounds[4] = {};  ///< xmin, xmax, ymin, ymax of the scene, metres
};

/// Builds the scene. `spacing`: kernel grid spacing in metres (default 0.5); `test_points`:
/// number of labelled points (default 2000); `seed` makes the obstacles and points reproducible.
SyntheticScene make_synthetic_scene(std::uint32_t seed = 1, double spacing = 0.5,
                                    std::size_t test_points = 2000);

/// Ground truth of the scene made with `seed`: true where (x, y) is inside an obstacle. Draws
/// the scene's obstacles again on every call: for many queries, use SyntheticTruth.
bool synthetic_occupied(std::uint32_t seed, double x, double y);

/// The same ground truth with the obstacles drawn once, for many queries (ray casting).
class SyntheticTruth {
 public:
  explicit SyntheticTruth(std::uint32_t seed);
  /// true where (x, y), metres, is inside an obstacle.
  bool occupied(double x, double y) const;

 private:
  std::vector<double> boxes_;  // x0, x1, y0, y1 per obstacle
};

}  // namespace potmap
POTMAP_CXX_API_END
