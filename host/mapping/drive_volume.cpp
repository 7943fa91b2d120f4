// export_drive_volume: blocks grouped in columns, each group's kernels uploaded once, its blocks
// evaluated on the device a batch at a time while a worker thread turns the batch before into
// voxel states, OctoMap block codes, point-cloud records and band cells.

#include "potmap/mapping/drive_volume.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>

#include "io/atomic_file.hpp"
#include "potmap/error.hpp"
#include "potmap/io/octomap_binary.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/height_band.hpp"
#include "potmap/map/voxel_blocks.hpp"
#include "runtime/serial_worker.hpp"

namespace potmap {

namespace {

constexpr double kGroup = 64.0;      // metres: the columns of blocks that share one upload
constexpr std::size_t kBatch = 256;  // blocks a launch (a million voxels)
// Metres between the corners where the band's height is the path's (bilinear between them): a
// car's road climbs a few centimetres over it, and a corner costs a search of the whole path.
constexpr double kHeightStep = 8.0;
constexpr std::size_t kVox = VoxelBlocks::kVoxels;
constexpr int kSide = VoxelBlocks::kSide;

using Column = std::pair<long, long>;

// The sensor's height at (x, y): that of the nearest point of the path (the positions joined in
// order), so the band follows a road that climbs without steps.
double path_height(const std::vector<double>& pos, double x, double y) {
  const std::size_t n = pos.size() / 3;
  double best = HUGE_VAL, z = pos[2];
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

// path_height at the corners of a square lattice, bilinear inside its squares: continuous, and
// one path search per corner rather than per voxel.
struct BandHeight {
  const std::vector<double>& pos;
  double edge;  // the corners' spacing, metres
  std::map<Column, double> corner;
  double at_corner(long i, long j) {
    const auto it = corner.find({i, j});
    if (it != corner.end()) return it->second;
    return corner[{i, j}] = path_height(pos, double(i) * edge, double(j) * edge);
  }
  double operator()(double x, double y) {
    const long i = long(std::floor(x / edge)), j = long(std::floor(y / edge));
    const double u = x / edge - double(i), v = y / edge - double(j);
    return (1 - u) * (1 - v) * at_corner(i, j) + u * (1 - v) * at_corner(i + 1, j) +
           (1 - u) * v * at_corner(i, j + 1) + u * v * at_corner(i + 1, j + 1);
  }
};

HeightBandRaster make_band(const VoxelBlocks& blocks) {
  HeightBandRaster band;
  band.res = blocks.voxel;
  double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
  for (std::size_t b = 0; b < blocks.size(); ++b)
    for (int d = 0; d < 2; ++d) {
      lo[d] = std::min(lo[d], blocks.corner(b, d));
      hi[d] = std::max(hi[d], blocks.corner(b, d) + kSide * blocks.voxel);
    }
  band.origin[0] = lo[0];
  band.origin[1] = lo[1];
  band.nx = std::size_t(std::lround((hi[0] - lo[0]) / band.res));
  band.ny = std::size_t(std::lround((hi[1] - lo[1]) / band.res));
  if (double(band.nx) * double(band.ny) > double(std::size_t(1) << 28))
    throw ArgumentError("drive volume: the band at " + std::to_string(band.res) + " m is " +
                        std::to_string(band.nx) + " x " + std::to_string(band.ny) +
                        " cells: choose a coarser voxel");
  band.prob.assign(band.nx * band.ny, -1.0f);
  band.var.assign(band.nx * band.ny, 0.0f);
  return band;
}

// One batch's values, as the device wrote them (4096 a block).
struct Batch {
  std::size_t count = 0;
  std::vector<float> var, prob, support;
};

// What the worker makes of the batches.
struct Sinks {
  Sinks(const VoxelBlocks& b, const DriveVolumeOptions& opt, double bias,
        const std::vector<double>& path)
      : blocks(b),
        o(opt),
        bias_var(bias),
        height{path, kHeightStep, {}},
        band(make_band(b)),
        codes(b.size()) {}
  const VoxelBlocks& blocks;
  const DriveVolumeOptions& o;
  double bias_var;
  BandHeight height;
  HeightBandRaster band;
  std::vector<OctomapBlockCode> codes;
  std::string cloud;  // the PLY's records
  std::size_t occupied = 0, free = 0, unknown = 0;

  // Block b's voxels: their variance, probability and support.
  void block(std::size_t b, const float* var, const float* prob, const float* sup) {
    OctomapState state[kVox];
    const double v = blocks.voxel, x0 = blocks.corner(b, 0), y0 = blocks.corner(b, 1),
                 z0 = blocks.corner(b, 2);
    for (std::size_t i = 0; i < kVox; ++i) {
      const double spread = sup[i] > 0 ? (double(var[i]) - bias_var) / sup[i] : 0.0;
      if (!is_known(sup[i], spread, o.known)) {
        state[i] = OctomapState::unknown;
        ++unknown;
        continue;
      }
      const bool occ = prob[i] > 0.5f;
      state[i] = occ ? OctomapState::occupied : OctomapState::free;
      ++(occ ? occupied : free);
      if (!occ || o.cloud_path.empty()) continue;
      const float r[5] = {float(x0 + (i % kSide + 0.5) * v),
                          float(y0 + (i / kSide % kSide + 0.5) * v),
                          float(z0 + (i / (kSide * kSide) + 0.5) * v), prob[i], var[i]};
      cloud.append(reinterpret_cast<const char*>(r), sizeof r);  // the hosts are little-endian
    }
    if (!o.octomap_path.empty()) codes[b] = encode_octomap_block(state);
    add_to_band(b, state, prob, var);
  }

  // The known voxels of each column of the block within the band about the path's height.
  void add_to_band(std::size_t b, const OctomapState* state, const float* prob, const float* var) {
    const double v = blocks.voxel;
    const long ci = std::lround((blocks.corner(b, 0) - band.origin[0]) / v);
    const long cj = std::lround((blocks.corner(b, 1) - band.origin[1]) / v);
    for (int j = 0; j < kSide; ++j)
      for (int i = 0; i < kSide; ++i) {
        const double x = blocks.corner(b, 0) + (i + 0.5) * v,
                     y = blocks.corner(b, 1) + (j + 0.5) * v;
        const double zr = height(x, y);
        const std::size_t cell = std::size_t(ci + i) + band.nx * std::size_t(cj + j);
        for (int k = 0; k < kSide; ++k) {
          const double z = blocks.corner(b, 2) + (k + 0.5) * v;
          if (z < zr + o.band_low || z > zr + o.band_high) continue;
          const std::size_t at = std::size_t(i + kSide * (j + kSide * k));
          if (state[at] == OctomapState::unknown) continue;
          keep_band_max(prob[at], var[at], 0.0f, band.prob[cell], band.var[cell]);
        }
      }
  }
};

// The kernels of each column group: those within `reach` metres of its square, each group's in
// the map's order. A kernel is tested against a neighbouring column only when it lies within
// `reach` of that side of its own, and the last column looked up is kept (a drive's map holds
// its kernels tile by tile): a map lookup for every kernel and each of the nine columns around
// it took as long as a third of the scores' evaluation.
std::map<Column, std::vector<std::uint32_t>> group_kernels(
    const KernelMap& map, const std::map<Column, std::vector<std::size_t>>& groups, double reach) {
  std::map<Column, std::vector<std::uint32_t>> g;
  for (const auto& [c, members] : groups) g[c];
  auto at = g.end();  // the column looked up last
  auto list_of = [&](const Column& c) -> std::vector<std::uint32_t>* {
    if (at == g.end() || at->first != c) at = g.find(c);
    return at == g.end() ? nullptr : &at->second;
  };
  for (std::size_t k = 0; k < map.size(); ++k) {
    const double x = map.position[3 * k], y = map.position[3 * k + 1];
    const long cx = long(std::floor(x / kGroup)), cy = long(std::floor(y / kGroup));
    const double fx = x - double(cx) * kGroup, fy = y - double(cy) * kGroup;
    const long x0 = fx <= reach ? -1 : 0, x1 = kGroup - fx <= reach ? 1 : 0;
    const long y0 = fy <= reach ? -1 : 0, y1 = kGroup - fy <= reach ? 1 : 0;
    for (long dy = y0; dy <= y1; ++dy)
      for (long dx = x0; dx <= x1; ++dx) {
        const Column c{cx + dx, cy + dy};
        std::vector<std::uint32_t>* list = list_of(c);
        if (!list) continue;
        const double gx = std::clamp(x, c.first * kGroup, (c.first + 1) * kGroup);
        const double gy = std::clamp(y, c.second * kGroup, (c.second + 1) * kGroup);
        if ((gx - x) * (gx - x) + (gy - y) * (gy - y) <= reach * reach)
          list->push_back(std::uint32_t(k));
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
  m.cutoff_tau = map.cutoff_tau;
  return m;
}

void check(const KernelMap& map, const std::vector<double>& path, const DriveVolumeOptions& o) {
  if (map.dim != 3) throw ArgumentError("drive volume: the map is not 3D");
  if (map.empty()) throw ArgumentError("drive volume: the map has no kernels");
  if (path.size() < 3 || path.size() % 3 != 0)
    throw ArgumentError("drive volume: the path needs at least one position (x y z)");
  if (!(o.voxel > 0) || !std::isfinite(o.voxel))
    throw ArgumentError("drive volume: the voxel edge must be positive, got " +
                        std::to_string(o.voxel));
  if (!(o.known.min_support >= 0) || !(o.known.unknown_variance > 0))
    throw ArgumentError(
        "drive volume: the known rule's min_support must be >= 0 and its "
        "unknown_variance > 0");
  if (!(o.band_high > o.band_low))
    throw ArgumentError("drive volume: the band's top " + std::to_string(o.band_high) +
                        " m must be above its bottom " + std::to_string(o.band_low) + " m");
}

void write_cloud(const std::string& path, const std::string& records) {
  detail::AtomicFile f(path);
  const std::string head =
      "ply\nformat binary_little_endian 1.0\ncomment potmap occupied voxels: probability and "
      "logit variance of the map\nelement vertex " +
      std::to_string(records.size() / 20) +
      "\nproperty float x\nproperty float y\nproperty float z\nproperty float "
      "probability\nproperty float variance\nend_header\n";
  f.write(head.data(), head.size());
  f.write(records.data(), records.size());
  f.commit();
}

// Every block, group after group, evaluated in batches while the worker sinks the batch before.
void volume_pass(Context& ctx, const KernelMap& map, const VoxelBlocks& blocks, Sinks& sinks,
                 const std::function<void(double)>& progress) {
  std::map<Column, std::vector<std::size_t>> groups;
  const double edge = kSide * blocks.voxel;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    groups[{long(std::floor((blocks.corner(b, 0) + 0.5 * edge) / kGroup)),
            long(std::floor((blocks.corner(b, 1) + 0.5 * edge) / kGroup))}]
        .push_back(b);
  }
  double gmin = HUGE_VAL;
  for (double g : map.gamma) gmin = std::min(gmin, g);
  const double reach = std::sqrt(std::min(kDefaultCutoffTau, map.cutoff_tau) / gmin) + edge;
  auto kernels = group_kernels(map, groups, reach);
  Batch batch[2];
  detail::SerialWorker worker;
  std::size_t done = 0, turn = 0;
  for (const auto& group : groups) {
    const std::vector<std::size_t>* members = &group.second;
    MapEvaluator ev(ctx, subset(map, kernels[group.first]));
    kernels[group.first] = {};
    for (std::size_t m0 = 0; m0 < members->size(); m0 += kBatch) {
      Batch& bt = batch[turn++ % 2];  // the worker is done with it: submit waited for it
      VoxelBlocks part;
      part.voxel = blocks.voxel;
      bt.count = std::min(members->size(), m0 + kBatch) - m0;
      for (std::size_t m = m0; m < m0 + bt.count; ++m)
        part.index.insert(part.index.end(), &blocks.index[3 * (*members)[m]],
                          &blocks.index[3 * (*members)[m]] + 3);
      for (auto* v : {&bt.var, &bt.prob, &bt.support}) v->resize(bt.count * kVox);
      ev.evaluate_blocks(part, bt.var.data(), bt.prob.data(), bt.support.data());
      worker.submit([&sinks, &bt, members, m0] {
        for (std::size_t q = 0; q < bt.count; ++q)
          sinks.block((*members)[m0 + q], &bt.var[q * kVox], &bt.prob[q * kVox],
                      &bt.support[q * kVox]);
      });
      done += bt.count;
      if (progress) progress(double(done) / double(blocks.size()));
    }
  }
  worker.wait();
}

}  // namespace

std::vector<float> probability_by_columns(Context& ctx, const KernelMap& map,
                                          const std::vector<double>& points) {
  const std::size_t n = points.size() / 3;
  std::vector<float> prob(n, 0.5f);
  if (map.dim != 3) throw ArgumentError("probability_by_columns: the map is not 3D");
  if (map.empty() || n == 0) return prob;
  std::map<Column, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < n; ++i)
    groups[{long(std::floor(points[3 * i] / kGroup)), long(std::floor(points[3 * i + 1] / kGroup))}]
        .push_back(i);
  double gmin = HUGE_VAL;
  for (double g : map.gamma) gmin = std::min(gmin, g);
  auto kernels = group_kernels(map, groups,
                               std::sqrt(std::min(kDefaultCutoffTau, map.cutoff_tau) / gmin) + 0.1);
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

DriveVolume export_drive_volume(Context& ctx, const KernelMap& map, const std::vector<double>& path,
                                const DriveVolumeOptions& o) {
  check(map, path, o);
  const VoxelBlocks blocks = blocks_holding_kernels(map, o.voxel);
  Sinks sinks(blocks, o, map.has_bias ? map.bias_var : 0.0, path);
  volume_pass(ctx, map, blocks, sinks, o.progress);
  DriveVolume out;
  out.voxel = o.voxel;
  out.blocks = blocks.size();
  out.occupied = sinks.occupied;
  out.free = sinks.free;
  out.unknown = sinks.unknown;
  if (!o.octomap_path.empty()) {
    const OctomapFile bt = octomap_binary_file(o.voxel, blocks.index, sinks.codes);
    out.octomap_nodes = bt.nodes;
    out.octomap_leaves = bt.leaves;
    detail::AtomicFile f(o.octomap_path);
    f.write(bt.bytes.data(), bt.bytes.size());
    f.commit();
  }
  if (!o.cloud_path.empty()) write_cloud(o.cloud_path, sinks.cloud);
  out.band = std::move(sinks.band);
  return out;
}

}  // namespace potmap
