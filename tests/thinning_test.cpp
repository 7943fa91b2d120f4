// Thinning of sector samples (host/pot/thinning.hpp) against plain versions: one point per
// occupied cell, the first in input order, whatever the table the cells are counted in.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <set>

#include "pot/thinning.hpp"

namespace potmap::detail {
namespace {

std::vector<std::size_t> plain_thin(const std::vector<double>& pts, int dim, double cell) {
  std::set<std::array<long, 3>> seen;
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < pts.size() / std::size_t(dim); ++i) {
    std::array<long, 3> c{0, 0, 0};
    for (int d = 0; d < dim; ++d) c[d] = long(std::floor(pts[i * dim + d] / cell));
    if (seen.insert(c).second) out.push_back(i);
  }
  return out;
}

// Clusters and lines at negative and positive coordinates, with exact repeats.
std::vector<double> cloud(int dim, std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-30, 30), v(-0.5, 0.5);
  std::vector<double> pts;
  for (std::size_t i = 0; i < n; ++i) {
    const double base = i % 3 == 0 ? u(rng) : 0.2 * double(i % 50);
    for (int d = 0; d < dim; ++d) pts.push_back(d == 0 ? base : u(rng) * (i % 2) + v(rng));
    if (i % 7 == 0) {
      const std::size_t from = pts.size() - std::size_t(dim);
      for (int d = 0; d < dim; ++d) pts.push_back(pts[from + std::size_t(d)]);
      ++i;
    }
  }
  return pts;
}

TEST(Thinning, ToCellsKeepsTheFirstPointOfEveryCell) {
  for (int dim : {2, 3})
    for (double cell : {0.05, 0.25, 1.0, 7.5})
      for (std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(9), std::size_t(3000)}) {
        const std::vector<double> pts = cloud(dim, n, unsigned(n) + 3);
        EXPECT_EQ(thin_to_cells(pts, dim, cell), plain_thin(pts, dim, cell))
            << dim << "D, cell " << cell << ", " << n << " points";
      }
}

}  // namespace
}  // namespace potmap::detail
