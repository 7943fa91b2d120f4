// PCD and PLY point-cloud frames, parsed by PCL's io module; this file alone sees PCL's headers,
// so the rest of the build does not pay for them.
#include <pcl/PCLPointCloud2.h>
#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <vector>

#include "data/file_bytes.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

bool ends_with(const std::string& s, const std::string& e) {
  return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), ::tolower);
  return s;
}

const char* type_name(std::uint8_t t) {
  switch (t) {
    case pcl::PCLPointField::INT8:
      return "int8";
    case pcl::PCLPointField::UINT8:
      return "uint8";
    case pcl::PCLPointField::INT16:
      return "int16";
    case pcl::PCLPointField::UINT16:
      return "uint16";
    case pcl::PCLPointField::INT32:
      return "int32";
    case pcl::PCLPointField::UINT32:
      return "uint32";
    case pcl::PCLPointField::FLOAT32:
      return "float32";
    case pcl::PCLPointField::FLOAT64:
      return "float64";
    default:
      return "unknown";
  }
}

std::string field_list(const pcl::PCLPointCloud2& c) {
  std::string s;
  for (const auto& f : c.fields) s += (s.empty() ? "" : " ") + f.name;
  return s.empty() ? "none" : s;
}

// PCL reports why a read failed only on its console; potmap says it in the exception instead,
// so PCL is kept quiet while potmap reads (and set back after, for a host program using PCL).
class QuietPcl {
 public:
  QuietPcl() : lock_(mutex()), saved_(pcl::console::getVerbosityLevel()) {
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  }
  ~QuietPcl() { pcl::console::setVerbosityLevel(saved_); }

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  std::lock_guard<std::mutex> lock_;
  pcl::console::VERBOSITY_LEVEL saved_;
};

// PCL's header readers size the cloud's buffer from the header's point count before looking
// at the body, so a header claiming 10^18 points exhausts memory inside PCL. Read the counts
// ourselves first and refuse any that the file cannot hold: every encoding stores a point in at
// least one byte per field (ASCII: a digit and a separator; LZF-compressed PCD: at most about
// 1:100, taken as the bound), so a point count above 100 x the file size is never genuine.
void check_point_count(const std::string& path, bool ply) {
  std::error_code ec;
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  if (ec) return;  // PCL reports the unreadable file
  std::ifstream f(path, std::ios::binary);
  std::string line;
  std::uint64_t claimed = 0;
  for (int n = 0; n < 200 && std::getline(f, line); ++n) {
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    std::string value;
    if (!ply && (key == "POINTS" || key == "WIDTH" || key == "HEIGHT")) {
      ls >> value;
    } else if (ply && key == "element") {
      std::string name;
      ls >> name >> value;
    } else if ((!ply && key == "DATA") || (ply && key == "end_header")) {
      break;
    } else {
      continue;
    }
    errno = 0;
    char* end = nullptr;
    const unsigned long long v = std::strtoull(value.c_str(), &end, 10);
    if (value.empty() || *end != '\0' || errno == ERANGE || value[0] == '-')
      throw InputError(path + ": header line " + std::to_string(n + 1) + ": " + key + " '" + value +
                       "' is not a count");
    claimed = std::max<std::uint64_t>(claimed, v);
  }
  const std::uint64_t bound = 100 * size + 1024;
  if (claimed > bound)
    throw InputError(path + ": header: " + std::to_string(claimed) +
                     " points (or rows) in a file of " + std::to_string(size) +
                     " bytes, more than any encoding holds");
}

