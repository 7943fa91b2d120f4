#pragma once
// Whole-file reads, transparently gunzipped when the file starts with the gzip magic bytes, and
// the lookups of the files an input names.
#include <string>

namespace potmap::data {
/// The file's bytes, decompressed if gzip. Throws InputError naming the file when unreadable or
/// when the gzip stream is corrupt.
std::string read_file_bytes(const std::string& path);
/// Whether `path` (a file an input names) exists. A lookup the system refuses (a name too long,
/// a folder it may not search) is bad input, not a filesystem exception: InputError
/// "<where>: cannot look up <path>: <reason>".
bool file_exists(const std::string& path, const std::string& where);
}  // namespace potmap::data
