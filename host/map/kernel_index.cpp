#include "map/kernel_index.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace potmap::detail {

namespace {
constexpr std::int64_t kMaxCellsPerClass = std::int64_t(1) << 22;
}

KernelIndex::KernelIndex(const KernelMap& map, double tau) : dim_(map.dim), tau_(tau), map_(&map) {
  const std::size_t m = map.size();
  if (m == 0) return;
  std::vector<double> reach(m);
  double rmin = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < m; ++k) {
    reach[k] = std::sqrt(tau / map.gamma[k]);
    rmin = std::min(rmin, reach[k]);
    max_reach_ = std::max(max_reach_, reach[k]);
  }
  // Class c holds reaches in (rmin * 2^(c-1), rmin * 2^c].
  const int nclass = 1 + static_cast<int>(std::ceil(std::log2(max_reach_ / rmin) + 1e-12));
  std::vector<std::vector<std::uint32_t>> members(nclass);
  for (std::size_t k = 0; k < m; ++k) {
    int c = static_cast<int>(std::ceil(std::log2(reach[k] / rmin) - 1e-12));
    c = std::clamp(c, 0, nclass - 1);
    members[c].push_back(static_cast<std::uint32_t>(k));
  }
  for (int c = 0; c < nclass; ++c) {
    if (members[c].empty()) continue;
    Class cl;
    double hi[3] = {0, 0, 0};
    for (int d = 0; d < dim_; ++d) {
      cl.lo[d] = std::numeric_limits<double>::infinity();
      hi[d] = -std::numeric_limits<double>::infinity();
    }
    double cell = 0;
    for (std::uint32_t k : members[c]) {
      cell = std::max(cell, reach[k]);
      for (int d = 0; d < dim_; ++d) {
        cl.lo[d] = std::min(cl.lo[d], map.position[k * dim_ + d]);
        hi[d] = std::max(hi[d], map.position[k * dim_ + d]);
      }
    }
    // A huge sparse map could ask for too many cells: widen them (more candidates, same result).
    for (;;) {
      std::int64_t total = 1;
      for (int d = 0; d < dim_; ++d) {
        cl.n[d] = static_cast<std::int64_t>(std::floor((hi[d] - cl.lo[d]) / cell)) + 1;
        total *= cl.n[d];
      }
      if (total <= kMaxCellsPerClass) break;
      cell *= 2;
    }
    cl.cell = cell;
    std::int64_t total = cl.n[0] * cl.n[1] * cl.n[2];
    std::vector<std::uint32_t> cell_of(members[c].size());
    cl.start.assign(total + 1, 0);
    for (std::size_t i = 0; i < members[c].size(); ++i) {
      const std::uint32_t k = members[c][i];
      std::int64_t idx = 0;
      for (int d = dim_ - 1; d >= 0; --d) {
        std::int64_t t = static_cast<std::int64_t>((map.position[k * dim_ + d] - cl.lo[d]) / cell);
        t = std::clamp<std::int64_t>(t, 0, cl.n[d] - 1);
        idx = idx * cl.n[d] + t;
      }
      cell_of[i] = static_cast<std::uint32_t>(idx);
      ++cl.start[idx + 1];
    }
    for (std::int64_t i = 0; i < total; ++i) cl.start[i + 1] += cl.start[i];
    cl.items.resize(members[c].size());
    std::vector<std::uint32_t> fill(cl.start.begin(), cl.start.end() - 1);
    for (std::size_t i = 0; i < members[c].size(); ++i)
      cl.items[fill[cell_of[i]]++] = members[c][i];
    classes_.push_back(std::move(cl));
  }
}

void KernelIndex::query_box(const double lo[3], const double hi[3],
                            std::vector<std::uint32_t>& out) const {
  if (!map_) return;
  const double* pos = map_->position.data();
  const double* gamma = map_->gamma.data();
  for (const Class& cl : classes_) {
    std::int64_t a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
    bool empty = false;
    for (int d = 0; d < dim_; ++d) {
      // Cells whose kernels can reach the box: the box grown by the class's largest reach.
      const double l = (lo[d] - cl.cell - cl.lo[d]) / cl.cell;
      const double h = (hi[d] + cl.cell - cl.lo[d]) / cl.cell;
      a[d] = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor(l)));
      b[d] = std::min<std::int64_t>(cl.n[d] - 1, static_cast<std::int64_t>(std::floor(h)));
      if (a[d] > b[d]) empty = true;
    }
    if (empty) continue;
    for (std::int64_t z = a[2]; z <= b[2]; ++z)
      for (std::int64_t y = a[1]; y <= b[1]; ++y) {
        const std::int64_t row = (z * cl.n[1] + y) * cl.n[0];
        const std::uint32_t s = cl.start[row + a[0]], e = cl.start[row + b[0] + 1];
        for (std::uint32_t i = s; i < e; ++i) {
          const std::uint32_t k = cl.items[i];
          double d2 = 0;
          for (int d = 0; d < dim_; ++d) {
            const double p = pos[k * dim_ + d];
            const double q = std::clamp(p, lo[d], hi[d]);
            d2 += (p - q) * (p - q);
          }
          if (gamma[k] * d2 <= tau_) out.push_back(k);
        }
      }
  }
}

LocalSums local_sums(const KernelMap& map, const KernelIndex& index, const double* x,
                     std::vector<std::uint32_t>& scratch) {
  LocalSums r;
  scratch.clear();
  index.query_box(x, x, scratch);
  const int dim = map.dim;
  double best = HUGE_VAL;
  for (std::uint32_t k : scratch) {
    double d2 = 0;
    for (int d = 0; d < dim; ++d) {
      const double t = x[d] - map.position[std::size_t(k) * dim + d];
      d2 += t * t;
    }
    const double phi = std::exp(-map.gamma[k] * d2);
    r.mu += map.w_mean[k] * phi;
    r.s2 += map.w_var[k] * phi * phi;
    r.sum += phi;
    r.sum2 += phi * phi;
    if (d2 < best) {
      best = d2;
      r.nearest_gamma = map.gamma[k];
    }
  }
  return r;
}

}  // namespace potmap::detail