// PCL's PCD header parser trusts its input: inconsistent lines (a FIELDS line longer than its
// SIZE line, found by fuzz_point_cloud) make it throw or write past its buffers. So the header
// must be the one the PCD format describes before PCL reads it: the known keywords in order,
// FIELDS, SIZE, TYPE and COUNT of one length, sizes 1/2/4/8 with types F/I/U, counts >= 1,
// POINTS = WIDTH x HEIGHT, DATA ascii, binary or binary_compressed.
void check_pcd_header(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::string line;
  std::vector<std::string> fields, sizes, types, counts;
  unsigned long long width = 0, height = 0, points = 0;
  bool have_width = false, have_height = false, have_points = false;
  auto fail = [&](int n, const std::string& what) {
    throw InputError(path + ": header line " + std::to_string(n) + ": " + what);
  };
  auto count = [&](int n, const std::string& key, std::istringstream& ls) {
    std::string v;
    ls >> v;
    errno = 0;
    char* end = nullptr;
    const unsigned long long x = std::strtoull(v.c_str(), &end, 10);
    if (v.empty() || *end != '\0' || errno == ERANGE || v[0] == '-')
      fail(n, key + " '" + v + "' is not a count");
    return x;
  };
  for (int n = 1; n <= 200 && std::getline(f, line); ++n) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string key, item;
    ls >> key;
    std::vector<std::string> rest;
    if (key == "VERSION" || key == "VIEWPOINT") continue;
    if (key == "FIELDS" || key == "SIZE" || key == "TYPE" || key == "COUNT") {
      while (ls >> item) rest.push_back(item);
      (key == "FIELDS" ? fields : key == "SIZE" ? sizes : key == "TYPE" ? types : counts) = rest;
    } else if (key == "WIDTH") {
      width = count(n, key, ls), have_width = true;
    } else if (key == "HEIGHT") {
      height = count(n, key, ls), have_height = true;
    } else if (key == "POINTS") {
      points = count(n, key, ls), have_points = true;
    } else if (key == "DATA") {
      ls >> item;
      if (item != "ascii" && item != "binary" && item != "binary_compressed")
        fail(n, "DATA '" + item + "' is not ascii, binary or binary_compressed");
      if (fields.empty() || sizes.size() != fields.size() || types.size() != fields.size() ||
          (!counts.empty() && counts.size() != fields.size()))
        fail(n, std::to_string(fields.size()) + " FIELDS, " + std::to_string(sizes.size()) +
                    " SIZE, " + std::to_string(types.size()) + " TYPE and " +
                    std::to_string(counts.size()) + " COUNT entries: they must match");
      for (std::size_t i = 0; i < fields.size(); ++i) {
        const std::string& z = sizes[i];
        const std::string& t = types[i];
        if (z != "1" && z != "2" && z != "4" && z != "8")
          fail(n, "field '" + fields[i] + "' has SIZE '" + z + "', not 1, 2, 4 or 8");
        if (t != "F" && t != "I" && t != "U")
          fail(n, "field '" + fields[i] + "' has TYPE '" + t + "', not F, I or U");
        if (t == "F" && z != "4" && z != "8")
          fail(n, "field '" + fields[i] + "' is a float of " + z + " bytes");
        if (!counts.empty()) {
          std::istringstream cs(counts[i]);
          const unsigned long long c = count(n, "COUNT", cs);
          if (c < 1 || c > 1000000) fail(n, "field '" + fields[i] + "' has COUNT " + counts[i]);
        }
      }
      if (!have_width || !have_height) fail(n, "WIDTH and HEIGHT must come before DATA");
      if (height != 0 && width > ~0ull / height) fail(n, "WIDTH x HEIGHT overflows");
      if (have_points && points != width * height)
        fail(n, "POINTS " + std::to_string(points) + " is not WIDTH x HEIGHT " +
                    std::to_string(width * height));
      return;
    } else {
      fail(n, "'" + key.substr(0, 40) + "' is not a PCD header keyword");
    }
  }
  throw InputError(path + ": header: no DATA line in the first 200 lines: not a PCD file");
}

