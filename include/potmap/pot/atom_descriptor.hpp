#pragma once
// Cheap pre-selection of atoms before the Sinkhorn ranking (large dictionaries
// must stay usable).
//
// The ranking compares a target sector with every atom rotated about its centroid (the origin
// of the sector frame), by the OT cost of squared distances. Rotations about the origin keep
// each point's distance from it (in 3D: the horizontal radius and the height z), so the
// distribution of those radii is what survives rotation. A descriptor holds, for the hits and
// for the free samples separately, the quantiles of the radius (and of z in 3D) at K levels.
//
// Why quantiles: x -> |x| is 1-Lipschitz, so the 1D 2-Wasserstein distance between the radius
// distributions is a lower bound on the 2-Wasserstein distance between the point sets under
// any rotation (in 3D, W2^2(radius) + W2^2(z) is, because the squared cost splits over
// (horizontal, vertical)); and the 1D W2^2 is the mean squared difference of the quantile
// functions, which K quantiles approximate in O(K). The pre-selection cost of a candidate
// mirrors the ranking score: hits term / its largest value over the atoms + free term / its
// largest value. Atoms without a sample class the target has (hits or free) come after all
// atoms that have it; a class the target lacks contributes nothing.

#include <array>
#include <cstddef>
#include <vector>
#include "potmap/export.h"

#include "potmap/pot/atoms.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Rotation-invariant summary of one sector (scaled units, like the sector's points).
struct AtomDescriptor {
  static constexpr int kQuantiles = 16;  ///< levels (i + 0.5) / 16, i < 16
  int dim = 2;
  std::size_t hits = 0, free = 0;  ///< sample counts (0: that class is absent)
  /// Quantiles of the (horizontal, in 3D) radius of the hits, then of the free samples.
  std::array<float, kQuantiles> hit_radius{}, free_radius{};
  /// 3D only: quantiles of z of the hits and of the free samples (zeros in 2D).
  std::array<float, kQuantiles> hit_z{}, free_z{};
};

/// The descriptor of one sector. O(n log n) in its samples.
AtomDescriptor describe_sector(const Sector& sector);

/// Squared quantile distance of one class: mean over levels of the squared difference of the
/// radius quantiles (plus the z quantiles in 3D); an estimate of a lower bound on that class's
/// OT cost under any rotation. Both descriptors must have the class (hits: true, free: false).
double descriptor_distance(const AtomDescriptor& a, const AtomDescriptor& b, bool hits);

/// Descriptors of every atom of a dictionary, computed once, then queried per target sector.
class AtomPreselector {
 public:
  AtomPreselector() = default;
  explicit AtomPreselector(const Dictionary& dict);

  /// Indices of the k atoms most similar to `target` by the cost described above, most similar
  /// first (ties by index). k = 0 or k >= size(): every atom, in that order. Throws
  /// ArgumentError when the target's dimension differs from the dictionary's.
  std::vector<std::size_t> select(const Sector& target, std::size_t k) const;
  /// The same with the target's descriptor already computed.
  std::vector<std::size_t> select(const AtomDescriptor& target, std::size_t k) const;

  std::size_t size() const { return desc_.size(); }
  const std::vector<AtomDescriptor>& descriptors() const { return desc_; }

 private:
  int dim_ = 2;
  std::vector<AtomDescriptor> desc_;
};

/// Convenience: AtomPreselector(dict).select(target, k). Describes every atom on each call
/// (O(points in the dictionary)); build an AtomPreselector once to rank many targets.
std::vector<std::size_t> preselect_atoms(const Dictionary& dict, const Sector& target,
                                         std::size_t k);

}  // namespace potmap
POTMAP_CXX_API_END
