#pragma once
// Map files that merge, of either kind, and a mapper's map written with what merging needs:
// the mapping layer's part of merging, above the learners (potmap/learn/bhm_joint_merge.hpp:
// joint BHM maps in information form) and transport (POT's averaged map).
//
// POT's averaged overall map is not a Gaussian posterior, but it too is a sum over scans: at
// each anchor of its grid the support and the support-weighted logit, variance and width.
// AveragedMap::add_map() adds another map's sums and solves the weights again, which averages
// over both maps' scans; a map added to itself gives back its own averages (counted once).
//
// Both are .potmap files of format version 2 (include/potmap/io/map_io.hpp): the map, readable
// by read_map(), then a section whose first u32 says which form follows.

#include <optional>
#include <string>
#include <vector>

#include "potmap/export.h"
#include "potmap/learn/bhm_joint_merge.hpp"
#include "potmap/pot/averaged_map.hpp"
#include "potmap/pot/mapper.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// POT's averaged overall map (AveragedMap) into a .potmap file (version 2): its solved map,
/// readable by read_map(), and its anchors' running sums, which AveragedMap::add_map() adds
/// (`potmap merge` of such files). Atomic. Throws ArgumentError for a name that does not end in
/// .potmap, potmap::Error if writing fails.
void write_averaged_map(const AveragedMap& map, const std::string& path);

/// The averaged map of a .potmap file written by write_averaged_map(); std::nullopt for a map
/// without one (a joint BHM's, version 1). Throws InputError as read_joint_bhm_information().
std::optional<AveragedMap> read_averaged_map_information(const std::string& path);

/// What merge_map_files() merged.
struct MapMergeSummary {
  bool averaged = false;    ///< POT's averaged maps (else joint BHM maps)
  std::size_t kernels = 0;  ///< kernels (anchors) of the merged map
  std::size_t scans = 0;    ///< joint BHM: scans the merged map holds (data_ids())
};

/// Merges .potmap files of one kind, joint BHM maps (merge_joint_bhm) or POT's averaged maps
/// (AveragedMap::add_map), and writes the result with what a further merge needs to `out`.
/// `options.names` is filled with the paths. Throws InputError naming a file written without
/// what merging needs (ABHM, POT's summed kernels, CSV, NPZ, a build before merging),
/// ArgumentError for fewer than two files, maps of both kinds, or as merge_joint_bhm().
MapMergeSummary merge_map_files(const std::vector<std::string>& paths, const std::string& out,
                                JointBhmMergeOptions options = {});

/// Writes a mapper's overall map to `path`: into a .potmap with what merging needs (RePOT's
/// persistent map: write_joint_bhm_map; POT's averaged map: write_averaged_map), else the map
/// alone (write_map: POT's summed kernels, other formats).
void write_mapper_map(const Mapper& mapper, const std::string& path);

}  // namespace potmap
POTMAP_CXX_API_END
