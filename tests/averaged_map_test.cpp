// The averaged overall map (include/potmap/pot/averaged_map.hpp): what a place reads is the
// support-weighted average of the scans that saw it, never their sum.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/pot/averaged_map.hpp"

namespace potmap {
namespace {

constexpr double kGamma = 6.64;  // the experiments' BHM atoms' width at 0.5 m spacing

// A scan's instantaneous map as POT builds it: a wall of kernels along y = 0 (logit `wall`)
// and free space below it (logit `free`), kernels 0.5 m apart, weights normalised so that
// each class reproduces its logit (the partition of kernels at samples).
KernelMap room(double wall, double free, double x0 = 0, double x1 = 6) {
  KernelMap m;
  const double sum = 1.383;  // sum of phi of a 0.5 m line of kernels at one of them
  for (double x = x0; x <= x1 + 1e-9; x += 0.5) {
    const double p[2] = {x, 0};
    m.push_back(p, kGamma, wall / sum, 0.5);
    for (double y = -0.75; y >= -4; y -= 0.5) {
      const double q[2] = {x, y};
      m.push_back(q, kGamma, free / 1.91, 0.2);  // 1.91: a 0.5 m grid's sum of phi
    }
  }
  return m;
}

double logit_at(const KernelMap& m, double x, double y) {
  const double p[2] = {x, y};
  return evaluate_exact(m, p, 1).mean[0];
}

TEST(AveragedMap, ReproducesOneScanWhereItSawThePlace) {
  const KernelMap inst = room(2.0, -4.0);
  AveragedMap avg(2);
  avg.add(inst);
  ASSERT_GT(avg.size(), 100u);
  // Inside the room (away from its edges) the solved map reads what the scan reads.
  for (double x = 1.5; x <= 4.5; x += 0.25) {
    EXPECT_NEAR(logit_at(avg.map(), x, 0.0), logit_at(inst, x, 0.0), 0.5) << x;
    EXPECT_NEAR(logit_at(avg.map(), x, -2.5), logit_at(inst, x, -2.5), 0.5) << x;
  }
  // Far from every kernel it says nothing.
  EXPECT_NEAR(logit_at(avg.map(), 3.0, 8.0), 0.0, 1e-6);
}

TEST(AveragedMap, ThePlaceSeenTwiceReadsTheSameNotDouble) {
  const KernelMap inst = room(2.0, -4.0);
  AveragedMap once(2), twice(2);
  once.add(inst);
  twice.add(inst);
  twice.add(inst);
  EXPECT_EQ(twice.size(), once.size());  // memory follows the area seen, not the scans
  for (double x = 1.5; x <= 4.5; x += 0.5) {
    // The second add only continues the weights' solve (about a tenth closer to the average
    // here); the average itself is unchanged.
    for (double y : {0.0, -2.5}) {
      const double a = logit_at(once.map(), x, y), b = logit_at(twice.map(), x, y);
      EXPECT_NEAR(b, a, 0.15 * std::abs(a)) << x << " " << y;
    }
  }
  // Kernels summed would double the wall.
  KernelMap summed = inst;
  for (std::size_t k = 0; k < summed.size(); ++k) summed.w_mean[k] *= 2;
  EXPECT_GT(logit_at(summed, 3.0, 0.0), 1.6 * logit_at(twice.map(), 3.0, 0.0));
  for (int i = 0; i < 20; ++i) twice.add(inst);
  EXPECT_EQ(twice.size(), once.size());
}

// Two scans that disagree about a place: it reads their support-weighted mean (here equal
// supports: the plain mean), where kernels summed would read their sum.
TEST(AveragedMap, DisagreeingScansReadTheirMean) {
  auto field = [](double logit, double offset) {
    KernelMap m;
    for (double x = offset; x <= 5 + 1e-9; x += 0.5)
      for (double y = offset; y <= 5 + 1e-9; y += 0.5) {
        const double q[2] = {x, y};
        m.push_back(q, kGamma, logit / 1.91, 0.2);
      }
    return m;
  };
  const KernelMap a = field(3.0, 0.0), b = field(-1.0, 0.25);
  AveragedMap avg(2);
  avg.add(a);
  avg.add(b);
  for (double x = 1.5; x <= 3.5; x += 0.25) {
    const double va = logit_at(a, x, 2.5), vb = logit_at(b, x, 2.5);
    EXPECT_NEAR(va, 3.0, 0.1);
    EXPECT_NEAR(vb, -1.0, 0.1);
    EXPECT_NEAR(logit_at(avg.map(), x, 2.5), 0.5 * (va + vb), 0.15) << x;
  }
}

TEST(AveragedMap, FreeSpaceAloneGivesNoOccupiedRing) {
  // Weights keep their average's sign: around free space seen alone nothing reads occupied.
  KernelMap m;
  for (double x = 0; x <= 4 + 1e-9; x += 0.5)
    for (double y = 0; y <= 4 + 1e-9; y += 0.5) {
      const double q[2] = {x, y};
      m.push_back(q, kGamma, -6.0 / 1.91, 0.2);
    }
  AveragedMap avg(2);
  avg.add(m);
  for (std::size_t k = 0; k < avg.size(); ++k) EXPECT_LE(avg.map().w_mean[k], 0.0) << k;
  for (double x = -2; x <= 6; x += 0.1)
    for (double y = -2; y <= 6; y += 0.5) EXPECT_LE(logit_at(avg.map(), x, y), 1e-12);
}

TEST(AveragedMap, RejectsBadOptionsAndOtherDimensions) {
  AveragedMapOptions o;
  o.spacing = 0;
  EXPECT_THROW(AveragedMap(2, o), ArgumentError);
  o = {};
  o.min_support = 0;
  EXPECT_THROW(AveragedMap(2, o), ArgumentError);
  o = {};
  o.ridge = -1;
  EXPECT_THROW(AveragedMap(2, o), ArgumentError);
  EXPECT_THROW(AveragedMap(4), ArgumentError);
  AveragedMap avg(3);
  EXPECT_THROW(avg.add(room(1, -1)), ArgumentError);
  KernelMap bad = room(1, -1);
  bad.gamma[0] = -1;
  AveragedMap two(2);
  EXPECT_THROW(two.add(bad), ArgumentError);
  two.add(KernelMap{});  // an empty scan changes nothing
  EXPECT_EQ(two.size(), 0u);
}

TEST(AveragedMap, ThreeDimensionsToo) {
  KernelMap m;
  m.dim = 3;
  for (double x = 0; x <= 3 + 1e-9; x += 0.5)
    for (double y = 0; y <= 3 + 1e-9; y += 0.5) {
      const double q[3] = {x, y, 0.0};
      m.push_back(q, kGamma, x < 1.6 ? -0.5 : 0.5, 0.2);
    }
  AveragedMap avg(3);
  avg.add(m);
  ASSERT_GT(avg.size(), 50u);
  const double lo[3] = {0.5, 1.5, 0}, hi[3] = {2.5, 1.5, 0};
  const auto v = evaluate_exact(avg.map(), lo, 1).mean[0];
  const auto w = evaluate_exact(avg.map(), hi, 1).mean[0];
  EXPECT_LT(v, -0.3);
  EXPECT_GT(w, 0.3);
}

// The anchors are found through blocks of cells (32 x 32 in 2D, 16^3 in 3D): a map moved by a
// whole number of cells, across block edges and to negative coordinates, must solve to the
// same weights at the moved anchors, each cell holding one anchor. Several overlapping scans,
// so that later ones find the anchors of earlier ones through the blocks.
void expect_moved_map_is_the_same(int dim, const double shift[3]) {
  const double h = AveragedMapOptions{}.spacing;
  auto scan = [&](double x0, double y0, const double* by) {
    KernelMap m;
    m.dim = dim;
    for (double x = 0; x <= 9 + 1e-9; x += 0.5)
      for (double y = 0; y <= 4 + 1e-9; y += 0.5)
        for (double z = 0; z <= (dim == 3 ? 1.0 : 0.0) + 1e-9; z += 0.5) {
          const double q[3] = {x0 + x + by[0], y0 + y + by[1], z + by[2]};
          m.push_back(q, kGamma, y < 0.6 ? 1.2 : -0.8, 0.3);
        }
    return m;
  };
  const double none[3] = {0, 0, 0};
  AveragedMap here(dim), there(dim);
  for (int i = 0; i < 4; ++i) {
    here.add(scan(2.5 * i, 1.5 * i, none));
    there.add(scan(2.5 * i, 1.5 * i, shift));
  }
  ASSERT_EQ(here.size(), there.size());
  ASSERT_GT(here.size(), 500u);
  std::set<std::array<long, 3>> cells;
  for (std::size_t k = 0; k < here.size(); ++k) {
    std::array<long, 3> c{0, 0, 0};
    for (int d = 0; d < dim; ++d) {
      const double p = here.map().position[k * dim + d], q = there.map().position[k * dim + d];
      ASSERT_NEAR(q - p, shift[d], 1e-9) << "anchor " << k;
      c[d] = std::lround(std::floor(q / h));
    }
    EXPECT_TRUE(cells.insert(c).second) << "two anchors in one cell at anchor " << k;
    EXPECT_NEAR(there.map().w_mean[k], here.map().w_mean[k], 1e-9) << "anchor " << k;
    EXPECT_NEAR(there.map().w_var[k], here.map().w_var[k], 1e-9) << "anchor " << k;
  }
}

TEST(AveragedMap, AMapMovedAcrossBlocksSolvesTheSame) {
  const double h = AveragedMapOptions{}.spacing;
  const double by2[3] = {-37 * h, -45 * h, 0};
  expect_moved_map_is_the_same(2, by2);
  const double by2b[3] = {61 * h, -203 * h, 0};
  expect_moved_map_is_the_same(2, by2b);
  const double by3[3] = {-21 * h, 13 * h, -9 * h};
  expect_moved_map_is_the_same(3, by3);
}

// The first scan's solve written plainly: every cell's sums by one exp per kernel and cell,
// every neighbour by its distance, the Gauss-Seidel sweeps in cell order (z, then y, then x).
// AveragedMap sums along runs, pairs mirrored neighbours and walks Gaussian factors by
// recurrence; each is exact in arithmetic, so the two agree to rounding.
KernelMap plain_first_scan(const KernelMap& inst, const AveragedMapOptions& o) {
  const int dim = inst.dim;
  const double h = o.spacing;
  const double gmin = *std::min_element(inst.gamma.begin(), inst.gamma.end());
  const long reach = long(std::ceil(std::sqrt(16.0 / gmin) / h));
  struct Cell {
    double m = 0, v = 0, sup = 0, sg = 0;
  };
  std::map<std::array<long, 3>, Cell> cells;  // ordered by z, y, x as the box is
  for (std::size_t k = 0; k < inst.size(); ++k) {
    long c0[3] = {0, 0, 0};
    for (int a = 0; a < dim; ++a) c0[a] = long(std::floor(inst.position[k * dim + a] / h));
    for (long dz = dim == 3 ? -reach : 0; dz <= (dim == 3 ? reach : 0); ++dz)
      for (long dy = -reach; dy <= reach; ++dy)
        for (long dx = -reach; dx <= reach; ++dx) {
          const long c[3] = {c0[0] + dx, c0[1] + dy, c0[2] + dz};
          double r2 = 0;
          for (int a = 0; a < dim; ++a) {
            const double t = (c[a] + 0.5) * h - inst.position[k * dim + a];
            r2 += t * t;
          }
          if (inst.gamma[k] * r2 > 16.0) continue;
          const double phi = std::exp(-inst.gamma[k] * r2);
          Cell& cell = cells[{c[2], c[1], c[0]}];
          cell.m += inst.w_mean[k] * phi;
          cell.v += inst.w_var[k] * phi * phi;
          cell.sup += phi;
          cell.sg += inst.gamma[k] * phi;
        }
  }
  KernelMap out;
  out.dim = dim;
  std::vector<std::array<long, 3>> at;  // each anchor's cell (z, y, x)
  std::vector<double> average;
  for (const auto& [c, cell] : cells) {
    if (cell.sup < o.min_support) continue;
    const double x[3] = {(c[2] + 0.5) * h, (c[1] + 0.5) * h, (c[0] + 0.5) * h};
    // The scan's logit and variance at the cell are its average there (support-weighted over
    // one scan).
    out.push_back(x, cell.sg / cell.sup, 0.0, cell.v);
    at.push_back(c);
    average.push_back(cell.m);
  }
  const long ws = std::min(reach, long(std::floor(std::sqrt(9.0 / (gmin * h * h)))));
  const std::size_t n = at.size();
  std::vector<std::vector<std::pair<std::size_t, long>>> near(n);  // (anchor, squared cells)
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = 0; b < n; ++b) {
      long q = 0;
      for (int i = 0; i < 3; ++i) q += (at[a][i] - at[b][i]) * (at[a][i] - at[b][i]);
      if (b != a && q <= ws * ws) near[a].push_back({b, q});
    }
  auto gram = [&](std::size_t a, long q) { return std::exp(-out.gamma[a] * h * h * double(q)); };
  for (std::size_t a = 0; a < n; ++a) {
    double part = 1, part2 = 1;
    for (const auto& [b, q] : near[a]) {
      part += gram(a, q);
      part2 += gram(a, q) * gram(a, q);
    }
    out.w_mean[a] = average[a] / part;
    out.w_var[a] /= part2;
  }
  for (int sweep = 0; sweep < o.sweeps; ++sweep)
    for (std::size_t a = 0; a < n; ++a) {
      double r = average[a];
      for (const auto& [b, q] : near[a]) r -= gram(a, q) * out.w_mean[b];
      const double w = r / (1.0 + o.ridge);
      out.w_mean[a] = average[a] >= 0 ? std::max(w, 0.0) : std::min(w, 0.0);
    }
  return out;
}

TEST(AveragedMap, OneScanSolvesAsThePlainSolve) {
  for (int dim : {2, 3}) {
    // Scattered kernels of three widths and both signs, at negative and positive coordinates.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-2.5, 2.5), w(-2, 2);
    KernelMap inst;
    inst.dim = dim;
    for (int k = 0; k < (dim == 3 ? 120 : 200); ++k) {
      const double p[3] = {u(rng), u(rng), 0.4 * u(rng)};
      inst.push_back(p, kGamma * (1 + 0.25 * (k % 3)), w(rng), 0.2 + 0.1 * (k % 4));
    }
    AveragedMap avg(dim);
    avg.add(inst);
    const KernelMap want = plain_first_scan(inst, avg.options());
    ASSERT_EQ(avg.size(), want.size()) << dim << "D";
    ASSERT_GT(avg.size(), 300u);
    for (std::size_t k = 0; k < want.size(); ++k) {
      for (int a = 0; a < dim; ++a)
        ASSERT_NEAR(avg.map().position[k * dim + a], want.position[k * dim + a], 1e-12) << k;
      EXPECT_NEAR(avg.map().gamma[k], want.gamma[k], 1e-12 * want.gamma[k]) << dim << "D " << k;
      EXPECT_NEAR(avg.map().w_mean[k], want.w_mean[k], 1e-9) << dim << "D anchor " << k;
      EXPECT_NEAR(avg.map().w_var[k], want.w_var[k], 1e-9) << dim << "D anchor " << k;
    }
  }
}

}  // namespace
}  // namespace potmap
