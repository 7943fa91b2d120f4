// The instantaneous map of a scan's anchors (detail::anchors_to_map, host/pot/
// placement_at_samples.cpp) against a plain sum over every pair: its anchors are binned and
// each pair met once, and the weights must be those of the plain partition.
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

}  // namespace
}  // namespace potmap::detail
