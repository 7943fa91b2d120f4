// Choosing the map format from the file name.
#include <filesystem>

#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"

namespace potmap {

namespace {

enum class Format { csv, npz, native };

std::string lower_extension(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  for (char& c : e)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return e;
}

template <class E>
Format format_of(const std::string& path) {
  const std::string e = lower_extension(path);
  if (e == ".csv") return Format::csv;
  if (e == ".npz") return Format::npz;
  if (e == ".potmap") return Format::native;
  if (e == ".gz")
    throw E(path + ": compressed maps are not supported; decompress it first (gunzip)");
  throw E(path + ": unknown map format '" + e + "' (expected .csv, .npz or .potmap)");
}

}  // namespace

KernelMap read_map(const std::string& path) {
  switch (format_of<InputError>(path)) {
    case Format::csv:
      return read_map_csv(path);
    case Format::npz:
      return read_map_npz(path);
    case Format::native:
      break;
  }
  return read_map_native(path);
}

void write_map(const KernelMap& map, const std::string& path) {
  switch (format_of<ArgumentError>(path)) {
    case Format::csv:
      return write_map_csv(map, path);
    case Format::npz:
      return write_map_npz(map, path);
    case Format::native:
      break;
  }
  write_map_native(map, path);
}

}  // namespace potmap
