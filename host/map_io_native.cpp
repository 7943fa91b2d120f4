// The native binary map format (layout: include/potmap/map_io.hpp).
#include <cstring>
#include <limits>
#include <sstream>

#include "file_util.hpp"
#include "le_bytes.hpp"
#include "map_checks.hpp"
#include "potmap/error.hpp"
#include "potmap/map_io.hpp"
#include "text_io.hpp"

namespace potmap {

namespace {

using detail::MapField;

constexpr char kMagic[8] = {'P', 'O', 'T', 'M', 'A', 'P', '\r', '\n'};
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kHeaderBytes = 48;
constexpr std::size_t kCrcBytes = 4;

using detail::get_f64;
using detail::get_le;
using detail::put_f64;
using detail::put_u32;
using detail::put_u64;

[[noreturn]] void fail_at(const std::string& path, std::size_t offset, const std::string& what) {
  throw InputError(path + ": byte offset " + std::to_string(offset) + ": " + what);
}

}  // namespace

KernelMap read_map_native(const std::string& path) {
  const std::string bytes = detail::read_whole_file(path);
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::size_t size = bytes.size();
  if (size < sizeof kMagic && std::memcmp(b, kMagic, size) == 0)
    fail_at(path, size, "truncated: " + std::to_string(size) + " bytes");
  if (size < sizeof kMagic || std::memcmp(b, kMagic, sizeof kMagic) != 0)
    fail_at(path, 0,
            "not a potmap map: magic " +
                detail::quote_value(std::string_view(bytes).substr(0, sizeof kMagic)) +
                " (expected 'POTMAP\\r\\n')");
  if (size < kHeaderBytes + kCrcBytes)
    fail_at(path, size,
            "truncated: " + std::to_string(size) + " bytes, the header alone needs " +
                std::to_string(kHeaderBytes + kCrcBytes));
  const std::uint32_t version = static_cast<std::uint32_t>(get_le(b + 8, 4));
  if (version != kVersion)
    fail_at(path, 8,
            "unsupported format version " + std::to_string(version) +
                " (this build reads version " + std::to_string(kVersion) + ")");
  const std::uint32_t dim = static_cast<std::uint32_t>(get_le(b + 12, 4));
  if (dim != 2 && dim != 3)
    fail_at(path, 12, "dimension " + std::to_string(dim) + " (must be 2 or 3)");
  const std::uint64_t count = get_le(b + 16, 8);
  // The count decides how much is read: check it against the file size before trusting it.
  const std::uint64_t per_kernel = 8ull * (dim + 3);
  const std::uint64_t max_count = (std::numeric_limits<std::uint64_t>::max() - 64) / per_kernel;
  const std::uint64_t expected =
      count <= max_count ? kHeaderBytes + count * per_kernel + kCrcBytes : 0;
  if (expected == 0 || expected != size) {
    std::ostringstream m;
    m << "kernel count " << count << " in " << dim << "D needs a file of "
      << (expected ? std::to_string(expected) : std::string("more than 2^64"))
      << " bytes, the file has " << size << (expected > size || !expected ? " (truncated)" : "");
    fail_at(path, 16, m.str());
  }
  const std::size_t crc_at = size - kCrcBytes;
  const std::uint32_t stored = static_cast<std::uint32_t>(get_le(b + crc_at, 4));
  const std::uint32_t actual = detail::crc32_of(b, crc_at);
  if (stored != actual) {
    char m[128];
    std::snprintf(m, sizeof m,
                  "checksum mismatch: stored CRC-32 %08x, computed %08x (corrupt file)", stored,
                  actual);
    fail_at(path, crc_at, m);
  }
  const std::uint32_t flags = static_cast<std::uint32_t>(get_le(b + 24, 4));
  if (flags > 1) fail_at(path, 24, "unknown flags " + std::to_string(flags));
  const std::uint32_t reserved = static_cast<std::uint32_t>(get_le(b + 28, 4));
  if (reserved != 0) fail_at(path, 28, "reserved field is " + std::to_string(reserved) + ", not 0");

  KernelMap map;
  map.dim = static_cast<int>(dim);
  map.has_bias = flags & 1;
  map.bias_mean = get_f64(b + 32);
  map.bias_var = get_f64(b + 40);
  auto check = [&](MapField f, double v, std::size_t at, const std::string& name) {
    if (const char* why = detail::map_value_problem(f, v))
      fail_at(path, at, name + " = " + detail::format_double(v) + ": " + why);
  };
  if (map.has_bias) {
    check(MapField::bias_mean, map.bias_mean, 32, "bias mean");
    check(MapField::bias_var, map.bias_var, 40, "bias variance");
  }
  const std::size_t m = static_cast<std::size_t>(count);
  const std::size_t pos_at = kHeaderBytes;
  const std::size_t gamma_at = pos_at + 8 * m * dim;
  const std::size_t mean_at = gamma_at + 8 * m;
  const std::size_t var_at = mean_at + 8 * m;
  map.position.resize(m * dim);
  map.gamma.resize(m);
  map.w_mean.resize(m);
  map.w_var.resize(m);
  for (std::size_t i = 0; i < m * dim; ++i) {
    map.position[i] = get_f64(b + pos_at + 8 * i);
    check(MapField::position, map.position[i], pos_at + 8 * i,
          "kernel " + std::to_string(i / dim) + " position[" + std::to_string(i % dim) + "]");
  }
  for (std::size_t i = 0; i < m; ++i) {
    map.gamma[i] = get_f64(b + gamma_at + 8 * i);
    check(MapField::gamma, map.gamma[i], gamma_at + 8 * i,
          "kernel " + std::to_string(i) + " gamma");
    map.w_mean[i] = get_f64(b + mean_at + 8 * i);
    check(MapField::w_mean, map.w_mean[i], mean_at + 8 * i,
          "kernel " + std::to_string(i) + " w_mean");
    map.w_var[i] = get_f64(b + var_at + 8 * i);
    check(MapField::w_var, map.w_var[i], var_at + 8 * i, "kernel " + std::to_string(i) + " w_var");
  }
  return map;
}

void write_map_native(const KernelMap& map, const std::string& path) {
  map.validate(path);
  std::string out(kMagic, sizeof kMagic);
  out.reserve(kHeaderBytes + map.size() * 8 * (map.dim + 3) + kCrcBytes);
  put_u32(out, kVersion);
  put_u32(out, static_cast<std::uint32_t>(map.dim));
  put_u64(out, map.size());
  put_u32(out, map.has_bias ? 1u : 0u);
  put_u32(out, 0);
  put_f64(out, map.has_bias ? map.bias_mean : 0.0);
  put_f64(out, map.has_bias ? map.bias_var : 0.0);
  for (double v : map.position) put_f64(out, v);
  for (double v : map.gamma) put_f64(out, v);
  for (double v : map.w_mean) put_f64(out, v);
  for (double v : map.w_var) put_f64(out, v);
  put_u32(out, detail::crc32_of(reinterpret_cast<const unsigned char*>(out.data()), out.size()));
  detail::write_file_atomically(path, out);
}

}  // namespace potmap
