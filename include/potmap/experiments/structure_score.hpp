#pragma once
// Structural score of an occupancy map: do its occupied cells lie where a reference's are, and
// does it cover them? ACC, AUC and NLL score held-out samples one by one, so a map of blobs
// around the walls, or a lattice of dots along them, can rank hits above free samples and still
// look nothing like the walls. This score compares the two sets of occupied cells as shapes.
//
// The experiments (`potmap experiment`) take as reference an OctoMap occupancy grid at 0.1 m of
// the task's own training beams (fine enough to hold a wall one cell thick) and score every
// method's map against it on a raster of that cell size over the task's window. The reference
// is a map too (it has the same training beams and no held-out ones): the score says how close
// a map comes to what a fine grid makes of the same data, not to the ground truth.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>
#include "potmap/export.h"

#include "potmap/experiments/experiment.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Occupied cells of a map against those of a reference on the same raster.
struct StructureScore {
  /// Fraction of the map's occupied cells within the tolerance of a reference occupied cell;
  /// NaN when the map has no occupied cell (nothing to be right or wrong about).
  double precision = NAN;
  /// Fraction of the reference's occupied cells within the tolerance of a map occupied cell;
  /// NaN when the reference has no occupied cell.
  double recall = NAN;
  /// Harmonic mean of precision and recall: 0 when both are 0 and when exactly one side has no
  /// occupied cell (one has structure the other lacks entirely), NaN when neither has any.
  double f1 = NAN;
  /// Mean of the two directed mean distances, metres, from each occupied cell (centre) of one
  /// side to the nearest occupied cell of the other; NaN when either side has none.
  double chamfer_m = NAN;
  std::size_t map_cells = 0;        ///< occupied cells of the map
  std::size_t reference_cells = 0;  ///< occupied cells of the reference
};

/// Scores `map` against `reference`: two boolean rasters of one window, row-major, `width` x
/// `height` cells (non-zero: occupied), `cell_m` metres a side (> 0). Distances are Euclidean
/// between cell centres, within the window only, from an exact distance transform (two passes of
/// the 1D lower envelope of parabolas, Felzenszwalb and Huttenlocher 2012), so the cost is
/// linear in the cells. A cell is "within the tolerance" when its distance is at most
/// `tolerance_m` metres (default 0.2: two cells at 0.1 m, so a wall drawn one cell beside the
/// reference's still counts while a blob reaching 0.3 m past it does not; an exact match is
/// tolerance 0). A raster of no cells (width or height 0) is valid: both counts 0, every score
/// NaN. Throws ArgumentError for cell_m <= 0, tolerance_m < 0 (or not finite) or null data with
/// cells.
StructureScore structure_score(const std::uint8_t* map, const std::uint8_t* reference,
                               std::size_t width, std::size_t height, double cell_m,
                               double tolerance_m = 0.2);
/// The same on vectors of width * height cells (throws ArgumentError for another size).
StructureScore structure_score(const std::vector<std::uint8_t>& map,
                               const std::vector<std::uint8_t>& reference, std::size_t width,
                               std::size_t height, double cell_m, double tolerance_m = 0.2);

/// Distance, metres, from the centre of every cell of a `width` x `height` raster (row-major,
/// `cell_m` metres a side) to the centre of the nearest occupied cell (non-zero); +infinity
/// everywhere when no cell is occupied, 0 at occupied cells. Exact Euclidean.
std::vector<double> distance_to_occupied(const std::uint8_t* occupied, std::size_t width,
                                         std::size_t height, double cell_m);

}  // namespace potmap
POTMAP_CXX_API_END

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

/// The raster a task is scored on: cells of `cell_m` metres aligned to multiples of the cell
/// size (as OctoMap's cells are, so that each raster cell is exactly one grid cell of the
/// reference), covering the task's window. Row 0 is the lowest y, column 0 the lowest x.
struct StructureGrid {
  double cell_m = 0.1;       ///< cell edge, metres
  double tolerance_m = 0.2;  ///< tolerance the score uses, metres
  std::int64_t ix0 = 0;      ///< column 0 spans [ix0, ix0 + 1) * cell_m in x
  std::int64_t iy0 = 0;      ///< row 0 spans [iy0, iy0 + 1) * cell_m in y
  std::size_t width = 0;     ///< columns
  std::size_t height = 0;    ///< rows
  std::size_t cells() const { return width * height; }
  double x(std::size_t c) const { return (double(ix0) + double(c) + 0.5) * cell_m; }
  double y(std::size_t r) const { return (double(iy0) + double(r) + 0.5) * cell_m; }
};

/// The raster over [lo, hi] (x, y; metres) at `cell_m` metres (default 0.1: the reference
/// grid's cell, fine enough for a wall one cell thick) with `tolerance_m` (default 0.2, see
/// structure_score). A window of more than `max_cells` cells (default 4,000,000: a 200 x 200 m
/// area at 0.1 m, 4 MB per boolean raster and 32 MB per distance transform, which bounds the
/// memory and the time of a huge window) is coarsened instead, to the smallest integer multiple k
/// of cell_m that fits, and the tolerance grows by the same factor (it stays two cells): the record
/// says which cell size it got. Throws ArgumentError for a window that is empty or not finite,
/// cell_m <= 0 or max_cells 0.
StructureGrid structure_grid(const double lo[3], const double hi[3], double cell_m = 0.1,
                             double tolerance_m = 0.2, std::size_t max_cells = 4000000);

/// Occupied cells of a fitted map: its query() at every cell centre, occupied where
/// p >= 0.5 except in the band p <= 0.501 next to 0.5, which is "no evidence" (a cell no beam
/// touched in an occupancy grid; a point no kernel reaches in a kernel map, exactly 0.5 on the
/// float device evaluator but a hair either side in the CPU's double sum of far tails) and
/// counts as free, as the reference's unknown cells do (a touched OctoMap cell is at least one
/// update, 0.4 or 0.7, away from 0.5); NaN counts as free too. `dim` is the map's dimension (2; for
/// 3 the points are at height `z`).
std::vector<std::uint8_t> occupied_cells(const FittedMap& map, int dim, const StructureGrid& grid,
                                         double z = 0);

/// The reference of a 2D task: an OctoMap occupancy grid with cells of grid.cell_m (the OGM
/// method's model, prob_hit 0.7, prob_miss 0.4, rays cut at each scan's max_range) built from
/// every training scan of the task in order, as a FittedMap (query: the grid's probability,
/// 0.5 where unknown). Throws ArgumentError for a task whose dim is not 2: the experiments skip
/// the score on 3D tasks (a 3D grid at 0.1 m of full LIDAR frames would cost more than the
/// methods it scores).
FittedMap structure_reference(const MapTask& task, const StructureGrid& grid);

/// Scores `map` on the grid against the occupied cells `reference` (occupied_cells of the
/// reference map on the same grid).
StructureScore score_structure(const FittedMap& map, int dim, const StructureGrid& grid,
                               const std::vector<std::uint8_t>& reference);

}  // namespace potmap::experiment
POTMAP_CXX_API_END
