#pragma once
// Spatial index over the kernels of a map, answering "which kernels' cut-off balls reach this
// box?". Kernel reach varies by orders of magnitude (Town 1: 4.8 m to 36 m), so kernels are
// grouped into classes of similar reach, each with its own uniform grid whose cell is the
// class's largest reach: a box query then visits a few cells per class, and wide kernels are
// never lost.

#include <cstdint>
#include <vector>

#include "potmap/map/kernel_map.hpp"

namespace potmap::detail {

class KernelIndex {
 public:
  KernelIndex() = default;
  KernelIndex(const KernelMap& map, double tau);

  /// Appends to `out` every kernel k with gamma_k * dist(h_k, box)^2 <= tau, where box is
  /// [lo, hi] (dim axes). Order: by reach class, then by cell.
  void query_box(const double lo[3], const double hi[3], std::vector<std::uint32_t>& out) const;
  /// Largest reach sqrt(tau / gamma) over the map, metres (0 for an empty map).
  double max_reach() const { return max_reach_; }

 private:
  struct Class {
    double cell = 0;  // grid cell edge >= every reach in the class
    double lo[3] = {0, 0, 0};
    std::int64_t n[3] = {1, 1, 1};
    std::vector<std::uint32_t> start;  // CSR over cells
    std::vector<std::uint32_t> items;  // kernel ids
  };
  int dim_ = 2;
  double tau_ = 18;
  double max_reach_ = 0;
  const KernelMap* map_ = nullptr;
  std::vector<Class> classes_;
};

/// A map's sums at one point over the kernels the index finds there: the logit mean and
/// variance (SPEC section 2), the sums of phi and phi^2, and the width of the nearest kernel.
struct LocalSums {
  double mu = 0, s2 = 0, sum = 0, sum2 = 0;
  double nearest_gamma = 0;  ///< 0 when no kernel reaches the point
  bool empty() const { return nearest_gamma == 0; }
};
/// `scratch` holds the kernel ids between calls (no allocation per point).
LocalSums local_sums(const KernelMap& map, const KernelIndex& index, const double* x,
                     std::vector<std::uint32_t>& scratch);

}  // namespace potmap::detail
