#pragma once
// Fingerprints that tell a mapping run's inputs apart, so that a checkpoint (Mapper::save_state,
// `potmap map --resume`) is never continued with another dictionary, other scans or other
// options: 64-bit FNV-1a hashes of the values that decide the maps, in a fixed byte order
// (little-endian), so that the same inputs give the same fingerprint on every platform and
// build. A fingerprint detects a mistake (a different file, a changed option); it is no
// cryptographic hash.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "potmap/data/scan.hpp"
#include "potmap/export.h"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/pot/overall_map.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Every value of the dictionary: its settings and each atom's sector, kernels and provenance.
std::uint64_t fingerprint(const Dictionary& dict);

/// Every value of the scans (poses, hits, no-return directions, ranges, timestamps), in order.
std::uint64_t fingerprint(const std::vector<Scan>& scans);

/// Every option that changes a map: MapperOptions (not `pipeline`, which changes only the
/// timing, nor the preselector and index, which are built from the dictionary) and the overall
/// map's options.
std::uint64_t fingerprint(const MapperOptions& options, const OverallMapOptions& overall);

}  // namespace potmap
POTMAP_CXX_API_END
