// map_server / nav2 occupancy maps: PGM image and YAML description (include/potmap/io/ros_map.hpp).
#include "potmap/io/ros_map.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <vector>

#include "io/atomic_file.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"  // GridSpec

namespace potmap {

namespace {

// The values map_saver writes, which its loader reads back as occupied, free and unknown.
constexpr std::uint8_t kOccupied = 0, kFree = 254, kUnknown = 205;

// Shortest text that reads back to the same double, for the YAML.
std::string number(double v) {
  char buf[32];
  for (int prec = 6; prec <= 17; ++prec) {
    std::snprintf(buf, sizeof buf, "%.*g", prec, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

void check(const RosMapOptions& o) {
  if (!(o.resolution > 0) || !std::isfinite(o.resolution))
    throw ArgumentError("ROS map: resolution " + number(o.resolution) + " m is not positive");
  if (!(o.free_thresh >= 0 && o.free_thresh < o.occupied_thresh && o.occupied_thresh <= 1))
    throw ArgumentError("ROS map: thresholds free " + number(o.free_thresh) + ", occupied " +
                        number(o.occupied_thresh) + " need 0 <= free < occupied <= 1");
}

bool auto_window(const RosMapOptions& o) {
  return o.xmin == 0 && o.xmax == 0 && o.ymin == 0 && o.ymax == 0;
}

GridSpec window(const KernelMap& map, const RosMapOptions& o) {
  double lo[3] = {o.xmin, o.ymin, o.z}, hi[3] = {o.xmax, o.ymax, o.z};
  if (auto_window(o)) {
    if (map.empty()) throw ArgumentError("ROS map: an empty map and no window");
    map.bounds(lo, hi);
    for (int d = 0; d < 2; ++d) {
      lo[d] -= o.margin;
      hi[d] += o.margin;
    }
  }
  if (!(hi[0] > lo[0]) || !(hi[1] > lo[1]))
    throw ArgumentError("ROS map: empty window x [" + number(lo[0]) + ", " + number(hi[0]) +
                        "], y [" + number(lo[1]) + ", " + number(hi[1]) + "]");
  GridSpec g = GridSpec::covering(2, lo, hi, o.resolution);
  if (g.count[0] > o.max_pixels || g.count[1] > o.max_pixels)
    throw ArgumentError("ROS map: " + std::to_string(g.count[0]) + " x " +
                        std::to_string(g.count[1]) + " pixels at " + number(o.resolution) +
                        " m is over the limit of " + std::to_string(o.max_pixels) +
                        " a side: raise the resolution or narrow the window");
  return g;
}

// Cell centres of a 2D grid at height z, as dim-coordinate points.
std::vector<double> cell_points(const GridSpec& g, int dim, double z) {
  std::vector<double> p;
  p.reserve(g.cells() * dim);
  for (std::size_t j = 0; j < g.count[1]; ++j)
    for (std::size_t i = 0; i < g.count[0]; ++i) {
      p.push_back(g.origin[0] + (i + 0.5) * g.resolution);
      p.push_back(g.origin[1] + (j + 0.5) * g.resolution);
      if (dim == 3) p.push_back(z);
    }
  return p;
}

}  // namespace

std::uint8_t ros_map_pixel(double prob, bool known, const RosMapOptions& o) {
  if (o.mode == RosMapMode::scale) {
    const double p = known ? prob : 0.5;
    return static_cast<std::uint8_t>(std::lround(255.0 * (1.0 - p)));
  }
  if (!known) return kUnknown;
  if (prob > o.occupied_thresh) return kOccupied;
  if (prob < o.free_thresh) return kFree;
  return kUnknown;
}

RosMapSummary write_ros_map(Context* ctx, const KernelMap& map, const std::string& yaml_path,
                            const RosMapOptions& o) {
  check(o);
  map.validate(yaml_path);
  const GridSpec g = window(map, o);
  const std::vector<double> pts = cell_points(g, map.dim, o.z);
  const KnownValues kv = known_values(ctx, map, pts, o.known);
  const double origin[2] = {g.origin[0], g.origin[1]};
  return write_ros_cells(kv.prob, kv.known, g.count[0], g.count[1], origin, yaml_path, o);
}

RosMapSummary write_ros_cells(const std::vector<double>& prob,
                              const std::vector<std::uint8_t>& known, std::size_t nx,
                              std::size_t ny, const double origin[2], const std::string& yaml_path,
                              const RosMapOptions& o) {
  check(o);
  if (prob.size() != nx * ny || known.size() != nx * ny || nx == 0 || ny == 0)
    throw ArgumentError("ROS map: " + std::to_string(prob.size()) + " probabilities and " +
                        std::to_string(known.size()) + " known flags for " + std::to_string(nx) +
                        " x " + std::to_string(ny) + " cells");
  // Cells [i0, i1) x [j0, j1) of the grid are written: all of a given window; without one,
  // the known cells' bounds widened by the margin (a persistent map's tiles reach far beyond
  // where the scans went).
  std::size_t i0 = 0, i1 = nx, j0 = 0, j1 = ny;
  if (auto_window(o)) {
    std::size_t a0 = nx, a1 = 0, b0 = ny, b1 = 0;
    for (std::size_t j = 0; j < ny; ++j)
      for (std::size_t i = 0; i < nx; ++i)
        if (known[i + nx * j]) {
          a0 = std::min(a0, i);
          a1 = std::max(a1, i + 1);
          b0 = std::min(b0, j);
          b1 = std::max(b1, j + 1);
        }
    if (a1 > a0) {
      const auto pad = static_cast<std::size_t>(std::ceil(o.margin / o.resolution));
      i0 = a0 > pad ? a0 - pad : 0;
      j0 = b0 > pad ? b0 - pad : 0;
      i1 = std::min(nx, a1 + pad);
      j1 = std::min(ny, b1 + pad);
    }
  }
  RosMapSummary s;
  s.width = i1 - i0;
  s.height = j1 - j0;
  s.origin[0] = origin[0] + double(i0) * o.resolution;
  s.origin[1] = origin[1] + double(j0) * o.resolution;
  s.yaml = yaml_path;
  s.pgm = std::filesystem::path(yaml_path).replace_extension(".pgm").string();
  // PGM rows run from the top of the picture: the window's largest y first.
  std::vector<std::uint8_t> image(s.width * s.height);
  for (std::size_t j = 0; j < s.height; ++j)
    for (std::size_t i = 0; i < s.width; ++i) {
      const std::size_t c = (i0 + i) + nx * (j0 + j);
      const std::uint8_t v = ros_map_pixel(prob[c], known[c] != 0, o);
      image[i + s.width * (s.height - 1 - j)] = v;
      const double occ = (255.0 - v) / 255.0;
      if (occ > o.occupied_thresh)
        ++s.occupied;
      else if (occ < o.free_thresh)
        ++s.free;
      else
        ++s.unknown;
    }

  detail::AtomicFile pgm(s.pgm);
  const std::string header = "P5\n# potmap occupancy map\n" + std::to_string(s.width) + " " +
                             std::to_string(s.height) + "\n255\n";
  pgm.write(header.data(), header.size());
  pgm.write(image.data(), image.size());

  std::ostringstream y;
  y << "image: " << std::filesystem::path(s.pgm).filename().string() << "\n"
    << "mode: " << (o.mode == RosMapMode::scale ? "scale" : "trinary") << "\n"
    << "resolution: " << number(o.resolution) << "\n"
    << "origin: [" << number(s.origin[0]) << ", " << number(s.origin[1]) << ", 0.0]\n"
    << "negate: 0\n"
    << "occupied_thresh: " << number(o.occupied_thresh) << "\n"
    << "free_thresh: " << number(o.free_thresh) << "\n";
  detail::AtomicFile yaml(yaml_path);
  const std::string text = y.str();
  yaml.write(text.data(), text.size());
  // Both synced before either is renamed: a full disk leaves the previous pair as it was. The
  // image first: a YAML never names a PGM that is not there.
  pgm.sync();
  yaml.sync();
  pgm.commit();
  yaml.commit();
  return s;
}

}  // namespace potmap
