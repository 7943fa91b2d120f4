// The structural score (structure_score.hpp): precision, recall, F1 and chamfer distance of
// occupied cells, on rasters whose answers can be worked out by hand, and the experiments'
// rasters (aligned grid, occupied cells of a fitted map, the OGM reference).
#include "potmap/experiments/structure_score.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "potmap/error.hpp"

using namespace potmap;

namespace {

struct Raster {
  std::size_t w, h;
  std::vector<std::uint8_t> v;
  Raster(std::size_t w_, std::size_t h_) : w(w_), h(h_), v(w_ * h_, 0) {}
  void set(std::size_t r, std::size_t c) { v[r * w + c] = 1; }
};

// A vertical wall one cell thick at column `c`, rows [r0, r1).
Raster wall(std::size_t w, std::size_t h, std::size_t c, std::size_t r0, std::size_t r1) {
  Raster g(w, h);
  for (std::size_t r = r0; r < r1; ++r) g.set(r, c);
  return g;
}

}  // namespace

TEST(StructureScore, IdenticalRastersScoreOne) {
  Raster g = wall(40, 30, 12, 3, 27);
  g.set(5, 30);  // and a lone cell
  g.set(20, 2);
  const StructureScore s = structure_score(g.v, g.v, g.w, g.h, 0.1);
  EXPECT_EQ(s.map_cells, 26u);
  EXPECT_EQ(s.reference_cells, 26u);
  EXPECT_DOUBLE_EQ(s.precision, 1.0);
  EXPECT_DOUBLE_EQ(s.recall, 1.0);
  EXPECT_DOUBLE_EQ(s.f1, 1.0);
  EXPECT_DOUBLE_EQ(s.chamfer_m, 0.0);
}

// Three cells at 0.1 m is 0.3 m, past the 0.2 m tolerance: nothing matches, and every cell of
// either wall is exactly 0.3 m from the other wall.
TEST(StructureScore, WallShiftedThreeCellsMatchesNothing) {
  const Raster ref = wall(40, 30, 12, 0, 30);
  const Raster map = wall(40, 30, 15, 0, 30);
  const StructureScore s = structure_score(map.v, ref.v, 40, 30, 0.1, 0.2);
  EXPECT_EQ(s.precision, 0.0);
  EXPECT_EQ(s.recall, 0.0);
  EXPECT_EQ(s.f1, 0.0);
  EXPECT_NEAR(s.chamfer_m, 0.3, 1e-12);
  // Two cells (0.2 m) is within the tolerance, inclusive.
  const Raster near = wall(40, 30, 14, 0, 30);
  const StructureScore t = structure_score(near.v, ref.v, 40, 30, 0.1, 0.2);
  EXPECT_DOUBLE_EQ(t.precision, 1.0);
  EXPECT_DOUBLE_EQ(t.recall, 1.0);
  EXPECT_NEAR(t.chamfer_m, 0.2, 1e-12);
}

// Blobs over a wall: every wall cell is covered (recall 1), but most of the blobs' cells are far
// from it (precision low). The opposite failure, a lattice of dots along the wall: every dot is
// on the wall (precision 1), most of the wall far from a dot (recall low).
TEST(StructureScore, BlobsLoseOnPrecisionDotsOnRecall) {
  const std::size_t w = 80, h = 80;
  const Raster ref = wall(w, h, 40, 10, 70);
  Raster blobs(w, h);
  for (std::size_t cr = 10; cr < 70; cr += 10)  // disks of radius 8 cells along the wall
    for (std::size_t r = 0; r < h; ++r)
      for (std::size_t c = 0; c < w; ++c) {
        const double dr = double(r) - double(cr), dc = double(c) - 40.0;
        if (dr * dr + dc * dc <= 64) blobs.set(r, c);
      }
  const StructureScore b = structure_score(blobs.v, ref.v, w, h, 0.1, 0.2);
  EXPECT_DOUBLE_EQ(b.recall, 1.0);
  EXPECT_LT(b.precision, 0.4);  // 5 of the 17 columns of a disk lie within 2 cells of the wall
  EXPECT_LT(b.f1, 0.6);
  EXPECT_GT(b.map_cells, 5 * b.reference_cells);

  Raster dots(w, h);
  for (std::size_t r = 12; r < 70; r += 10) dots.set(r, 40);  // rows 12, 22, ..., 62
  const StructureScore d = structure_score(dots.v, ref.v, w, h, 0.1, 0.2);
  EXPECT_DOUBLE_EQ(d.precision, 1.0);
  // Each dot covers the 5 wall cells within 2 of it: 6 dots, 30 of 60 cells.
  EXPECT_DOUBLE_EQ(d.recall, 0.5);
  EXPECT_NEAR(d.f1, 2 * 0.5 / 1.5, 1e-12);
}

