// KITTI and nuScenes LIDAR frames (float32 records) and KITTI odometry poses.
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "data/file_bytes.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

Scan read_float_records(const std::string& path, std::size_t fields, double max_range,
                        std::size_t* dropped) {
  const std::string bytes = data::read_file_bytes(path);
  const std::size_t rec = fields * sizeof(float);
  if (bytes.size() % rec != 0) {
    throw InputError(path + ": byte " + std::to_string(bytes.size() - bytes.size() % rec) +
                     ": file size " + std::to_string(bytes.size()) + " is not a multiple of " +
                     std::to_string(rec) + " bytes (" + std::to_string(fields) +
                     " float32 per point)");
  }
  const std::size_t n = bytes.size() / rec;
  Scan sc;
  sc.dim = 3;
  sc.max_range = max_range;
  sc.hits.reserve(3 * n);
  std::size_t drop = 0;
  for (std::size_t i = 0; i < n; ++i) {
    float v[3];
    std::memcpy(v, bytes.data() + i * rec, sizeof v);
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
      ++drop;
      continue;
    }
    sc.hits.push_back(v[0]);
    sc.hits.push_back(v[1]);
    sc.hits.push_back(v[2]);
  }
  if (dropped) *dropped = drop;
  return sc;
}

using M34 = std::array<double, 12>;

M34 parse_m34(const std::string& path, std::size_t line, std::istringstream& ss) {
  M34 m{};
  for (int k = 0; k < 12; ++k) {
    std::string tok;
    if (!(ss >> tok))
      throw InputError(path + ": line " + std::to_string(line) + ": expected 12 numbers, got " +
                       std::to_string(k) + ": '" + tok + "'");
    char* e = nullptr;
    m[k] = std::strtod(tok.c_str(), &e);
    if (e == tok.c_str() || *e != '\0' || !std::isfinite(m[k]))
      throw InputError(path + ": line " + std::to_string(line) + ": bad pose value: '" + tok + "'");
  }
  return m;
}

M34 mul(const M34& a, const M34& b) {
  M34 c{};
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k)
      c[r * 4 + k] = a[r * 4] * b[k] + a[r * 4 + 1] * b[4 + k] + a[r * 4 + 2] * b[8 + k];
    c[r * 4 + 3] = a[r * 4] * b[3] + a[r * 4 + 1] * b[7] + a[r * 4 + 2] * b[11] + a[r * 4 + 3];
  }
  return c;
}

M34 rigid_inverse(const M34& a) {
  M34 c{};
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) c[r * 4 + k] = a[k * 4 + r];
  for (int r = 0; r < 3; ++r)
    c[r * 4 + 3] = -(c[r * 4] * a[3] + c[r * 4 + 1] * a[7] + c[r * 4 + 2] * a[11]);
  return c;
}

}  // namespace

std::array<double, 3> Scan::origin() const {
  if (dim == 3) return {pose3d[3], pose3d[7], pose3d[11]};
  return {pose2d[0], pose2d[1], 0};
}

Scan read_kitti_bin(const std::string& path, double max_range) {
  std::size_t d = 0;
  return read_float_records(path, 4, max_range, &d);
}

Scan read_nuscenes_bin(const std::string& path, double max_range) {
  std::size_t d = 0;
  return read_float_records(path, 5, max_range, &d);
}

Dataset read_velodyne_dataset(const std::string& path, std::size_t fields, double max_range) {
  Dataset ds;
  ds.scans.push_back(read_float_records(path, fields, max_range, &ds.stats.points_dropped));
  return ds;
}

void apply_pose(Scan& scan, const std::array<double, 12>& T) {
  if (scan.dim != 3) throw ArgumentError("apply_pose: scan is not 3D");
  auto xf = [&T](std::vector<double>& v, bool dir) {
    for (std::size_t i = 0; i + 2 < v.size(); i += 3) {
      const double x = v[i], y = v[i + 1], z = v[i + 2];
      for (int r = 0; r < 3; ++r)
        v[i + r] = T[r * 4] * x + T[r * 4 + 1] * y + T[r * 4 + 2] * z + (dir ? 0 : T[r * 4 + 3]);
    }
  };
  xf(scan.hits, false);
  xf(scan.no_return, true);
  scan.pose3d = mul(T, scan.pose3d);
}

std::vector<std::array<double, 12>> read_kitti_poses(const std::string& poses_path,
                                                     const std::string& calib_path) {
  M34 tr{};
  bool have_tr = false;
  {
    std::istringstream in(data::read_file_bytes(calib_path));
    std::string l;
    std::size_t line = 0;
    while (std::getline(in, l)) {
      ++line;
      if (l.rfind("Tr:", 0) != 0) continue;
      std::istringstream ss(l.substr(3));
      tr = parse_m34(calib_path, line, ss);
      have_tr = true;
    }
  }
  if (!have_tr) throw InputError(calib_path + ": line 0: no 'Tr:' line (velodyne to camera)");
  const M34 tr_inv = rigid_inverse(tr);
  std::vector<M34> out;
  std::istringstream in(data::read_file_bytes(poses_path));
  std::string l;
  std::size_t line = 0;
  while (std::getline(in, l)) {
    ++line;
    if (l.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream ss(l);
    const M34 p = parse_m34(poses_path, line, ss);
    std::string extra;
    if (ss >> extra)
      throw InputError(poses_path + ": line " + std::to_string(line) + ": more than 12 numbers: '" +
                       extra + "'");
    out.push_back(mul(tr_inv, mul(p, tr)));
  }
  return out;
}

}  // namespace potmap
