#pragma once
// Placement at the target's own samples (PotPlacement::target_samples, host/pot/
// placement_at_samples.cpp): kernels sit on the target's thinned hits and free samples, and what
// they carry is pulled back through the plans from the atom's map at the coupled source samples.

#include <array>
#include <vector>

#include <Eigen/Core>

#include "atom_transport_cache.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/transfer.hpp"

namespace potmap::detail {

/// One target anchor before the scan's partition turns values into weights: the logit mean and
/// variance the instantaneous map should read there (world frame).
struct Anchor {
  std::array<double, 3> position{0, 0, 0};  ///< world frame, metres
  double gamma = 0;                         ///< 1/m^2
  double value = 0;                         ///< logit mean to reproduce
  double variance = 0;                      ///< logit variance to reproduce
  bool hit = false;                         ///< anchored on a hit (else a free sample)
};

/// The anchors of one target sector. `plan_source`/`plan_target`/`coupling` per class (0 hits,
/// 1 free; an empty coupling: that class was not transported), in the problems' frame (centred,
/// scaled; the source not yet rotated by `angle`).
struct SectorPlans {
  std::array<const Eigen::MatrixXd*, 2> source{nullptr, nullptr};
  std::array<const Eigen::MatrixXd*, 2> target{nullptr, nullptr};
  std::array<const Eigen::MatrixXd*, 2> coupling{nullptr, nullptr};
  /// The atom's map at each source (AtomTransportCache::sample_map), or null: computed here.
  std::array<const SampleMap*, 2> source_map{nullptr, nullptr};
  double angle = 0;
};

/// The anchor sites of `sec` (the target sector) for the transport targets `targets[q]` of
/// class q (0 hits, 1 free samples; null: the class is not transported), in the problems'
/// frame (centred, scaled): each kept sample's nearest target (AnchorSites).
AnchorSites anchor_sites(const Sector& sec, const std::array<const Eigen::MatrixXd*, 2>& targets,
                         const PotOptions& o);

/// Appends the anchors of `sec` (the target sector) transported from `atom` by `plans`, at
/// `sites` (anchor_sites() of the plans' targets). `classes`: the atom's kernel classes if
/// already known (AtomTransportCache), else null. Returns how many anchors it dropped (free
/// anchors within the wall clearance of a hit).
std::size_t anchors_at_samples(const Atom& atom, const Sector& sec, const SectorPlans& plans,
                               const AnchorSites& sites, const PotOptions& o,
                               std::vector<Anchor>& out, const KernelClasses* classes = nullptr);

/// The instantaneous map of a scan's anchors, appended to `map`. Variances: each class's
/// kernels weighted so that, alone, they reproduce the anchors' variances at the anchors (a
/// Nadaraya-Watson partition, as atoms' kernels at samples are built). Means: `gain` times the
/// anchors' values; with `sweeps` = 0 by the same partition, else solved so that the map of both
/// classes together reads them at the anchors (projected Gauss-Seidel over every pair within
/// gamma d^2 <= 16, each weight kept to its value's sign, started from the partition's weights).
/// PotOptions::anchor_sweeps and logit_gain say why.
void anchors_to_map(const std::vector<Anchor>& anchors, int dim, KernelMap& map, int sweeps = 0,
                    double gain = 1.0);

}  // namespace potmap::detail
