// Labelled samples gathered per voxel: one weighted sample for each scan, label and small voxel.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

#include "potmap/data/labelling.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

// 21 bits an axis (signed, +-2^20 voxels), the label in the lowest bit: a key orders the
// voxels in raster order (z, y, x), hits after free samples.
constexpr std::int64_t kAxisBits = 21;
constexpr std::int64_t kAxisHalf = std::int64_t(1) << (kAxisBits - 1);

bool voxel_key(const double* x, int dim, double inv, std::uint8_t label, std::uint64_t* key) {
  std::uint64_t k = 0;
  for (int d = dim - 1; d >= 0; --d) {
    const double c = std::floor(x[d] * inv);
    if (!(c >= -double(kAxisHalf) && c < double(kAxisHalf))) return false;
    k = (k << kAxisBits) | std::uint64_t(std::int64_t(c) + kAxisHalf);
  }
  *key = (k << 1) | (label ? 1u : 0u);
  return true;
}

}  // namespace

LabelledPoints aggregate_voxels(const LabelledPoints& samples, double voxel) {
  if (!(voxel > 0) || !std::isfinite(voxel))
    throw ArgumentError("aggregate_voxels: voxel edge must be positive, got " +
                        std::to_string(voxel));
  const std::size_t n = samples.size();
  const int dim = samples.dim;
  if (samples.position.size() != n * std::size_t(dim) ||
      (!samples.weight.empty() && samples.weight.size() != n) ||
      (!samples.scan.empty() && samples.scan.size() != n))
    throw ArgumentError(
        "aggregate_voxels: positions, labels, scans and weights disagree in number");
  const double inv = 1.0 / voxel;
  // (scan, key, index), sorted: each run of equal (scan, key) is one output sample. A point
  // farther than 2^20 voxels from the origin keeps a voxel of its own (index as its key).
  struct Entry {
    std::int64_t scan;
    std::uint64_t key;
    std::uint32_t index;
    bool alone;
  };
  std::vector<Entry> e(n);
  for (std::size_t i = 0; i < n; ++i) {
    Entry& en = e[i];
    en.scan = samples.scan.empty() ? 0 : samples.scan[i];
    en.index = std::uint32_t(i);
    en.alone = !voxel_key(&samples.position[i * dim], dim, inv, samples.label[i], &en.key);
    if (en.alone) en.key = i;
  }
  std::sort(e.begin(), e.end(), [](const Entry& a, const Entry& b) {
    if (a.scan != b.scan) return a.scan < b.scan;
    if (a.alone != b.alone) return b.alone;
    return a.key != b.key ? a.key < b.key : a.index < b.index;
  });
  LabelledPoints out;
  out.dim = dim;
  for (std::size_t a = 0; a < n;) {
    std::size_t b = a + 1;
    while (b < n && e[b].scan == e[a].scan && e[b].key == e[a].key && e[b].alone == e[a].alone) ++b;
    double sum[3] = {0, 0, 0}, w = 0;
    for (std::size_t k = a; k < b; ++k) {
      const std::size_t i = e[k].index;
      const double wi = samples.weight.empty() ? 1.0 : samples.weight[i];
      for (int d = 0; d < dim; ++d) sum[d] += wi * samples.position[i * dim + d];
      w += wi;
    }
    if (w > 0) {
      for (int d = 0; d < dim; ++d) out.position.push_back(sum[d] / w);
      out.label.push_back(samples.label[e[a].index]);
      out.scan.push_back(e[a].scan);
      out.weight.push_back(w);
    }
    a = b;
  }
  return out;
}

}  // namespace potmap
