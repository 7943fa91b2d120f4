// Thinning of sector samples (see thinning.hpp).
#include "thinning.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "cell_key.hpp"
#include "data/sim_rng.hpp"

namespace potmap::detail {

std::uint64_t mix(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  data::SimRng r{a * 0x9e3779b97f4a7c15ULL ^ (b + 0x632be59bd9b4e019ULL) * 0xbf58476d1ce4e5b9ULL ^
                 c * 0x94d049bb133111ebULL};
  return r.next();
}

std::vector<std::size_t> thin_to_cells(const std::vector<double>& pts, int dim, double cell) {
  // The cells seen, in an open-addressing table (a node-based set allocated once per point,
  // and the placement thins every sector's samples every scan). pack_cell leaves the top bit
  // clear, so a key with it set is never 0, the empty slot.
  const std::size_t n = pts.size() / std::size_t(dim);
  int bits = 4;
  while ((std::size_t(1) << bits) < 2 * n) ++bits;
  std::vector<std::uint64_t> table(std::size_t(1) << bits, 0);
  const std::size_t mask = table.size() - 1;
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < n; ++i) {
    std::int64_t c[3] = {0, 0, 0};
    for (int d = 0; d < dim; ++d)
      c[d] = static_cast<std::int64_t>(std::floor(pts[i * dim + d] / cell));
    const std::uint64_t key = pack_cell(c) | (std::uint64_t(1) << 63);
    std::size_t h = std::size_t((key * 0x9e3779b97f4a7c15ULL) >> (64 - bits));
    while (table[h] != 0 && table[h] != key) h = (h + 1) & mask;
    if (table[h] == 0) {
      table[h] = key;
      out.push_back(i);
    }
  }
  return out;
}

Eigen::MatrixXd subsample(const std::vector<double>& pts, int dim, std::size_t cap,
                          std::uint64_t seed) {
  const std::size_t n = pts.size() / dim;
  const std::size_t k = std::min(n, cap);
  std::vector<std::size_t> idx(n);
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  if (k < n) {
    data::SimRng rng{seed};
    for (std::size_t i = 0; i < k; ++i) std::swap(idx[i], idx[i + rng.below(n - i)]);
    std::sort(idx.begin(), idx.begin() + k);
  }
  Eigen::MatrixXd out(k, dim);
  for (std::size_t i = 0; i < k; ++i)
    for (int d = 0; d < dim; ++d) out(i, d) = pts[idx[i] * dim + d];
  return out;
}

// The cell size is found by bisection (docs/pot-measurements.md: what even thinning did to the
// transport's convergence and the maps).
std::vector<std::size_t> even_indices(const std::vector<double>& pts, int dim, std::size_t cap) {
  const std::size_t n = pts.size() / dim;
  std::vector<std::size_t> keep;
  if (n > cap) {
    double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    for (int d = 0; d < dim; ++d) lo[d] = hi[d] = pts[d];
    for (std::size_t i = 0; i < n; ++i)
      for (int d = 0; d < dim; ++d) {
        lo[d] = std::min(lo[d], pts[i * dim + d]);
        hi[d] = std::max(hi[d], pts[i * dim + d]);
      }
    double extent = 0;
    for (int d = 0; d < dim; ++d) extent = std::max(extent, hi[d] - lo[d]);
    // Occupied cells (and the first point of each, in input order) for a cell size, counted in
    // an open-addressing table: this runs a dozen times per call, twice per sector and scan.
    std::size_t slots = 1;
    while (slots < 2 * n) slots <<= 1;
    std::vector<std::uint64_t> table(slots);
    // Stops counting past `stop` cells: the bisection only asks whether a size leaves more
    // than the cap.
    auto cells = [&](double cell, std::vector<std::size_t>* firsts, std::size_t stop) {
      std::fill(table.begin(), table.end(), 0);
      std::size_t count = 0;
      for (std::size_t i = 0; i < n && count <= stop; ++i) {
        std::uint64_t key = 1;  // 0 marks an empty slot
        for (int d = 0; d < dim; ++d)
          key = (key << 21) | static_cast<std::uint64_t>((pts[i * dim + d] - lo[d]) / cell);
        std::size_t h = static_cast<std::size_t>((key * 0x9e3779b97f4a7c15ULL) >> 20) & (slots - 1);
        while (table[h] != 0 && table[h] != key) h = (h + 1) & (slots - 1);
        if (table[h] == 0) {
          table[h] = key;
          ++count;
          if (firsts) firsts->push_back(i);
        }
      }
      return count;
    };
    // Cells of extent / 2^20 keep every distinct point apart; a cell of the whole extent holds
    // them all. Bisect the cell size between the two on a log scale.
    double small = extent / (1 << 20), large = extent * 1.0001;
    if (extent > 0) {
      for (int round = 0; round < 24 && large / small > 1.03; ++round) {
        const double mid = std::sqrt(small * large);
        (cells(mid, nullptr, cap) > cap ? small : large) = mid;
      }
      cells(large, &keep, n);
    } else {
      keep.push_back(0);  // every point at the same place
    }
  } else {
    keep.resize(n);
    std::iota(keep.begin(), keep.end(), std::size_t{0});
  }
  return keep;
}

Eigen::MatrixXd subsample_even(const std::vector<double>& pts, int dim, std::size_t cap) {
  const std::vector<std::size_t> keep = even_indices(pts, dim, cap);
  Eigen::MatrixXd out(keep.size(), dim);
  for (std::size_t i = 0; i < keep.size(); ++i)
    for (int d = 0; d < dim; ++d) out(i, d) = pts[keep[i] * dim + d];
  return out;
}

}  // namespace potmap::detail
