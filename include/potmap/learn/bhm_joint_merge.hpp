#pragma once
// Merging joint BHM maps in information form (SPEC section 9), and the map file that carries
// that form. Map files of either kind (POT's averaged maps too) merge through
// potmap/mapping/map_files.hpp.
//
// With the Jaakkola-Jordan bound a joint BHM's posterior is Gaussian with precision
// P = P_0 + (data) and information vector eta = P_0 mu_0 + (data): data enter as sums. Maps
// learned from independent data over the same prior fuse exactly as
//
//   P_C = P_A + P_B - P_0,   eta_C = eta_A + eta_B - P_0 mu_0   (the prior counted once)
//
// kernel by kernel on their common lattice, then the means solve P_C mean = eta_C (the
// learner's own conjugate gradients) and the variances follow as in JointBhm::map(). The
// variational xi of each side were fitted to its own posterior, so the fused map is close to,
// not equal to, one run over both data sets (docs/merging.md has the measured difference).
//
// Seeds (JointBhm::seed_unreached, RePOT's transported kernels) are priors, not data: where a
// sample reached a kernel in either map the merged kernel has the plain prior (as a seed
// yields to data in one map); where none did, the kernel keeps the seed of the map that seeded
// it (the firmer seed, smaller variance, when both did).
//
// The .potmap file of a joint BHM (write_joint_bhm_map) is format version 2: the version 1 map
// (means and variances, readable by read_map) with bit 1 of its flags set and, after the
// kernels' arrays and before the checksum, a u64 byte count and the information form (the
// learner's options, tiles, precision stencils, eta, flags, bias parameters, retired tiles
// and data fingerprints; host/learn/bhm_joint_file.cpp). Version 1 files read as before.

#include <optional>
#include <string>
#include <vector>

#include "potmap/export.h"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/map/kernel_map.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct JointBhmMergeOptions {
  /// Merge maps that share a data fingerprint (JointBhm::data_ids(): the same scan learned by
  /// both). Default false: ArgumentError, since the shared scans would be counted twice, the
  /// map growing twice as sure of them as the data allow. True counts them twice, knowingly.
  bool allow_overlap = false;
  /// The maps' names in errors (file names; default "map 1", "map 2", ...).
  std::vector<std::string> names;
};

/// Fuses joint BHM maps of overlapping places, each learned from its own data over the same
/// prior, into one: the sum of their precisions and information vectors with the prior counted
/// once, the means solved (tolerance 1e-8, as JointBhm::map()'s polish) and the variance cache
/// marked for recomputation. The result continues learning like any JointBhm (its update()
/// adds further scans to the fused posterior); its options, solver settings included, are the
/// first map's, and its data_ids() the maps' together.
///
/// The maps must share the lattice and the prior: dimension, spacing, kernel width, cut-off
/// tau, prior variance, bias, and for bounded maps the same bounds (growable maps all sit on
/// the lattice through the origin). Throws ArgumentError naming both maps and the value that
/// differs; for fewer than one map; for a map with retired tiles (JointBhm::retire_far() folded
/// their couplings into their neighbours' information vector, which is then no longer a sum of
/// data); for a map whose seeds do not yield (options.seeds_yield false), whose seeded kernels'
/// data and seed cannot be told apart; and, unless options.allow_overlap, for two maps sharing
/// a data fingerprint (a map merged with itself, or two maps of the same scans).
JointBhm merge_joint_bhm(const std::vector<const JointBhm*>& maps,
                         const JointBhmMergeOptions& options = {});

/// Writes a joint BHM map to a .potmap file (version 2): its exported map (`exported`, or
/// learner.map() when null) readable by read_map(), and its information form for merging.
/// Atomic (temporary file, then rename). Throws ArgumentError for a name that does not end
/// in .potmap, potmap::Error if writing fails.
void write_joint_bhm_map(const JointBhm& learner, const std::string& path,
                         const KernelMap* exported = nullptr);

/// The information form of a .potmap file written by write_joint_bhm_map(): the learner as
/// it was saved (it continues learning as the saved one would, up to the solver's scratch).
/// std::nullopt for a map without one (format version 1, or maps of other methods: POT's
/// averaged map, ABHM). Throws InputError "<path>: byte offset <n>: ..." for a file that is not
/// a readable .potmap map or whose information form is corrupt.
std::optional<JointBhm> read_joint_bhm_information(const std::string& path);

}  // namespace potmap
POTMAP_CXX_API_END