TEST(StructureScore, EmptySides) {
  const Raster none(20, 10);
  const Raster some = wall(20, 10, 5, 0, 10);
  const StructureScore both = structure_score(none.v, none.v, 20, 10, 0.1);
  EXPECT_EQ(both.map_cells, 0u);
  EXPECT_EQ(both.reference_cells, 0u);
  EXPECT_TRUE(std::isnan(both.precision));
  EXPECT_TRUE(std::isnan(both.recall));
  EXPECT_TRUE(std::isnan(both.f1));
  EXPECT_TRUE(std::isnan(both.chamfer_m));

  const StructureScore no_map = structure_score(none.v, some.v, 20, 10, 0.1);
  EXPECT_TRUE(std::isnan(no_map.precision));
  EXPECT_EQ(no_map.recall, 0.0);
  EXPECT_EQ(no_map.f1, 0.0);
  EXPECT_TRUE(std::isnan(no_map.chamfer_m));
  EXPECT_EQ(no_map.reference_cells, 10u);

  const StructureScore no_ref = structure_score(some.v, none.v, 20, 10, 0.1);
  EXPECT_EQ(no_ref.precision, 0.0);
  EXPECT_TRUE(std::isnan(no_ref.recall));
  EXPECT_EQ(no_ref.f1, 0.0);
  EXPECT_TRUE(std::isnan(no_ref.chamfer_m));

  // A raster of no cells at all.
  const StructureScore zero = structure_score(nullptr, nullptr, 0, 0, 0.1);
  EXPECT_EQ(zero.map_cells + zero.reference_cells, 0u);
  EXPECT_TRUE(std::isnan(zero.f1));
  EXPECT_TRUE(distance_to_occupied(nullptr, 0, 5, 0.1).empty());
}

// 3 x 3 cells of 0.5 m. Map: the cell at row 0, column 0; reference: (0, 2) and (2, 2).
// Map to reference: 2 cells = 1 m. Reference to map: 2 cells and sqrt(8) cells, mean
// (2 + 2.828...) / 2 cells. Chamfer: the mean of the two, times 0.5 m.
TEST(StructureScore, ChamferByHand) {
  Raster map(3, 3), ref(3, 3);
  map.set(0, 0);
  ref.set(0, 2);
  ref.set(2, 2);
  const StructureScore s = structure_score(map.v, ref.v, 3, 3, 0.5, 1.0);
  const double expect = 0.5 * (2.0 + 0.5 * (2.0 + std::sqrt(8.0))) * 0.5;
  EXPECT_NEAR(s.chamfer_m, expect, 1e-12);
  EXPECT_DOUBLE_EQ(s.precision, 1.0);  // (0, 0) is 1 m from (0, 2): within 1 m
  EXPECT_DOUBLE_EQ(s.recall, 0.5);     // (2, 2) is 1.41 m from the map's cell
  EXPECT_NEAR(s.f1, 2.0 / 3.0, 1e-12);
}

