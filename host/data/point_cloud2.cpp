// sensor_msgs/PointCloud2's x, y, z out of its packed rows, for both ROS storages.
#include <cmath>
#include <cstring>
#include <string>

#include "data/bag_source.hpp"
#include "potmap/error.hpp"

namespace potmap::data {

namespace {

bool host_is_little_endian() {
  const std::uint16_t one = 1;
  std::uint8_t first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

template <typename T>
T load(const std::uint8_t* p, bool swap) {
  std::uint8_t b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (swap)
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

const PointFieldDesc& coordinate(const PointCloud2View& view, const char* name,
                                 const std::string& where) {
  for (const PointFieldDesc& f : view.fields) {
    if (f.name != name) continue;
    const auto type = static_cast<PointFieldType>(f.datatype);
    if (type != PointFieldType::float32 && type != PointFieldType::float64)
      throw InputError(where + ": PointCloud2 field '" + name + "' has datatype " +
                       std::to_string(f.datatype) +
                       "; x, y and z must be FLOAT32 (7) or FLOAT64 (8)");
    const std::uint32_t size = type == PointFieldType::float32 ? 4 : 8;
    if (static_cast<std::uint64_t>(f.offset) + size > view.point_step)
      throw InputError(where + ": PointCloud2 field '" + name + "' at offset " +
                       std::to_string(f.offset) + " runs past point_step " +
                       std::to_string(view.point_step));
    return f;
  }
  std::string names;
  for (const PointFieldDesc& f : view.fields) names += (names.empty() ? "" : ", ") + f.name;
  throw InputError(where + ": PointCloud2 has no field '" + name +
                   "' (fields: " + (names.empty() ? "none" : names) + ")");
}

double read_coordinate(const std::uint8_t* p, const PointFieldDesc& f, bool swap) {
  return static_cast<PointFieldType>(f.datatype) == PointFieldType::float32
             ? static_cast<double>(load<float>(p + f.offset, swap))
             : load<double>(p + f.offset, swap);
}

}  // namespace

void decode_point_cloud2(const PointCloud2View& view, const std::string& where, CloudMsg& cloud) {
  const PointFieldDesc& fx = coordinate(view, "x", where);
  const PointFieldDesc& fy = coordinate(view, "y", where);
  const PointFieldDesc& fz = coordinate(view, "z", where);
  const std::uint64_t row_bytes = static_cast<std::uint64_t>(view.width) * view.point_step;
  if (view.row_step < row_bytes)
    throw InputError(where + ": PointCloud2 row_step " + std::to_string(view.row_step) +
                     " is shorter than width x point_step = " + std::to_string(row_bytes));
  const std::uint64_t need = static_cast<std::uint64_t>(view.height) * view.row_step;
  if (view.size < need)
    throw InputError(where + ": PointCloud2 data holds " + std::to_string(view.size) +
                     " bytes, height x row_step needs " + std::to_string(need));
  const bool swap = view.is_bigendian == host_is_little_endian();
  cloud.xyz.clear();
  cloud.xyz.reserve(static_cast<std::size_t>(view.height) * view.width * 3);
  cloud.dropped = 0;
  for (std::uint32_t r = 0; r < view.height; ++r) {
    const std::uint8_t* row = view.data + static_cast<std::size_t>(r) * view.row_step;
    for (std::uint32_t c = 0; c < view.width; ++c) {
      const std::uint8_t* p = row + static_cast<std::size_t>(c) * view.point_step;
      const double x = read_coordinate(p, fx, swap), y = read_coordinate(p, fy, swap),
                   z = read_coordinate(p, fz, swap);
      // Drivers of organised clouds (Ouster's, Velodyne's) mark a missing return as NaN or as
      // the sensor's own origin; neither is a surface.
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z) ||
          (x == 0 && y == 0 && z == 0)) {
        ++cloud.dropped;
        continue;
      }
      cloud.xyz.push_back(static_cast<float>(x));
      cloud.xyz.push_back(static_cast<float>(y));
      cloud.xyz.push_back(static_cast<float>(z));
    }
  }
}

}  // namespace potmap::data