// The header alone: its fields, point count and where the data begin, so that a truncated
// binary body is named with the sizes involved rather than as PCL's bare -1.
void check_header(const std::string& path, bool ply) {
  pcl::PCLPointCloud2 head;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0, data_type = 0;
  unsigned int data_idx = 0;
  int rc = 0;
  if (ply) {
    pcl::PLYReader r;
    rc = r.readHeader(path, head, origin, orientation, version, data_type, data_idx);
  } else {
    pcl::PCDReader r;
    rc = r.readHeader(path, head, origin, orientation, version, data_type, data_idx);
  }
  // PCL's PLY reader parses the whole file to read its header, so a short body fails here.
  if (rc < 0 && ply) {
    std::error_code ec;
    throw InputError(path + ": not a readable PLY file of " +
                     std::to_string(std::filesystem::file_size(path, ec)) +
                     " bytes: a malformed header, a body shorter than its header's element "
                     "counts (truncated) or a value that is not a number (PCL's reader returned " +
                     std::to_string(rc) + ")");
  }
  if (rc < 0)
    throw InputError(path + ": byte 0: not a readable PCD header (PCL's reader returned " +
                     std::to_string(rc) + ")");
  for (const char* axis : {"x", "y", "z"}) {
    auto it = std::find_if(head.fields.begin(), head.fields.end(),
                           [&](const pcl::PCLPointField& f) { return f.name == axis; });
    if (it == head.fields.end())
      throw InputError(path + ": header: no field '" + axis + "' (fields: " + field_list(head) +
                       "); potmap needs x, y and z");
    if (it->datatype != pcl::PCLPointField::FLOAT32 && it->datatype != pcl::PCLPointField::FLOAT64)
      throw InputError(path + ": header: field '" + axis + "' is " + type_name(it->datatype) +
                       ", not float32 or float64");
  }
  const std::uint64_t points = std::uint64_t(head.width) * head.height;
  if (points == 0)
    throw InputError(path + ": header: the cloud holds no points (width " +
                     std::to_string(head.width) + ", height " + std::to_string(head.height) + ")");
  // Binary bodies have a fixed size: a shorter file lost its tail. (ASCII bodies are checked
  // by PCL's count of the points it read; compressed ones by their own length field.)
  if (data_type == 1) {
    const std::uint64_t need = data_idx + points * head.point_step;
    std::error_code ec;
    const std::uint64_t have = std::filesystem::file_size(path, ec);
    if (!ec && have < need)
      throw InputError(path + ": byte " + std::to_string(have) + ": truncated: the header's " +
                       std::to_string(points) + " points of " + std::to_string(head.point_step) +
                       " bytes from byte " + std::to_string(data_idx) + " need " +
                       std::to_string(need) + " bytes");
  }
}

double read_value(const std::uint8_t* p, std::uint8_t type) {
  if (type == pcl::PCLPointField::FLOAT64) {
    double d;
    std::memcpy(&d, p, sizeof d);
    return d;
  }
  float f;
  std::memcpy(&f, p, sizeof f);
  return f;
}

}  // namespace

Scan read_point_cloud(const std::string& path, double max_range, std::size_t* dropped) {
  if (!std::filesystem::is_regular_file(path))
    throw InputError(path + ": no such point-cloud file");
  const std::string l = lower(path);
  const bool ply = ends_with(l, ".ply");
  if (!ply && !ends_with(l, ".pcd")) throw InputError(path + ": not a .pcd or .ply file name");
  pcl::PCLPointCloud2 cloud;
  Eigen::Vector4f origin = Eigen::Vector4f::Zero();
  Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
  {
    QuietPcl quiet;
    int version = 0, rc = 0;
    // PCL's readers throw standard exceptions on some malformed headers (std::out_of_range on a
    // FIELDS line shorter than its SIZE line, found by fuzz_point_cloud): they become InputError.
    try {
      check_point_count(path, ply);
      if (!ply) check_pcd_header(path);
      check_header(path, ply);
      if (ply) {
        pcl::PLYReader r;
        rc = r.read(path, cloud, origin, orientation, version);
      } else {
        pcl::PCDReader r;
        rc = r.read(path, cloud, origin, orientation, version);
      }
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      throw InputError(path + ": malformed " + (ply ? "PLY" : "PCD") + " file (PCL: " + e.what() +
                       ")");
    }
    if (rc < 0)
      throw InputError(path + ": malformed or truncated " + std::string(ply ? "PLY" : "PCD") +
                       " body (fewer points than the header's " +
                       std::to_string(std::uint64_t(cloud.width) * cloud.height) +
                       ", or a value that is not a number; PCL's reader returned " +
                       std::to_string(rc) + ")");
  }
  const std::uint64_t points = std::uint64_t(cloud.width) * cloud.height;
  if (points == 0) throw InputError(path + ": the cloud holds no points");
  std::uint32_t off[3];
  std::uint8_t type[3];
  const char* axes[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    auto it = std::find_if(cloud.fields.begin(), cloud.fields.end(),
                           [&](const pcl::PCLPointField& f) { return f.name == axes[a]; });
    if (it == cloud.fields.end() || (it->datatype != pcl::PCLPointField::FLOAT32 &&
                                     it->datatype != pcl::PCLPointField::FLOAT64))
      throw InputError(path + ": no float field '" + axes[a] + "' (fields: " + field_list(cloud) +
                       ")");
    off[a] = it->offset;
    type[a] = it->datatype;
    const std::uint32_t size = type[a] == pcl::PCLPointField::FLOAT64 ? 8 : 4;
    if (std::uint64_t(off[a]) + size > cloud.point_step)
      throw InputError(path + ": field '" + axes[a] + "' at byte " + std::to_string(off[a]) +
                       " lies outside the " + std::to_string(cloud.point_step) + "-byte point");
  }
  if (cloud.data.size() < points * cloud.point_step)
    throw InputError(path + ": truncated: " + std::to_string(cloud.data.size()) +
                     " bytes of data for " + std::to_string(points) + " points of " +
                     std::to_string(cloud.point_step) + " bytes");
  Scan sc;
  sc.dim = 3;
  sc.max_range = max_range;
  sc.hits.reserve(3 * points);
  std::size_t drop = 0;
  // Organised clouds (height > 1) mark missing returns as NaN points: dropped and counted, as
  // every reader drops non-finite points at the door.
  for (std::uint64_t i = 0; i < points; ++i) {
    const std::uint8_t* p = cloud.data.data() + i * cloud.point_step;
    const double x = read_value(p + off[0], type[0]), y = read_value(p + off[1], type[1]),
                 z = read_value(p + off[2], type[2]);
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
      ++drop;
      continue;
    }
    sc.hits.insert(sc.hits.end(), {x, y, z});
  }
  if (sc.hits.empty())
    throw InputError(path + ": all " + std::to_string(points) +
                     " points are NaN or Inf: no point to map");
  // PCL's viewpoint is the sensor's pose in the cloud's frame (identity unless the writer set
  // it): the points stay as stored and the scan's origin is the sensor's.
  const Eigen::Matrix3f R = orientation.normalized().toRotationMatrix();
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) sc.pose3d[r * 4 + k] = R(r, k);
    sc.pose3d[r * 4 + 3] = origin[r];
  }
  if (dropped) *dropped = drop;
  return sc;
}