// The distance transform is exact: against brute force on random rasters of several densities
// and shapes (one row, one column, wide, tall).
TEST(StructureScore, DistanceTransformIsExact) {
  std::mt19937 rng(7);
  const std::size_t shapes[][2] = {{1, 1}, {1, 17}, {23, 1}, {31, 19}, {8, 40}, {50, 50}};
  for (const auto& sh : shapes)
    for (double density : {0.0, 0.002, 0.03, 0.3, 0.9}) {
      const std::size_t w = sh[0], h = sh[1];
      std::bernoulli_distribution occ(density);
      std::vector<std::uint8_t> g(w * h);
      for (auto& x : g) x = occ(rng);
      const std::vector<double> d = distance_to_occupied(g.data(), w, h, 0.25);
      ASSERT_EQ(d.size(), w * h);
      for (std::size_t r = 0; r < h; ++r)
        for (std::size_t c = 0; c < w; ++c) {
          double best = HUGE_VAL;
          for (std::size_t r2 = 0; r2 < h; ++r2)
            for (std::size_t c2 = 0; c2 < w; ++c2)
              if (g[r2 * w + c2]) {
                const double dr = double(r) - double(r2), dc = double(c) - double(c2);
                best = std::min(best, std::sqrt(dr * dr + dc * dc) * 0.25);
              }
          if (std::isinf(best))
            EXPECT_TRUE(std::isinf(d[r * w + c])) << w << "x" << h << " " << density;
          else
            EXPECT_NEAR(d[r * w + c], best, 1e-12)
                << w << "x" << h << " density " << density << " at " << r << "," << c;
        }
    }
}

TEST(StructureScore, RejectsBadArguments) {
  const Raster g(4, 4);
  EXPECT_THROW(structure_score(g.v, g.v, 4, 4, 0.0), ArgumentError);
  EXPECT_THROW(structure_score(g.v, g.v, 4, 4, 0.1, -1), ArgumentError);
  EXPECT_THROW(structure_score(g.v, g.v, 4, 5, 0.1), ArgumentError);  // size mismatch
  EXPECT_THROW(structure_score(nullptr, g.v.data(), 4, 4, 0.1), ArgumentError);
}

// The experiments' raster: cells aligned to multiples of the cell size, covering the window;
// a huge window coarsened by an integer factor, tolerance scaled with it.
TEST(StructureScore, GridIsAlignedAndCoarsenedWhenHuge) {
  const double lo[3] = {-1.23, 0.05, 0}, hi[3] = {2.0, 1.0, 0};
  const experiment::StructureGrid g = experiment::structure_grid(lo, hi, 0.1, 0.2);
  EXPECT_DOUBLE_EQ(g.cell_m, 0.1);
  EXPECT_EQ(g.ix0, -13);
  EXPECT_EQ(g.iy0, 0);
  EXPECT_EQ(g.width, 33u);  // [-1.3, 2.0)
  EXPECT_EQ(g.height, 10u);
  EXPECT_NEAR(g.x(0), -1.25, 1e-12);
  EXPECT_LE(g.x(0) - 0.05, lo[0]);
  EXPECT_GE(g.x(g.width - 1) + 0.05, hi[0] - 1e-9);

  const double blo[3] = {0, 0, 0}, bhi[3] = {1000, 1000, 0};
  const experiment::StructureGrid b = experiment::structure_grid(blo, bhi, 0.1, 0.2, 4000000);
  EXPECT_NEAR(b.cell_m, 0.5, 1e-12);  // 10,000^2 cells at 0.1 m; 2000^2 = 4M at 0.5 m
  EXPECT_NEAR(b.tolerance_m, 1.0, 1e-12);
  EXPECT_LE(b.cells(), 4000000u);
  const experiment::StructureGrid c = experiment::structure_grid(blo, bhi, 0.1, 0.2, 3999999);
  EXPECT_NEAR(c.cell_m, 0.6, 1e-12);
  EXPECT_LE(c.cells(), 3999999u);
  const double flat[3] = {0, 0, 0};
  EXPECT_THROW(experiment::structure_grid(flat, flat), ArgumentError);
}

