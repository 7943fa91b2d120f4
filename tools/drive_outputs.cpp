#include "drive_outputs.hpp"

#include <octomap/OcTree.h>

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "potmap/map/evaluate.hpp"
#include "potmap/map/height_band.hpp"

#include "drive_band_picture.hpp"
#include "potmap/error.hpp"
#include "potmap/io/ros_map.hpp"
#include "progress.hpp"

namespace potmap::cli {

namespace {

constexpr double kBlock = 8.0;      // metres: the joint BHM's 3D tile at 1 m kernels
constexpr std::size_t kBatch = 16;  // blocks evaluated at once (about a million voxels)

using Block = std::array<long, 3>;

// The blocks holding a kernel, in raster order (z, y, x).
std::vector<Block> kernel_blocks(const KernelMap& map) {
  std::vector<Block> b;
  b.reserve(map.size() / 64 + 1);
  for (std::size_t k = 0; k < map.size(); ++k) {
    Block c;
    for (int d = 0; d < 3; ++d) c[d] = long(std::floor(map.position[3 * k + d] / kBlock));
    b.push_back({c[2], c[1], c[0]});
  }
  std::sort(b.begin(), b.end());
  b.erase(std::unique(b.begin(), b.end()), b.end());
  for (Block& c : b) std::swap(c[0], c[2]);  // back to x, y, z
  return b;
}

// The band raster: per cell the band's largest probability (-1: nothing known there) and the
// variance at that voxel.
struct Band {
  double origin[2] = {0, 0}, res = 0;
  std::size_t nx = 0, ny = 0;
  std::vector<float> prob, var;
  void add(double x, double y, double p, double v) {
    const long i = long(std::floor((x - origin[0]) / res)),
               j = long(std::floor((y - origin[1]) / res));
    if (i < 0 || j < 0 || std::size_t(i) >= nx || std::size_t(j) >= ny) return;
    const std::size_t c = std::size_t(i) + nx * std::size_t(j);
    keep_band_max(float(p), float(v), 0.0f, prob[c], var[c]);  // the raster's band rule
  }
};

// The sensor's height at (x, y): that of the nearest point of the path (the keyframes'
// positions joined in order), so the band follows a road that climbs without steps.
double path_height(const std::vector<double>& pos, double x, double y) {
  const std::size_t n = pos.size() / 3;
  double best = HUGE_VAL, z = n ? pos[2] : 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double* a = &pos[3 * i];
    const double* b = &pos[3 * std::min(i + 1, n - 1)];
    const double dx = b[0] - a[0], dy = b[1] - a[1], l2 = dx * dx + dy * dy;
    const double t = l2 > 0 ? std::clamp(((x - a[0]) * dx + (y - a[1]) * dy) / l2, 0.0, 1.0) : 0;
    const double px = a[0] + t * dx - x, py = a[1] + t * dy - y, d = px * px + py * py;
    if (d < best) {
      best = d;
      z = a[2] + t * (b[2] - a[2]);
    }
  }
  return z;
}

// path_height at the corners of the block columns, bilinear inside them: continuous across
// blocks, and one path search per corner rather than per voxel.
struct BandHeight {
  const std::vector<double>& pos;
  std::map<std::pair<long, long>, double> corner;
  double at_corner(long i, long j) {
    const auto it = corner.find({i, j});
    if (it != corner.end()) return it->second;
    return corner[{i, j}] = path_height(pos, double(i) * kBlock, double(j) * kBlock);
  }
  double operator()(double x, double y) {
    const long i = long(std::floor(x / kBlock)), j = long(std::floor(y / kBlock));
    const double u = x / kBlock - double(i), v = y / kBlock - double(j);
    return (1 - u) * (1 - v) * at_corner(i, j) + u * (1 - v) * at_corner(i + 1, j) +
           (1 - u) * v * at_corner(i, j + 1) + u * v * at_corner(i + 1, j + 1);
  }
};

// The occupied voxels as a binary PLY, streamed: records go to a temporary body file as they
// are found (their count is known only at the end), then header and body are joined into a
// temporary file renamed over `path`.
class PlyStream {
 public:
  explicit PlyStream(const std::string& path)
      : path_(path), body_(path + ".body-" + std::to_string(::getpid())) {
    out_.open(body_, std::ios::binary | std::ios::trunc);
    if (!out_) throw Error("cannot write " + body_);
  }
  ~PlyStream() {
    std::error_code ec;
    std::filesystem::remove(body_, ec);
  }
  void add(float x, float y, float z, float p, float v) {
    const float r[5] = {x, y, z, p, v};  // the hosts are little-endian
    out_.write(reinterpret_cast<const char*>(r), sizeof r);
    ++n_;
  }
  std::size_t size() const { return n_; }
  void finish() {
    out_.close();
    if (!out_) throw Error("cannot write " + body_);
    const std::string tmp = path_ + ".tmp-" + std::to_string(::getpid());
    {
      std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
      f << "ply\nformat binary_little_endian 1.0\ncomment potmap occupied voxels: probability "
           "and logit variance of the joint BHM\nelement vertex "
        << n_
        << "\nproperty float x\nproperty float y\nproperty float z\nproperty float "
           "probability\nproperty float variance\nend_header\n";
      std::ifstream in(body_, std::ios::binary);
      f << in.rdbuf();
      f.flush();
      if (!f) {
        std::error_code ec;
        std::filesystem::remove(tmp, ec);
        throw Error("cannot write " + path_ + " (disk full?)");
      }
    }
    std::filesystem::rename(tmp, path_);
  }

