// Thinning of sector samples (see thinning.hpp).
#include "thinning.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "cell_key.hpp"
#include "data/sim_rng.hpp"
#include "runtime/wider_vectors.hpp"

namespace potmap::detail {

std::uint64_t mix(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  data::SimRng r{a * 0x9e3779b97f4a7c15ULL ^ (b + 0x632be59bd9b4e019ULL) * 0xbf58476d1ce4e5b9ULL ^
                 c * 0x94d049bb133111ebULL};
  return r.next();
}

namespace {

// A set of non-zero 64-bit cell keys in an open-addressing table of at least 2 n slots: the
// thinnings count a sector's occupied cells many times a scan, and a node-based set allocated
// once a point.
class CellSet {
 public:
  explicit CellSet(std::size_t n) {
    while ((std::size_t(1) << bits_) < 2 * n) ++bits_;
    table_.assign(std::size_t(1) << bits_, 0);
  }
  void clear() { std::fill(table_.begin(), table_.end(), 0); }
  /// True when `key` (not 0) was not in the set yet.
  bool insert(std::uint64_t key) {
    const std::size_t mask = table_.size() - 1;
    std::size_t h = std::size_t((key * 0x9e3779b97f4a7c15ULL) >> (64 - bits_));
    while (table_[h] != 0 && table_[h] != key) h = (h + 1) & mask;
    if (table_[h] != 0) return false;
    table_[h] = key;
    return true;
  }

 private:
  int bits_ = 4;
  std::vector<std::uint64_t> table_;
};

// Cell keys of m points (1 above the axes' 21-bit cell indices, so never 0) from their offsets
// from the low corner, an axis at a time (`stride` apart): the divisions vectorise. The offsets
// are >= 0 and at most 2^20 cells (the bisection's smallest cell), so the index through a 32-bit
// integer is the one a direct conversion to 64 bits gives.
POTMAP_WIDER_VECTORS void cell_keys(const double* rel, std::size_t stride, int dim, std::size_t m,
                                    double cell, std::uint64_t* keys) {
  for (std::size_t i = 0; i < m; ++i) keys[i] = 1;
  for (int d = 0; d < dim; ++d) {
    const double* r = rel + std::size_t(d) * stride;
    for (std::size_t i = 0; i < m; ++i)
      keys[i] = (keys[i] << 21) | std::uint64_t(std::uint32_t(std::int32_t(r[i] / cell)));
  }
}

}  // namespace

std::vector<std::size_t> thin_to_cells(const std::vector<double>& pts, int dim, double cell) {
  const std::size_t n = pts.size() / std::size_t(dim);
  CellSet seen(n);
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < n; ++i) {
    std::int64_t c[3] = {0, 0, 0};
    for (int d = 0; d < dim; ++d)
      c[d] = static_cast<std::int64_t>(std::floor(pts[i * dim + d] / cell));
    // pack_cell leaves the top bit clear: with it set, no key is 0.
    if (seen.insert(pack_cell(c) | (std::uint64_t(1) << 63))) out.push_back(i);
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
    std::vector<double> rel(n * std::size_t(dim));
    for (std::size_t i = 0; i < n; ++i)
      for (int d = 0; d < dim; ++d) rel[std::size_t(d) * n + i] = pts[i * dim + d] - lo[d];
    // Occupied cells (and the first point of each, in input order) for a cell size: this runs
    // a dozen times per call, twice per sector and scan.
    CellSet table(n);
    constexpr std::size_t kBlock = 128;
    std::uint64_t keys[kBlock];
    // Stops counting past `stop` cells: the bisection only asks whether a size leaves more
    // than the cap. Keys are made a block at a time, so a stop wastes at most one block.
    auto cells = [&](double cell, std::vector<std::size_t>* firsts, std::size_t stop) {
      table.clear();
      std::size_t count = 0;
      for (std::size_t i0 = 0; i0 < n && count <= stop; i0 += kBlock) {
        const std::size_t m = std::min(kBlock, n - i0);
        cell_keys(rel.data() + i0, n, dim, m, cell, keys);
        for (std::size_t k = 0; k < m && count <= stop; ++k)
          if (table.insert(keys[k])) {
            ++count;
            if (firsts) firsts->push_back(i0 + k);
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
