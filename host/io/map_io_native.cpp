// The native binary map format (layout: include/potmap/io/map_io.hpp).
#include "io/map_io_native.hpp"

#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>

#include "io/container.hpp"
#include "io/text_io.hpp"
#include "map/map_checks.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"

namespace potmap {

namespace {

using detail::MapField;

constexpr std::size_t kHeaderBytes = 48;
constexpr std::size_t kCrcBytes = 4;
// No size field: the size follows from the dimension and the kernel count (version 2: and the
// section's length, after the kernels). A map without a section is written as version 1, as
// before, so that older readers still read it.
constexpr detail::ContainerLayout kLayout{"POTMAP\r\n", "a potmap map", 1, kHeaderBytes};
constexpr detail::ContainerLayout kLayoutV2{
    "POTMAP\r\n", "a potmap map", 2, kHeaderBytes, detail::ContainerLayout::kNoSizeField, 1};
constexpr std::uint32_t kHasBias = 1, kHasSection = 2, kHasCutoff = 4;

bool has_cutoff(const KernelMap& map) {
  return std::isfinite(map.cutoff_tau);
}

std::size_t map_bytes(const KernelMap& map) {
  return kHeaderBytes + map.size() * 8 * (map.dim + 3) + (has_cutoff(map) ? 8 : 0) + kCrcBytes;
}

void put_map(detail::ContainerWriter& out, const KernelMap& map, std::uint32_t flags) {
  out.u32(static_cast<std::uint32_t>(map.dim));
  out.u64(map.size());
  out.u32((map.has_bias ? kHasBias : 0u) | (has_cutoff(map) ? kHasCutoff : 0u) | flags);
  out.u32(0);
  out.f64(map.has_bias ? map.bias_mean : 0.0);
  out.f64(map.has_bias ? map.bias_var : 0.0);
  out.f64s(map.position);
  out.f64s(map.gamma);
  out.f64s(map.w_mean);
  out.f64s(map.w_var);
  if (has_cutoff(map)) out.f64(map.cutoff_tau);
}

}  // namespace

const detail::ContainerLayout& detail::native_map_layout() {
  return kLayoutV2;
}

KernelMap read_map_native(const std::string& path) {
  const detail::ContainerReader r(path, kLayoutV2);
  return detail::read_map_native_from(r, nullptr);
}

KernelMap detail::read_map_native_from(const ContainerReader& r, std::size_t* section_at) {
  const std::uint32_t version = r.version();
  const std::uint32_t dim = r.u32(12);
  if (dim != 2 && dim != 3) r.fail(12, "dimension " + std::to_string(dim) + " (must be 2 or 3)");
  const std::uint64_t count = r.u64(16);
  // The count decides how much is read: check it against the file size before trusting it.
  const std::uint64_t per_kernel = 8ull * (dim + 3);
  const std::uint64_t max_count = (std::numeric_limits<std::uint64_t>::max() - 64) / per_kernel;
  const std::uint32_t flags = r.u32(24);
  const std::uint32_t known = version >= 2 ? kHasBias | kHasSection | kHasCutoff : kHasBias;
  if (flags & ~known)
    r.fail(24, "unknown flags " + std::to_string(flags) + " in a version " +
                   std::to_string(version) + " map");
  // The kernels, and the cut-off after them where there is one.
  const std::uint64_t cutoff_bytes = flags & kHasCutoff ? 8 : 0;
  const std::uint64_t kernels_end =
      count <= max_count ? kHeaderBytes + count * per_kernel + cutoff_bytes : 0;
  std::uint64_t section = 0;
  if ((flags & kHasSection) && kernels_end && kernels_end + 8 + kCrcBytes <= r.size()) {
    section = r.u64(kernels_end);
    if (section > r.size()) section = r.size();  // check_size() below names it
  }
  const std::uint64_t expected = !kernels_end ? 0
                                 : (flags & kHasSection) == 0
                                     ? kernels_end + kCrcBytes
                                     : kernels_end + 8 + section + kCrcBytes;
  r.check_size(expected, 16,
               "kernel count " + std::to_string(count) + " in " + std::to_string(dim) + "D" +
                   (flags & kHasSection ? " and a section of " + std::to_string(section) + " bytes"
                                        : std::string()) +
                   " need a file of");
  r.check_checksum();
  if (section_at) *section_at = flags & kHasSection ? kernels_end + 8 : 0;
  const std::uint32_t reserved = r.u32(28);
  if (reserved != 0) r.fail(28, "reserved field is " + std::to_string(reserved) + ", not 0");

  KernelMap map;
  map.dim = static_cast<int>(dim);
  map.has_bias = flags & 1;
  map.bias_mean = r.f64(32);
  map.bias_var = r.f64(40);
  auto check = [&](MapField f, double v, std::size_t at, const std::string& name) {
    if (const char* why = detail::map_value_problem(f, v))
      r.fail(at, name + " = " + detail::format_double(v) + ": " + why);
  };
  if (flags & kHasCutoff) {
    const std::size_t at = kernels_end - 8;
    map.cutoff_tau = r.f64(at);
    check(MapField::cutoff_tau, map.cutoff_tau, at, "cut-off exponent");
  }
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
    map.position[i] = r.f64(pos_at + 8 * i);
    check(MapField::position, map.position[i], pos_at + 8 * i,
          "kernel " + std::to_string(i / dim) + " position[" + std::to_string(i % dim) + "]");
  }
  for (std::size_t i = 0; i < m; ++i) {
    map.gamma[i] = r.f64(gamma_at + 8 * i);
    check(MapField::gamma, map.gamma[i], gamma_at + 8 * i,
          "kernel " + std::to_string(i) + " gamma");
    map.w_mean[i] = r.f64(mean_at + 8 * i);
    check(MapField::w_mean, map.w_mean[i], mean_at + 8 * i,
          "kernel " + std::to_string(i) + " w_mean");
    map.w_var[i] = r.f64(var_at + 8 * i);
    check(MapField::w_var, map.w_var[i], var_at + 8 * i, "kernel " + std::to_string(i) + " w_var");
  }
  return map;
}

void write_map_native(const KernelMap& map, const std::string& path) {
  map.validate(path);
  // Version 1 where it says all; a cut-off needs version 2's flag.
  detail::ContainerWriter out(has_cutoff(map) ? kLayoutV2 : kLayout, map_bytes(map));
  put_map(out, map, 0);
  out.finish(path);
}

void detail::write_map_native_with_section(const KernelMap& map, const std::string& path,
                                           const std::function<void(ContainerWriter&)>& section) {
  map.validate(path);
  detail::ContainerWriter out(kLayoutV2, map_bytes(map));
  put_map(out, map, kHasSection);
  const std::size_t length_at = out.size();
  out.u64(0);
  section(out);
  out.patch_u64(length_at, out.size() - length_at - 8);
  out.finish(path);
}

bool detail::has_potmap_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".potmap";
}

void detail::check_potmap_name(const std::string& path, const char* what) {
  if (!has_potmap_extension(path))
    throw ArgumentError(path + ": " + what + " goes into a .potmap file, not '" +
                        std::filesystem::path(path).extension().string() + "'");
}

std::size_t detail::map_section_of(const ContainerReader& r) {
  std::size_t at = 0;
  read_map_native_from(r, &at);
  return at;
}

}  // namespace potmap