bool is_point_cloud_poses(const std::string& path) {
  std::istringstream in(data::read_file_bytes(path));
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    std::string first;
    if (!(ss >> first) || first[0] == '#') continue;
    const std::string l = lower(first);
    return ends_with(l, ".pcd") || ends_with(l, ".ply");
  }
  return false;
}

Dataset read_point_cloud_sequence(const std::string& poses_path, double max_range) {
  const std::filesystem::path dir = std::filesystem::path(poses_path).parent_path();
  std::istringstream in(data::read_file_bytes(poses_path));
  Dataset ds;
  std::string text;
  std::size_t line = 0;
  while (std::getline(in, text)) {
    ++line;
    std::istringstream ss(text);
    std::string frame;
    if (!(ss >> frame) || frame[0] == '#') continue;
    const std::string where = poses_path + ": line " + std::to_string(line);
    std::array<double, 12> pose{};
    for (int k = 0; k < 12; ++k) {
      std::string tok;
      if (!(ss >> tok))
        throw InputError(where + ": expected a frame and 12 numbers (3 x 4 [R | t]), got " +
                         std::to_string(k) + " numbers");
      char* e = nullptr;
      pose[k] = std::strtod(tok.c_str(), &e);
      if (e == tok.c_str() || *e != '\0' || !std::isfinite(pose[k]))
        throw InputError(where + ": bad pose value: '" + tok + "'");
    }
    std::string extra;
    if (ss >> extra) throw InputError(where + ": more than 12 numbers: '" + extra + "'");
    std::filesystem::path fp(frame);
    if (fp.is_relative()) fp = dir / fp;
    if (!data::file_exists(fp.string(), where))
      throw InputError(where + ": no frame " + fp.string());
    std::size_t dropped = 0;
    Scan scan = read_point_cloud(fp.string(), max_range, &dropped);
    apply_pose(scan, pose);
    scan.timestamp = static_cast<double>(ds.scans.size());
    ds.stats.points_dropped += dropped;
    ds.scans.push_back(std::move(scan));
  }
  if (ds.scans.empty())
    throw InputError(poses_path + ": line " + std::to_string(line) +
                     ": no frame listed (lines: FRAME.pcd|ply + 12 numbers)");
  return ds;
}

}  // namespace potmap
