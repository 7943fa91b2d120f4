#pragma once
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace potmap::detail {

// 64-bit FNV-1a. Used for cache keys only; the disk cache stores the full key next to the binary
// and compares it on load, so a collision costs a rebuild, never a wrong program.
inline std::uint64_t fnv1a64(std::string_view s, std::uint64_t h = 14695981039346656037ull) {
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

/// A hash as 16 hex digits, for messages and file names.
inline std::string hex64(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

}  // namespace potmap::detail