 private:
  std::string path_, body_;
  std::ofstream out_;
  std::size_t n_ = 0;
};

// Blocks grouped in columns of kGroup metres, each evaluated with the kernels within the
// evaluators' reach of it only: one evaluator over a whole drive's map would index the map's
// bounding box (gigabytes for a 2.4 km drive).
constexpr double kGroup = 32.0;
using Column = std::pair<long, long>;

std::map<Column, std::vector<std::size_t>> group_blocks(const std::vector<Block>& blocks) {
  std::map<Column, std::vector<std::size_t>> g;
  for (std::size_t b = 0; b < blocks.size(); ++b)
    g[{long(std::floor(blocks[b][0] * kBlock / kGroup)),
       long(std::floor(blocks[b][1] * kBlock / kGroup))}]
        .push_back(b);
  return g;
}

// The kernels of each column's local map: those within `reach` metres of its square.
std::map<Column, std::vector<std::uint32_t>> group_kernels(
    const KernelMap& map, const std::map<Column, std::vector<std::size_t>>& groups, double reach) {
  std::map<Column, std::vector<std::uint32_t>> g;
  for (std::size_t k = 0; k < map.size(); ++k) {
    const double x = map.position[3 * k], y = map.position[3 * k + 1];
    const long cx = long(std::floor(x / kGroup)), cy = long(std::floor(y / kGroup));
    for (long dy = -1; dy <= 1; ++dy)
      for (long dx = -1; dx <= 1; ++dx) {
        const Column c{cx + dx, cy + dy};
        if (!groups.count(c)) continue;
        const double gx = std::clamp(x, c.first * kGroup, (c.first + 1) * kGroup);
        const double gy = std::clamp(y, c.second * kGroup, (c.second + 1) * kGroup);
        if ((gx - x) * (gx - x) + (gy - y) * (gy - y) <= reach * reach)
          g[c].push_back(std::uint32_t(k));
      }
  }
  return g;
}

KernelMap subset(const KernelMap& map, const std::vector<std::uint32_t>& idx) {
  KernelMap m;
  m.dim = 3;
  m.reserve(idx.size());
  for (std::uint32_t k : idx)
    m.push_back(&map.position[3 * k], map.gamma[k], map.w_mean[k], map.w_var[k]);
  m.has_bias = map.has_bias;
  m.bias_mean = map.bias_mean;
  m.bias_var = map.bias_var;
  return m;
}

double kernel_reach(const KernelMap& map, double extra) {
  double gmin = HUGE_VAL;
  for (double g : map.gamma) gmin = std::min(gmin, g);
  return std::sqrt(kDefaultCutoffTau / gmin) + extra;
}

}  // namespace

