#pragma once
// NumPy .npz archives: a zip file of .npy arrays named "<key>.npy" (what numpy.savez writes and
// numpy.load reads). The zip container is libzip's; the arrays are npy.hpp's.

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "io/npy.hpp"

namespace potmap::npz {

/// Every "<key>.npy" member of the archive, by key (without ".npy"); other members are skipped.
/// Throws InputError naming the path (and the member) for an unreadable archive, a member whose
/// CRC or size is wrong, or a malformed array.
std::map<std::string, npy::Array> read(const std::string& path);

/// Writes the arrays as "<key>.npy" members, uncompressed as numpy.savez does, atomically.
void write(const std::string& path, const std::vector<std::pair<std::string, npy::Array>>& arrays);

}  // namespace potmap::npz
