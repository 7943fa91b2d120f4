// The instantaneous map of a scan's anchors (detail::anchors_to_map, host/pot/
// placement_at_samples.cpp) against a plain sum over every pair: its anchors are binned and
// each pair met once, and the weights must be those of the plain partition, or with sweeps,
// those of the same projected Gauss-Seidel sweeps over every pair.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "pot/placement_at_samples.hpp"

namespace potmap::detail {
namespace {

// Each anchor's weight and variance divided by its class's partition, summed over all pairs.
KernelMap plain_partition(const std::vector<Anchor>& anchors, int dim) {
  double gmin = HUGE_VAL;
  for (const Anchor& a : anchors) gmin = std::min(gmin, a.gamma);
  KernelMap out;
  out.dim = dim;
  for (const Anchor& a : anchors) {
    double sum = 0, sum2 = 0;
    for (const Anchor& b : anchors) {
      if (b.hit != a.hit) continue;
      double d2 = 0;
      for (int d = 0; d < dim; ++d)
        d2 += (a.position[d] - b.position[d]) * (a.position[d] - b.position[d]);
      if (gmin * d2 > 16 || b.gamma * d2 > 16) continue;
      const double phi = std::exp(-b.gamma * d2);
      sum += phi;
      sum2 += phi * phi;
    }
    out.push_back(a.position.data(), a.gamma, a.value / sum, a.variance / sum2);
  }
  return out;
}

void expect_plain_partition(const std::vector<Anchor>& anchors, int dim, const char* what) {
  KernelMap got;
  got.dim = dim;
  anchors_to_map(anchors, dim, got);
  const KernelMap want = plain_partition(anchors, dim);
  ASSERT_EQ(got.size(), want.size()) << what;
  for (std::size_t k = 0; k < want.size(); ++k) {
    for (int d = 0; d < dim; ++d)
      ASSERT_EQ(got.position[k * dim + d], want.position[k * dim + d]) << what << " " << k;
    EXPECT_EQ(got.gamma[k], want.gamma[k]) << what << " " << k;
    EXPECT_NEAR(got.w_mean[k], want.w_mean[k], 1e-12 * std::abs(want.w_mean[k]))
        << what << " " << k;
    EXPECT_NEAR(got.w_var[k], want.w_var[k], 1e-12 * want.w_var[k]) << what << " " << k;
  }
}

// Anchors of both classes, two widths (two sectors' atoms), 0.25 to 0.5 m apart as thinned
// samples are, in a square room or along one long wall.
std::vector<Anchor> anchors(int dim, bool along_a_line, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-6, 6), v(-1, 1);
  std::vector<Anchor> out;
  for (int k = 0; k < 900; ++k) {
    Anchor a;
    a.position = {along_a_line ? 8 * u(rng) : u(rng), along_a_line ? 0.01 * v(rng) : u(rng),
                  dim == 3 ? 1.5 * v(rng) : 0.0};
    a.gamma = k % 2 ? 6.643 : 4.2;
    a.hit = k % 3 == 0;
    a.value = a.hit ? 2 + v(rng) : -2 + v(rng);
    a.variance = 0.3 + 0.1 * v(rng);
    out.push_back(a);
  }
  return out;
}

TEST(AnchorsToMap, WeightsAreThoseOfThePlainPartition) {
  for (int dim : {2, 3}) {
    expect_plain_partition(anchors(dim, false, 5), dim, dim == 2 ? "2D room" : "3D room");
    expect_plain_partition(anchors(dim, true, 6), dim, dim == 2 ? "2D wall" : "3D wall");
  }
  std::vector<Anchor> one(1);
  one[0].gamma = 6.643;
  one[0].value = 1.5;
  one[0].variance = 0.2;
  expect_plain_partition(one, 2, "one anchor");
}

// The solve's reference: `sweeps` projected Gauss-Seidel sweeps over every pair (phi_j(x_i)
// where gamma_j d^2 <= 16), from the plain partition's weights times `gain`.
std::vector<double> plain_solve(const std::vector<Anchor>& anchors, int dim, int sweeps,
                                double gain) {
  const KernelMap start = plain_partition(anchors, dim);
  std::vector<double> w(anchors.size());
  for (std::size_t i = 0; i < w.size(); ++i) w[i] = gain * start.w_mean[i];
  for (int t = 0; t < sweeps; ++t)
    for (std::size_t i = 0; i < anchors.size(); ++i) {
      const double v = gain * anchors[i].value;
      double r = v;
      for (std::size_t j = 0; j < anchors.size(); ++j) {
        if (j == i) continue;
        double d2 = 0;
        for (int d = 0; d < dim; ++d)
          d2 += (anchors[i].position[d] - anchors[j].position[d]) *
                (anchors[i].position[d] - anchors[j].position[d]);
        if (anchors[j].gamma * d2 <= 16) r -= std::exp(-anchors[j].gamma * d2) * w[j];
      }
      w[i] = v >= 0 ? std::max(r, 0.0) : std::min(r, 0.0);
    }
  return w;
}

TEST(AnchorsToMap, SolvedWeightsAreThoseOfTheSweepsOverEveryPair) {
  for (int dim : {2, 3}) {
    const std::vector<Anchor> room = anchors(dim, false, 7);
    KernelMap got;
    got.dim = dim;
    anchors_to_map(room, dim, got, 6, 1.5);
    const std::vector<double> want = plain_solve(room, dim, 6, 1.5);
    const KernelMap partition = plain_partition(room, dim);
    ASSERT_EQ(got.size(), want.size());
    double moved = 0;
    for (std::size_t k = 0; k < want.size(); ++k) {
      EXPECT_NEAR(got.w_mean[k], want[k], 1e-9 * (1 + std::abs(want[k]))) << dim << "D " << k;
      // The variances stay the partition's.
      EXPECT_NEAR(got.w_var[k], partition.w_var[k], 1e-12 * partition.w_var[k]) << k;
      moved += std::abs(want[k] - 1.5 * partition.w_mean[k]);
    }
    EXPECT_GT(moved, 1e-3 * double(want.size())) << "the sweeps changed no weight";
  }
}

// A straight wall with free anchors from a quarter metre off it: each class's partition alone
// blurs the wall and the free space beside it into each other; the solved map reads the wall's
// value on the wall and the free anchors' beside it (away from the wall's ends).
TEST(AnchorsToMap, TheSolvedMapReadsTheWallAndTheFreeSpaceBesideIt) {
  std::vector<Anchor> wall;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 4; ++j) {
      Anchor a;
      a.position = {0.5 * i, j == 0 ? 0.0 : 0.5 * j - 0.25, 0.0};
      a.gamma = 4.2;
      a.hit = j == 0;
      a.value = a.hit ? 2.5 : -2.0;
      a.variance = 0.2;
      wall.push_back(a);
    }
  // The map's mean at each of the middle anchors of the wall and of the free row nearest it.
  auto readings = [&](int sweeps, double y) {
    KernelMap m;
    m.dim = 2;
    anchors_to_map(wall, 2, m, sweeps, 1.0);
    std::vector<double> out;
    for (const Anchor& a : wall) {
      if (a.position[1] != y || a.position[0] < 3 || a.position[0] > 7) continue;
      double mean = 0;
      for (std::size_t k = 0; k < m.size(); ++k) {
        const double dx = a.position[0] - m.position[2 * k];
        const double dy = a.position[1] - m.position[2 * k + 1];
        mean += m.w_mean[k] * std::exp(-m.gamma[k] * (dx * dx + dy * dy));
      }
      out.push_back(mean);
    }
    return out;
  };
  for (double on_wall : readings(0, 0.0)) EXPECT_LT(on_wall, 1.5);
  for (double beside : readings(0, 0.25)) EXPECT_GT(beside, 0.0);
  for (double on_wall : readings(30, 0.0)) EXPECT_NEAR(on_wall, 2.5, 0.05);
  for (double beside : readings(30, 0.25)) EXPECT_NEAR(beside, -2.0, 0.05);
}

}  // namespace
}  // namespace potmap::detail
