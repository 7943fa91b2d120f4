#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "potmap/error.hpp"
#include "potmap/pot/atom_descriptor.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

Sector random_sector(std::mt19937_64& rng, int dim, std::size_t nh, std::size_t nf) {
  std::normal_distribution<double> g(0, 0.1);
  Sector s;
  s.dim = dim;
  // An elongated blob: the radius distribution depends on the shape, not on its orientation.
  const double sx = std::exp(g(rng) * 5), sy = std::exp(g(rng) * 5);
  for (std::size_t i = 0; i < nh; ++i) {
    s.hits.push_back(sx * g(rng));
    s.hits.push_back(sy * g(rng));
    if (dim == 3) s.hits.push_back(g(rng));
  }
  for (std::size_t i = 0; i < nf; ++i) {
    s.free.push_back(0.2 + g(rng));
    s.free.push_back(g(rng) * sx);
    if (dim == 3) s.free.push_back(g(rng));
  }
  return s;
}

Dictionary dictionary_of(std::vector<Sector> sectors, int dim) {
  Dictionary d;
  d.dim = dim;
  for (auto& s : sectors) {
    Atom a;
    a.sector = std::move(s);
    a.kernels.dim = dim;
    d.atoms.push_back(std::move(a));
  }
  return d;
}

// Exact W2^2 between two equal-size point sets with uniform weights, over every rotation in
// `angles` (brute force over permutations: the OT plan of equal uniform sets is a permutation).
double exact_w2_rotated(const std::vector<double>& a, const std::vector<double>& b, int n) {
  double best = HUGE_VAL;
  for (int step = 0; step < 72; ++step) {
    const double t = step * M_PI / 36, c = std::cos(t), s = std::sin(t);
    std::vector<int> p(n);
    std::iota(p.begin(), p.end(), 0);
    do {
      double cost = 0;
      for (int i = 0; i < n; ++i) {
        const double x = c * b[2 * p[i]] - s * b[2 * p[i] + 1];
        const double y = s * b[2 * p[i]] + c * b[2 * p[i] + 1];
        cost += std::pow(a[2 * i] - x, 2) + std::pow(a[2 * i + 1] - y, 2);
      }
      best = std::min(best, cost / n);
    } while (std::next_permutation(p.begin(), p.end()));
  }
  return best;
}

}  // namespace

TEST(AtomDescriptor, RotationLeavesTheDescriptorUnchanged) {
  std::mt19937_64 rng(1);
  for (int dim : {2, 3}) {
    const Sector s = random_sector(rng, dim, 150, 40);
    const AtomDescriptor d = describe_sector(s);
    for (double a : {0.3, 1.7, 3.1, 5.0}) {
      const AtomDescriptor r = describe_sector(test::rotated_sector(s, a));
      EXPECT_EQ(r.hits, d.hits);
      for (int i = 0; i < AtomDescriptor::kQuantiles; ++i) {
        EXPECT_NEAR(r.hit_radius[i], d.hit_radius[i], 1e-6);
        EXPECT_NEAR(r.free_radius[i], d.free_radius[i], 1e-6);
        EXPECT_EQ(r.hit_z[i], d.hit_z[i]);
      }
      EXPECT_LT(descriptor_distance(d, r, true), 1e-10);
    }
  }
}

TEST(AtomDescriptor, DistanceIsALowerBoundOnTheRotatedOtCost) {
  std::mt19937_64 rng(2);
  const int n = 8;  // 16 quantile levels hit each of 8 sorted radii twice: exact 1D W2
  for (int trial = 0; trial < 4; ++trial) {
    const Sector a = random_sector(rng, 2, n, 0), b = random_sector(rng, 2, n, 0);
    const double lower = descriptor_distance(describe_sector(a), describe_sector(b), true);
    const double exact = exact_w2_rotated(a.hits, b.hits, n);
    EXPECT_LE(lower, exact * (1 + 1e-5) + 1e-12) << trial;
    EXPECT_GT(lower, 0);
  }
}

TEST(AtomDescriptor, RotatedCopyIsPreselectedFirst) {
  std::mt19937_64 rng(3);
  std::vector<Sector> atoms;
  for (int i = 0; i < 200; ++i) atoms.push_back(random_sector(rng, 2, 60 + i % 50, 10 + i % 20));
  const Sector target = test::rotated_sector(atoms[137], 2.2);
  const Dictionary dict = dictionary_of(atoms, 2);
  const auto top = preselect_atoms(dict, target, 5);
  ASSERT_EQ(top.size(), 5u);
  EXPECT_EQ(top[0], 137u);
  // The same order as the full ranking's head; k = 0 ranks everything.
  const AtomPreselector pre(dict);
  const auto all = pre.select(target, 0);
  ASSERT_EQ(all.size(), 200u);
  EXPECT_TRUE(std::equal(top.begin(), top.end(), all.begin()));
  std::vector<std::size_t> sorted = all;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i) EXPECT_EQ(sorted[i], i);
}

TEST(AtomDescriptor, AtomsLackingAClassTheTargetHasComeLast) {
  std::mt19937_64 rng(4);
  std::vector<Sector> atoms;
  atoms.push_back(random_sector(rng, 2, 50, 0));   // no free samples
  atoms.push_back(random_sector(rng, 2, 0, 30));   // no hits
  atoms.push_back(random_sector(rng, 2, 50, 30));  // both
  atoms.push_back(random_sector(rng, 2, 40, 20));  // both
  const Dictionary dict = dictionary_of(atoms, 2);
  const auto order = preselect_atoms(dict, random_sector(rng, 2, 50, 30), 0);
  EXPECT_TRUE((order[0] == 2 && order[1] == 3) || (order[0] == 3 && order[1] == 2));
  // A hits-only target ignores the free samples: the free-only atom is last.
  EXPECT_EQ(preselect_atoms(dict, random_sector(rng, 2, 50, 0), 0).back(), 1u);
  EXPECT_THROW(preselect_atoms(dict, random_sector(rng, 3, 5, 5), 1), ArgumentError);
}
