#pragma once
// The .potmap map file with a section of its own after the kernels (format version 2): the
// information form of a joint BHM (host/learn/bhm_joint_file.cpp). Layout:
// include/potmap/io/map_io.hpp.

#include <cstddef>
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

}  // namespace potmap::detail
