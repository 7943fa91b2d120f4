// PointGrid (host/spatial/point_grid.hpp) against a scan of every point: the placement on the
// target's samples asks it for nearest points and neighbourhoods, and its anchors must be the
// ones a plain scan would give.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <stdexcept>
#include <utility>

#include "spatial/point_grid.hpp"

using potmap::detail::PointGrid;

namespace {

long brute_nearest(const std::vector<double>& pts, int dim, const double* q, double& best) {
  best = HUGE_VAL;
  long at = -1;
  for (std::size_t i = 0; i < pts.size() / std::size_t(dim); ++i) {
    double d2 = 0;
    for (int d = 0; d < dim; ++d) d2 += (pts[i * dim + d] - q[d]) * (pts[i * dim + d] - q[d]);
    if (d2 < best) {
      best = d2;
      at = long(i);
    }
  }
  return at;
}

// Points along a few lines (walls) and a cluster, with exact duplicates: ties must go to the
// lowest index, as the scan in order picks.
std::vector<double> cloud(int dim, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> p;
  for (int i = 0; i < 300; ++i) {
    const double t = u(rng);
    p.push_back(t);
    p.push_back(i % 3 == 0 ? 0.4 : 0.02 * u(rng));
    if (dim == 3) p.push_back(0.1 * u(rng));
  }
  for (int i = 0; i < 40; ++i)
    for (int d = 0; d < dim; ++d) p.push_back(p[std::size_t(i * 7 % 300) * dim + d]);
  return p;
}

}  // namespace

TEST(PointGrid, NearestIsTheScansNearestInsideAndOutsideTheCloud) {
  for (int dim : {2, 3}) {
    std::mt19937 rng(5 + dim);
    const std::vector<double> pts = cloud(dim, rng);
    const PointGrid grid(pts, dim);
    std::uniform_real_distribution<double> u(-3, 3);
    for (int k = 0; k < 2000; ++k) {
      double q[3] = {u(rng), u(rng), u(rng)};
      if (k % 4 == 0)  // on a point (the placement's anchors are target samples)
        for (int d = 0; d < dim; ++d) q[d] = pts[std::size_t(k % 340) * dim + d];
      double want = 0, got = 0;
      const long a = brute_nearest(pts, dim, q, want);
      const long b = grid.nearest(q, got);
      ASSERT_EQ(a, b) << "dim " << dim << " query " << k;
      ASSERT_EQ(want, got);
    }
  }
}

TEST(PointGrid, WithinFindsExactlyThePointsInTheRadius) {
  for (int dim : {2, 3}) {
    std::mt19937 rng(11 + dim);
    const std::vector<double> pts = cloud(dim, rng);
    for (double cell : {0.0, 0.05, 0.3}) {
      const PointGrid grid(pts, dim, cell);
      std::uniform_real_distribution<double> u(-1.5, 1.5);
      for (int k = 0; k < 300; ++k) {
        const double q[3] = {u(rng), u(rng), u(rng)};
        const double r = 0.02 + 0.3 * std::abs(u(rng));
        std::multiset<std::size_t> want, got;
        for (std::size_t i = 0; i < pts.size() / std::size_t(dim); ++i) {
          double d2 = 0;
          for (int d = 0; d < dim; ++d) d2 += (pts[i * dim + d] - q[d]) * (pts[i * dim + d] - q[d]);
          if (d2 <= r * r) want.insert(i);
        }
        grid.for_each_within(q, r, [&](std::size_t i, double) { got.insert(i); });
        ASSERT_EQ(want, got) << "dim " << dim << " cell " << cell << " query " << k;
        // What the wall clearance and the sample distance ask: is any point that near?
        ASSERT_EQ(grid.any_within(q, r), !want.empty()) << "dim " << dim << " query " << k;
      }
    }
  }
}

TEST(PointGrid, PairsWithinARadiusAreEachMetOnce) {
  for (int dim : {2, 3}) {
    std::mt19937 rng(17 + dim);
    const std::vector<double> pts = cloud(dim, rng);
    const std::size_t n = pts.size() / std::size_t(dim);
    for (double r : {0.04, 0.3}) {
      const PointGrid grid(pts, dim, r);
      std::multiset<std::pair<std::size_t, std::size_t>> want, got;
      for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) {
          double d2 = 0;
          for (int d = 0; d < dim; ++d)
            d2 += (pts[i * dim + d] - pts[j * dim + d]) * (pts[i * dim + d] - pts[j * dim + d]);
          if (d2 <= r * r) want.insert({i, j});
        }
      grid.for_each_pair_within(r, [&](std::size_t i, std::size_t j, double) {
        got.insert({std::min(i, j), std::max(i, j)});
      });
      ASSERT_EQ(want, got) << "dim " << dim << " r " << r;
    }
    const PointGrid coarse(pts, dim, 0.1);
    EXPECT_THROW(coarse.for_each_pair_within(0.5, [](std::size_t, std::size_t, double) {}),
                 std::invalid_argument);
  }
}

TEST(PointGrid, EmptyAndSinglePointClouds) {
  const std::vector<double> none, one = {2.0, -1.0};
  double d2 = 0;
  const double q[2] = {0, 0};
  EXPECT_EQ(PointGrid(none, 2).nearest(q, d2), -1);
  EXPECT_EQ(PointGrid(one, 2).nearest(q, d2), 0);
  EXPECT_DOUBLE_EQ(d2, 5.0);
  int calls = 0;
  PointGrid(none, 2).for_each_within(q, 10, [&](std::size_t, double) { ++calls; });
  EXPECT_EQ(calls, 0);
}