std::vector<float> probability_by_columns(Context& ctx, const KernelMap& map,
                                          const std::vector<double>& points) {
  const std::size_t n = points.size() / 3;
  std::vector<float> prob(n, 0.5f);
  if (map.empty() || n == 0) return prob;
  std::map<Column, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < n; ++i)
    groups[{long(std::floor(points[3 * i] / kGroup)), long(std::floor(points[3 * i + 1] / kGroup))}]
        .push_back(i);
  auto kernels = group_kernels(map, groups, kernel_reach(map, 0.1));
  std::vector<double> pts;
  std::vector<float> p;
  for (const auto& [column, members] : groups) {
    const KernelMap local = subset(map, kernels[column]);
    kernels[column] = {};
    pts.clear();
    for (std::size_t i : members) pts.insert(pts.end(), &points[3 * i], &points[3 * i] + 3);
    p.assign(members.size(), 0.5f);
    if (!local.empty()) {
      MapEvaluator ev(ctx, local);
      ev.evaluate(pts.data(), members.size(), nullptr, nullptr, p.data());
    }
    for (std::size_t k = 0; k < members.size(); ++k) prob[members[k]] = p[k];
  }
  return prob;
}

namespace {

// The band raster over the blocks' x, y bounds at `res` metres.
Band make_band(const std::vector<Block>& blocks, double res) {
  Band band;
  band.res = res;
  double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
  for (const Block& b : blocks)
    for (int d = 0; d < 2; ++d) {
      lo[d] = std::min(lo[d], b[d] * kBlock);
      hi[d] = std::max(hi[d], (b[d] + 1) * kBlock);
    }
  band.origin[0] = lo[0];
  band.origin[1] = lo[1];
  band.nx = std::size_t(std::ceil((hi[0] - lo[0]) / band.res));
  band.ny = std::size_t(std::ceil((hi[1] - lo[1]) / band.res));
  if (double(band.nx) * double(band.ny) > double(std::size_t(1) << 28))
    throw ArgumentError("drive outputs: the band at " + std::to_string(band.res) + " m is " +
                        std::to_string(band.nx) + " x " + std::to_string(band.ny) +
                        " cells: choose a coarser --ros-res");
  band.prob.assign(band.nx * band.ny, -1.0f);
  band.var.assign(band.nx * band.ny, 0.0f);
  return band;
}

// Where each known voxel goes: the band, the OctoMap, the point cloud.
struct VoxelSink {
  Band& band;
  BandHeight& height;
  octomap::OcTree& tree;
  PlyStream& cloud;
  const DriveOutputOptions& o;
  std::size_t occupied = 0, free = 0, unknown = 0;
  void add(double x, double y, double z, double p, double var) {
    const double zr = height(x, y);
    if (z >= zr + o.band_low && z <= zr + o.band_high) band.add(x, y, p, var);
    // The .bt holds each voxel's most likely state only (OctoMap's writeBinary keeps no
    // more): set it so, and neighbours of one state prune into one node as the tree grows.
    tree.setNodeValue(octomap::point3d(float(x), float(y), float(z)),
                      p > 0.5 ? tree.getClampingThresMaxLog() : tree.getClampingThresMinLog(),
                      true);
    if (p > 0.5) {
      ++occupied;
      cloud.add(float(x), float(y), float(z), float(p), float(var));
    } else {
      ++free;
    }
  }
};

// Every voxel of every block, a column of blocks at a time with that column's local map.
void volume_pass(Context& ctx, const KernelMap& map, const std::vector<Block>& blocks, long per,
                 double vox, const KnownRule& known, VoxelSink& sink) {
  const auto groups = group_blocks(blocks);
  auto kernels = group_kernels(map, groups, kernel_reach(map, vox));
  auto progress = terminal_progress("outputs");
  std::vector<double> pts;
  std::size_t done = 0;
  for (const auto& [column, members] : groups) {
    KnownEvaluator ev(&ctx, subset(map, kernels[column]), known);
    kernels[column] = {};
    for (std::size_t m0 = 0; m0 < members.size(); m0 += kBatch) {
      const std::size_t m1 = std::min(members.size(), m0 + kBatch);
      pts.clear();
      for (std::size_t m = m0; m < m1; ++m) {
        const Block& blk = blocks[members[m]];
        for (long k = 0; k < per; ++k)
          for (long j = 0; j < per; ++j)
            for (long i = 0; i < per; ++i)
              pts.insert(pts.end(),
                         {blk[0] * kBlock + (i + 0.5) * vox, blk[1] * kBlock + (j + 0.5) * vox,
                          blk[2] * kBlock + (k + 0.5) * vox});
      }
      const KnownValues v = ev.values(pts);
      for (std::size_t q = 0; q < v.prob.size(); ++q) {
        if (v.known[q])
          sink.add(pts[3 * q], pts[3 * q + 1], pts[3 * q + 2], v.prob[q], v.var[q]);
        else
          ++sink.unknown;
      }
      done += m1 - m0;
      if (progress) progress(double(done) / double(blocks.size()));
    }
    sink.tree.updateInnerOccupancy();
    sink.tree.prune();
  }
}

}  // namespace

