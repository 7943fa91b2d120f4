#pragma once
// Whole-file reads, transparently gunzipped when the file starts with the gzip magic bytes.
#include <string>

namespace potmap::data {
/// The file's bytes, decompressed if gzip. Throws InputError naming the file when unreadable or
/// when the gzip stream is corrupt.
std::string read_file_bytes(const std::string& path);
}  // namespace potmap::data