// Occupied cells of a map through its query: p above 0.5 counts, 0.5 exactly (and the band of
// no evidence just above it, and NaN) does not.
TEST(StructureScore, OccupiedCellsFollowTheQuery) {
  experiment::FittedMap f;
  f.query = [](const double* p, std::size_t n, double* prob, double*) {
    for (std::size_t i = 0; i < n; ++i) {
      const double x = p[2 * i], y = p[2 * i + 1];
      prob[i] = x < 1 ? 0.9 : x < 2 ? 0.5 : x < 3 ? 0.5005 : x < 4 ? NAN : y < 0.5 ? 0.6 : 0.1;
    }
  };
  const double lo[3] = {0, 0, 0}, hi[3] = {5, 1, 0};
  const experiment::StructureGrid g = experiment::structure_grid(lo, hi, 0.1, 0.2);
  ASSERT_EQ(g.width, 50u);
  ASSERT_EQ(g.height, 10u);
  const std::vector<std::uint8_t> occ = experiment::occupied_cells(f, 2, g);
  for (std::size_t r = 0; r < g.height; ++r)
    for (std::size_t c = 0; c < g.width; ++c) {
      const bool expect = c < 10 || (c >= 40 && r < 5);
      EXPECT_EQ(occ[r * g.width + c] != 0, expect) << r << "," << c;
    }
}

// The reference of a task: an OGM of its training beams. A scan facing a wall 5 m ahead gives
// occupied cells along the wall and nowhere else; a map that is the wall band scores high.
TEST(StructureScore, OgmReferenceMarksTheWall) {
  Scan s;
  s.dim = 2;
  s.max_range = 20;
  for (int i = -40; i <= 40; ++i) {
    const double y = 0.1 * i;
    s.hits.push_back(5.05);
    s.hits.push_back(y + 0.05);
  }
  LabelOptions lo;
  lo.holdout_fraction = 0;
  LabelledPoints test;
  const experiment::MapTask task = experiment::make_task({s}, lo, test);
  const experiment::StructureGrid g = experiment::structure_grid(task.lo, task.hi);
  const experiment::FittedMap ref = experiment::structure_reference(task, g);
  const std::vector<std::uint8_t> occ = experiment::occupied_cells(ref, 2, g);
  std::size_t on_wall = 0, off_wall = 0;
  for (std::size_t r = 0; r < g.height; ++r)
    for (std::size_t c = 0; c < g.width; ++c)
      if (occ[r * g.width + c]) (std::abs(g.x(c) - 5.05) < 0.06 ? on_wall : off_wall) += 1;
  EXPECT_GE(on_wall, 75u);  // 81 beams, one cell each
  EXPECT_EQ(off_wall, 0u);
  // The reference scores 1 against itself; a band 0.9 m wide over the wall loses precision.
  experiment::FittedMap band;
  band.query = [](const double* p, std::size_t n, double* prob, double*) {
    for (std::size_t i = 0; i < n; ++i)
      prob[i] = std::abs(p[2 * i] - 5.05) < 0.45 && std::abs(p[2 * i + 1]) < 4.1 ? 0.8 : 0.2;
  };
  EXPECT_DOUBLE_EQ(experiment::score_structure(ref, 2, g, occ).f1, 1.0);
  const StructureScore b = experiment::score_structure(band, 2, g, occ);
  EXPECT_GT(b.recall, 0.95);
  EXPECT_LT(b.precision, 0.7);  // 5 of the band's 9 columns lie within 0.2 m of the wall
  experiment::MapTask t3;
  t3.dim = 3;
  EXPECT_THROW(experiment::structure_reference(t3, g), ArgumentError);
}
