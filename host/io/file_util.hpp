#pragma once
// Whole-file reads and writes for the map and point readers.

#include <string>

namespace potmap::detail {

/// Writes `bytes` to `path` atomically (AtomicFile: temporary file, then rename).
void write_file_atomically(const std::string& path, const std::string& bytes);

/// The whole content of a file. Throws InputError naming the path if it cannot be read.
std::string read_whole_file(const std::string& path);

}  // namespace potmap::detail
