#pragma once
// An overall map that averages the instantaneous maps instead of summing their kernels
// (AveragedMapOptions; measured in docs/pot-measurements.md).
//
// Summing the kernels of every scan (OverallMap) adds one scan's free-space kernels to another
// scan's wall kernels wherever the two pass near each other, and the wall reads 0.5. Here the
// overall logit at a place is the average of the instantaneous maps' logits there, each weighted
// by how much that scan's kernels cover the place (its support, sum of phi):
//     v(x) = sum_t s_t(x) mu_t(x) / sum_t s_t(x),   s_t(x) = sum_{k in scan t} phi_k(x),
// and the same average of the variances. The average is kept at anchors on a regular grid
// (AveragedMapOptions::spacing) as running sums, so adding a scan costs only its footprint. The
// map handed out is an ordinary kernel map with one kernel per anchor whose weights are solved
// (projected Gauss-Seidel sweeps of (Phi + ridge I) w = v over the scan's footprint, each weight
// kept to its average's sign, warm-started) so that it reproduces the anchors' averages; its
// variances are the averaged variances spread by the anchors' partition (the Nadaraya-Watson
// rule of atoms' kernels at samples). Memory grows with the area seen at the grid spacing, not
// with the number of scans. The solve takes each anchor's own width for its neighbours' (exact
// when the instantaneous maps share one width, as BHM atoms' kernels do).

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"

// Internal (host/), declared outside the exported region so that it stays hidden: saves and
// restores the private state (Mapper::save_state).
namespace potmap::detail {
struct AveragedMapState;
}

POTMAP_CXX_API_BEGIN
namespace potmap {

struct AveragedMapOptions {
  /// Anchor grid edge, metres (default 0.25: half the kernel spacing of the BHM atoms; at their
  /// spacing, 0.5 m, the solved map smooths walls away; measured in docs/pot-measurements.md).
  double spacing = 0.25;
  /// A scan counts at an anchor when its support there is at least this (sum of phi; default
  /// 1: about one of its kernels' worth. Lower floors let a scan's decaying tails become
  /// anchors whose small averages the solve turns into rings around what was seen).
  double min_support = 1.0;
  /// Ridge of the weights' solve (default 0.1: anchors 0.25 m apart have a poorly conditioned
  /// Gram matrix; the ridge keeps the weights from chasing each other, and the solve keeps each
  /// weight to its average's sign so that no weight exists only to cancel its neighbours).
  double ridge = 0.1;
  /// Gauss-Seidel sweeps over a scan's footprint per add (default 5; the sweeps of later scans
  /// continue them, and 30 changed no score in the third digit).
  int sweeps = 5;
};

class AveragedMap {
 public:
  /// `dim` 2 or 3; throws ArgumentError for bad options.
  explicit AveragedMap(int dim = 2, const AveragedMapOptions& options = {});

  /// Adds one instantaneous map (world frame; its bias is ignored). Throws ArgumentError when
  /// its dimension differs or it fails KernelMap::validate.
  void add(const KernelMap& instantaneous);

  /// Adds the scans of another averaged map of the same place, made apart (another robot):
  /// its anchors' running sums are added to this map's anchor by anchor (anchors it has and
  /// this map lacks are made), and the weights are solved again over the whole map, from this
  /// map's weights moved by each average's change (max(sweeps, 30) sweeps: the change spans
  /// the map, not one scan's footprint). The average is over both maps' scans as if one map
  /// had seen them all, so a map added to itself, or to a map of the same scans, gives back
  /// the same averages (each scan weighs as much as before: nothing is counted twice in the
  /// sense of growing surer); only the solve's path differs from one map's. Throws
  /// ArgumentError when the dimension or the options (spacing, min_support, ridge) differ.
  void add_map(const AveragedMap& other);

  /// The solved kernel map (no bias), one kernel per anchor. Valid until the next add().
  const KernelMap& map() const { return map_; }
  std::size_t size() const { return map_.size(); }
  std::size_t memory_bytes() const;
  const AveragedMapOptions& options() const { return opt_; }

 private:
  friend struct detail::AveragedMapState;
  std::int64_t cell(double x) const;
  std::int64_t block_side() const;
  /// Anchor slots of the `count` cells from c along x (-1: none) into out.
  void slots_along_x(const std::int64_t c[3], std::size_t count, std::int64_t* out) const;
  /// Makes `slot` the anchor of cell c; false (and nothing changed) when c has one already.
  bool set_slot(const std::int64_t c[3], std::uint32_t slot);
  // The steps of add(), over the box of cells the scan reaches (defined in averaged_map.cpp).
  struct Box;
  Box footprint(const KernelMap& instantaneous) const;
  /// The scan's logit, variance and support sums at every cell of the box into ws_.
  void scatter(const KernelMap& instantaneous, const Box& box);
  /// Anchors where the scan's support is enough, and their running sums updated.
  void place_anchors(const Box& box);
  /// The anchors' weights and variances solved over the box.
  void solve_weights(const Box& box);

  int dim_;
  AveragedMapOptions opt_;
  KernelMap map_;                        // anchor k = kernel k
  std::vector<double> sum_sm_, sum_s_;   // running sums of s * mu and s
  std::vector<double> sum_sv_, sum_sg_;  // of s * variance and s * gamma
  // The anchors' cells in blocks of block_side()^dim cells (a hash map from block to its
  // number, then a dense array of slots, -1 where no anchor): a scan's footprint reads its
  // slots a block row at a time instead of hashing every cell.
  std::unordered_map<std::uint64_t, std::uint32_t> blocks_;
  std::vector<std::int32_t> block_slots_;
  // Working memory of add(), kept between scans: a 360-beam scan's footprint needs megabytes,
  // and fresh pages for every scan cost more than filling them.
  struct Workspace {
    std::vector<double> m, v, sup, sg, t2, f, part, s2, change, w, has;
    std::vector<std::int64_t> slot;
    std::vector<std::size_t> active;
  } ws_;
};

}  // namespace potmap
POTMAP_CXX_API_END
