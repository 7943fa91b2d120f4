#pragma once
// The overall map of SPEC step 6 (paper Sec. III-D): kernels of successive instantaneous maps
// accumulated in the world frame, with bounded memory over long drives.
//
// Merging. Kernels are summed by the map model, so the same place seen twice must not end up
// with two copies of its kernels (the logit there would double). A new kernel n merges into the
// nearest existing kernel e (of the map before this add()) when
//     |h_n - h_e|^2 * max(gamma_n, gamma_e) < merge_radius   and
//     max(gamma_n, gamma_e) / min(gamma_n, gamma_e) <= gamma_ratio,
// i.e. when it lands well inside the narrower kernel's width and the two widths are alike.
// With c_e the number of kernels already merged into e and omega = c_e / (c_e + 1):
//   * weight: covariance intersection, 1/v = omega/v_e + (1-omega)/v_n,
//             w = v * (omega w_e/v_e + (1-omega) w_n/v_n).
//     Transported weights of successive scans are not independent evidence (they are copies of
//     the same dictionary atoms, or refinements from overlapping scans): a Bayesian product of
//     the two would shrink the variance with every visit and make the map overconfident where
//     the vehicle passes often. Covariance intersection is the fusion that stays consistent for
//     any unknown correlation: v never drops below min(v_e, v_n), the mean is still
//     precision-weighted (a confident RePOT weight outweighs a vague prior-like one), and with
//     omega from the counts it is the running precision-weighted average of every visit.
//     Merging a kernel with an identical copy leaves it unchanged (adding the same map twice is
//     idempotent). Zero variances are handled as the limit (exact weights win).
//   * position and gamma: count-weighted running means (h = omega h_e + (1-omega) h_n; the same
//     for gamma), so a kernel stays at the average place where it was transported.
//   * count c_e + 1; last_seen = the add() number.
// The same rule, with omega = c_e / (c_e + c_f), fuses two existing kernels e and f when a merge
// has moved e onto f (consolidation): the merge radius then stays a real spacing between
// kernels of similar width, so jittered revisits cannot pile kernels up around one place.
// Kernels of the current add() take no part in either (an instantaneous map's own kernels are
// meant to be summed); they can be fused in later adds. Kernel order is not stable: a fused or
// retired kernel's slot is taken by another.
//
// Spatial index: a hash grid over kernel positions (cell edge: the largest merge distance
// sqrt(merge_radius / gamma) seen in the first non-empty add(), fixed afterwards). A query
// visits the cells within the new kernel's own merge distance, so add() costs O(new kernels x
// kernels per cell) whatever the map's size, and results never depend on the cell edge.
//
// Hard cap (optional): when the map exceeds max_kernels, the least-supported kernels (smallest
// count, then oldest last_seen, then oldest index) are retired down to retire_to x max_kernels,
// so the O(M) selection is paid once per (1 - retire_to) x max_kernels additions.

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>
#include "potmap/export.h"

#include "potmap/map/kernel_map.hpp"

// Internal (host/), declared outside the exported region so that it stays hidden: saves and
// restores the private state (Mapper::save_state).
namespace potmap::detail {
struct OverallMapState;
}

POTMAP_CXX_API_BEGIN
namespace potmap {

struct OverallMapOptions {
  /// Merge when d^2 * max(gamma) is below this (unitless; default 0.25: within half of
  /// 1/sqrt(gamma), where phi is still above exp(-0.25) = 0.78). 0 disables merging.
  double merge_radius = 0.25;
  /// Largest ratio of widths that may merge (>= 1; default 2).
  double gamma_ratio = 2.0;
  /// Hard cap on the number of kernels (0, the default: none).
  std::size_t max_kernels = 0;
  /// Fraction of max_kernels kept after a retirement pass (in (0, 1]; default 0.9).
  double retire_to = 0.9;
};

/// What one add() did.
struct OverallMapAddStats {
  std::size_t added = 0;    ///< new kernels appended
  std::size_t merged = 0;   ///< new kernels merged into existing ones
  std::size_t retired = 0;  ///< kernels removed by the cap
  std::size_t fused = 0;    ///< pairs of existing kernels fused after a merge moved one
};

class OverallMap {
 public:
  /// `dim` 2 or 3; throws ArgumentError for bad options.
  explicit OverallMap(int dim = 2, const OverallMapOptions& options = {});

  /// Merges or appends every kernel of `instantaneous` (world frame; its bias is ignored).
  /// Throws ArgumentError when its dimension differs or it fails KernelMap::validate.
  OverallMapAddStats add(const KernelMap& instantaneous);

  /// The accumulated kernels (no bias). Valid until the next add().
  const KernelMap& map() const { return map_; }
  std::size_t size() const { return map_.size(); }
  /// Bytes held: kernel arrays, counts and the spatial index (capacity, not just size).
  std::size_t memory_bytes() const;
  /// Number of instantaneous kernels merged into each kernel (1 for a kernel never merged).
  const std::vector<std::uint32_t>& counts() const { return count_; }
  /// Number of add() calls so far.
  std::uint64_t adds() const { return adds_; }
  const OverallMapOptions& options() const { return opt_; }

 private:
  friend struct detail::OverallMapState;
  using CellKey = std::uint64_t;
  CellKey key_of(const double* p) const;
  CellKey key_of(const std::int64_t c[3]) const;
  void cell_of(const double* p, std::int64_t c[3]) const;
  void index_insert(std::uint32_t k);
  void index_erase(std::uint32_t k);
  long nearest_mergeable(const double* p, double gamma, long exclude) const;
  void merge_into(std::size_t e, const double* p, double g, double wm, double wv,
                  std::uint32_t count);
  std::size_t consolidate(std::size_t e);
  void remove(std::size_t k);
  std::size_t retire();

  int dim_;
  OverallMapOptions opt_;
  KernelMap map_;
  std::vector<std::uint32_t> count_;
  std::vector<std::uint64_t> last_seen_;
  std::vector<std::uint64_t> born_;  // add() number that created the kernel
  double cell_ = 0;                  // 0 until the first kernel arrives
  std::unordered_map<CellKey, std::vector<std::uint32_t>> grid_;
  std::uint64_t adds_ = 0;
};

}  // namespace potmap
POTMAP_CXX_API_END
