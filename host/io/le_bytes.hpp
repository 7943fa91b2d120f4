#pragma once
// Little-endian encoding and the CRC-32 of the native binary container (io/container.hpp), so
// that every native file writes and checks bytes the same way on every platform.

#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>

namespace potmap::detail {

inline void put_u32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out += static_cast<char>((v >> (8 * i)) & 0xff);
}
inline void put_u64(std::string& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out += static_cast<char>((v >> (8 * i)) & 0xff);
}
inline void put_f64(std::string& out, double d) {
  std::uint64_t v;
  std::memcpy(&v, &d, 8);
  put_u64(out, v);
}

inline void put_f32(std::string& out, float f) {
  std::uint32_t v;
  std::memcpy(&v, &f, 4);
  put_u32(out, v);
}

inline bool host_is_little_endian() {
  const std::uint32_t one = 1;
  unsigned char b;
  std::memcpy(&b, &one, 1);
  return b == 1;
}

/// n floats, little-endian: on a little-endian host (every platform potmap runs on today) the
/// bytes as they are, in one append; raster tiles carry millions of them.
inline void put_f32s(std::string& out, const float* v, std::size_t n) {
  if (host_is_little_endian()) {
    out.append(reinterpret_cast<const char*>(v), n * sizeof(float));
    return;
  }
  for (std::size_t i = 0; i < n; ++i) put_f32(out, v[i]);
}

/// n (<= 8) little-endian bytes at p as an unsigned integer.
inline std::uint64_t get_le(const unsigned char* p, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v |= std::uint64_t(p[i]) << (8 * i);
  return v;
}
inline double get_f64(const unsigned char* p) {
  const std::uint64_t v = get_le(p, 8);
  double d;
  std::memcpy(&d, &v, 8);
  return d;
}

inline float get_f32(const unsigned char* p) {
  const auto v = static_cast<std::uint32_t>(get_le(p, 4));
  float f;
  std::memcpy(&f, &v, 4);
  return f;
}

/// zlib's CRC-32 of n bytes.
inline std::uint32_t crc32_of(const unsigned char* p, std::size_t n) {
  uLong crc = crc32(0L, Z_NULL, 0);
  // zlib's length argument is a uInt: feed large payloads in pieces.
  while (n > 0) {
    const uInt chunk = static_cast<uInt>(std::min<std::size_t>(n, 1u << 30));
    crc = crc32(crc, p, chunk);
    p += chunk;
    n -= chunk;
  }
  return static_cast<std::uint32_t>(crc);
}

}  // namespace potmap::detail
