// Samples gathered per voxel (aggregate_voxels): one weighted sample per scan, label and voxel,
// at the weighted mean of its samples, every sample's weight accounted for.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <tuple>

#include "potmap/data/labelling.hpp"
#include "potmap/error.hpp"

using namespace potmap;

namespace {

LabelledPoints random_samples(int dim, std::size_t n, unsigned seed, bool weighted) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-3, 3);
  LabelledPoints s;
  s.dim = dim;
  for (std::size_t i = 0; i < n; ++i) {
    for (int d = 0; d < dim; ++d) s.position.push_back(u(rng));
    s.label.push_back(rng() % 3 == 0);
    s.scan.push_back(std::int64_t(rng() % 2));
    if (weighted) s.weight.push_back(0.5 + (rng() % 4));
  }
  return s;
}

}  // namespace

TEST(VoxelSamples, OneWeightedSampleAtTheMeanOfEachVoxel) {
  for (int dim : {2, 3})
    for (bool weighted : {false, true}) {
      SCOPED_TRACE(dim * 10 + weighted);
      const double v = 0.5;
      const LabelledPoints s = random_samples(dim, 4000, 11 + dim, weighted);
      const LabelledPoints g = aggregate_voxels(s, v);
      // The reference: sums per (scan, label, voxel) in a map.
      using Key = std::tuple<std::int64_t, int, long, long, long>;
      std::map<Key, std::array<double, 4>> ref;
      auto key_of = [&](const LabelledPoints& p, std::size_t i) {
        long c[3] = {0, 0, 0};
        for (int d = 0; d < dim; ++d) c[d] = long(std::floor(p.position[i * dim + d] / v));
        return Key{p.scan[i], p.label[i], c[0], c[1], c[2]};
      };
      for (std::size_t i = 0; i < s.size(); ++i) {
        const double w = weighted ? s.weight[i] : 1.0;
        auto& r = ref[key_of(s, i)];
        for (int d = 0; d < dim; ++d) r[d] += w * s.position[i * dim + d];
        r[3] += w;
      }
      ASSERT_EQ(g.size(), ref.size());
      ASSERT_EQ(g.weight.size(), g.size());
      ASSERT_LT(g.size(), s.size());  // 4000 samples over fewer voxels
      for (std::size_t i = 0; i < g.size(); ++i) {
        const auto it = ref.find(key_of(g, i));
        ASSERT_NE(it, ref.end());
        EXPECT_NEAR(g.weight[i], it->second[3], 1e-9);
        for (int d = 0; d < dim; ++d)
          EXPECT_NEAR(g.position[i * dim + d], it->second[d] / it->second[3], 1e-9);
      }
    }
}

TEST(VoxelSamples, SamplesFarFromTheOriginKeepTheirOwn) {
  LabelledPoints s;
  s.dim = 2;
  s.position = {1e9, 0, 1e9, 0, 0.1, 0.1, 0.2, 0.2};
  s.label = {0, 0, 1, 1};
  const LabelledPoints g = aggregate_voxels(s, 0.5);
  ASSERT_EQ(g.size(), 3u);  // the two hits share a voxel; the far samples stay apart
  double total = 0;
  for (double w : g.weight) total += w;
  EXPECT_DOUBLE_EQ(total, 4.0);
}

TEST(VoxelSamples, RefusesBadInput) {
  LabelledPoints s = random_samples(2, 10, 1, false);
  EXPECT_THROW(aggregate_voxels(s, 0), ArgumentError);
  EXPECT_THROW(aggregate_voxels(s, std::nan("")), ArgumentError);
  s.weight.assign(3, 1.0);
  EXPECT_THROW(aggregate_voxels(s, 0.5), ArgumentError);
}