DriveOutputs write_drive_outputs(Context& ctx, const KernelMap& map,
                                 const std::vector<double>& positions, const std::string& prefix,
                                 const DriveOutputOptions& o) {
  if (map.dim != 3) throw ArgumentError("drive outputs: the map is not 3D");
  if (!(o.voxel > 0) || !(o.band_high > o.band_low) || o.ros_res < 0 || o.picture_res < 0)
    throw ArgumentError("drive outputs: voxel must be positive, band_high above band_low");
  const std::vector<Block> blocks = kernel_blocks(map);
  if (blocks.empty()) throw ArgumentError("drive outputs: the map has no kernels");
  // Voxels per block side, so that voxel centres tile every block alike.
  const long per = std::max(1L, long(std::lround(kBlock / o.voxel)));
  const double vox = kBlock / double(per);
  Band band = make_band(blocks, o.ros_res > 0 ? o.ros_res : vox);
  BandHeight height{positions, {}};
  octomap::OcTree tree(vox);
  const std::string ply = prefix + "_occupied.ply";
  PlyStream cloud(ply);
  VoxelSink sink{band, height, tree, cloud, o};
  volume_pass(ctx, map, blocks, per, vox, o.known, sink);
  const std::size_t n_occ = sink.occupied, n_free = sink.free, n_unknown = sink.unknown;
  DriveOutputs out;
  const std::string bt = prefix + ".bt";
  {
    std::ostringstream s;
    if (!tree.writeBinary(s)) throw Error("OctoMap export: liboctomap could not write " + bt);
    write_text_atomically(bt, s.str());
  }
  cloud.finish();
  const BandFiles bf = write_band_files(band.prob, band.var, band.nx, band.ny, band.origin,
                                        band.res, prefix, o.picture_res, o.picture_pixels);
  out.files = {bt, ply};
  out.files.insert(out.files.end(), bf.files.begin(), bf.files.end());
  char line[512];
  std::snprintf(line, sizeof line,
                "volume         %zu blocks of %g m at %g m: %zu occupied, %zu free, %zu unknown "
                "voxels\nOctoMap        %zu leaves -> %s\npoint cloud    %zu occupied voxels "
                "-> %s\n%s",
                blocks.size(), kBlock, vox, n_occ, n_free, n_unknown,
                std::size_t(tree.getNumLeafNodes()), bt.c_str(), n_occ, ply.c_str(),
                bf.summary.c_str());
  out.summary = line;
  out.json = {{"voxel_m", vox},
              {"blocks", blocks.size()},
              {"occupied_voxels", n_occ},
              {"free_voxels", n_free},
              {"unknown_voxels", n_unknown},
              {"octomap_leaves", tree.getNumLeafNodes()},
              {"band_m", {o.band_low, o.band_high}},
              {"band", bf.json}};
  return out;
}

}  // namespace potmap::cli
