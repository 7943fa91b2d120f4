#pragma once
// The .potmap map file with a section of its own after the kernels (format version 2): the
// information form of a joint BHM (host/learn/bhm_joint_file.cpp) or POT's averaged map's
// anchor sums (host/mapping/averaged_map_file.cpp). Layout: include/potmap/io/map_io.hpp.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

#include "io/container.hpp"
#include "potmap/map/kernel_map.hpp"

namespace potmap::detail {

/// Writes `map` as version 2 with the section `section` writes (its length is filled in).
void write_map_native_with_section(const KernelMap& map, const std::string& path,
                                   const std::function<void(ContainerWriter&)>& section);

/// The map of an open .potmap file (version 1 or 2), checked as read_map_native() checks it;
/// `section_at` gets where a version 2 file's section starts (0 when there is none).
KernelMap read_map_native_from(const ContainerReader& r, std::size_t* section_at);

/// The layout of .potmap files this build reads (versions 1 and 2).
const ContainerLayout& native_map_layout();

/// A section's first u32, saying what follows.
constexpr std::uint32_t kJointBhmSection = 1;     ///< a joint BHM's information form
constexpr std::uint32_t kAveragedMapSection = 2;  ///< POT's averaged map: its anchors' sums

/// Whether `path` ends in .potmap (any case).
bool has_potmap_extension(const std::string& path);

/// Throws ArgumentError unless `path` ends in .potmap: `what` goes only into such a file.
void check_potmap_name(const std::string& path, const char* what);

/// Where the section of an open .potmap file starts, at its layout field (0: it has none).
std::size_t map_section_of(const ContainerReader& r);

}  // namespace potmap::detail
