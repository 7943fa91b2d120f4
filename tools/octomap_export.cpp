#include "octomap_export.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <vector>

#include "potmap/error.hpp"
#include "potmap/io/octomap_binary.hpp"
#include "progress.hpp"

namespace potmap::cli {

namespace {

constexpr double kClamp = 1e-3;  // probabilities stored within [kClamp, 1 - kClamp]
constexpr long kSide = 16;       // voxels a block side (octomap_binary.hpp)

bool has_extension(const std::string& path, const std::string& ext) {
  return path.size() > ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0;
}

long floor_div(long a, long b) {
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}

// The voxels evaluated: keys first[d] .. first[d] + count[d] - 1 (centre (key + 0.5) * res).
struct Volume {
  long first[3] = {0, 0, 0}, count[3] = {1, 1, 1};
};

Volume export_volume(const KernelMap& map, const OctomapExportOptions& o) {
  double lo[3], hi[3];
  map.bounds(lo, hi);
  // Voxel centres where OctoMap puts them, (k + 0.5) * resolution, so each lands in one voxel.
  Volume v;
  for (int d = 0; d < 3; ++d) {
    const bool spans = d < 2 || map.dim == 3;
    const double a = spans ? lo[d] - o.margin : o.z, b = spans ? hi[d] + o.margin : o.z;
    v.first[d] = static_cast<long>(std::floor(a / o.resolution));
    if (spans) v.count[d] = static_cast<long>(std::floor(b / o.resolution)) - v.first[d] + 1;
  }
  const double voxels = double(v.count[0]) * double(v.count[1]) * double(v.count[2]);
  if (voxels > double(o.max_voxels))
    throw ArgumentError("OctoMap export: " + std::to_string(v.count[0]) + " x " +
                        std::to_string(v.count[1]) + " x " + std::to_string(v.count[2]) +
                        " voxels at " + std::to_string(o.resolution) +
                        " m is over the limit: choose a coarser resolution");
  return v;
}

// Every known voxel of the volume, a layer at a time: visit(key x, key y, key z, log-odds).
// Returns the count of unknown voxels.
template <class Visit>
std::size_t each_known_voxel(Context* ctx, const KernelMap& map, const Volume& v,
                             const OctomapExportOptions& o, Visit&& visit) {
  std::size_t unknown = 0;
  auto progress = v.count[2] > 1 ? terminal_progress("octomap") : std::function<void(double)>();
  std::vector<double> pts;
  for (long k = 0; k < v.count[2]; ++k) {
    const double z = (v.first[2] + k + 0.5) * o.resolution;
    pts.clear();
    pts.reserve(std::size_t(v.count[0] * v.count[1]) * map.dim);
    for (long j = 0; j < v.count[1]; ++j)
      for (long i = 0; i < v.count[0]; ++i) {
        pts.push_back((v.first[0] + i + 0.5) * o.resolution);
        pts.push_back((v.first[1] + j + 0.5) * o.resolution);
        if (map.dim == 3) pts.push_back(z);
      }
    const KnownValues kv = known_values(ctx, map, pts, o.known);
    for (std::size_t c = 0; c < kv.prob.size(); ++c) {
      if (!kv.known[c]) {
        ++unknown;
        continue;
      }
      const double p = std::min(std::max(kv.prob[c], kClamp), 1 - kClamp);
      const long i = long(c) % v.count[0], j = long(c) / v.count[0];
      visit(v.first[0] + i, v.first[1] + j, v.first[2] + k, float(std::log(p / (1 - p))));
    }
    if (progress) progress(double(k + 1) / double(v.count[2]));
  }
  return unknown;
}

// The .bt through the library's own encoder (io/octomap_binary.hpp: liboctomap's bytes, without
// liboctomap's line on stderr), one slab of 16 voxel layers of blocks at a time. A voxel is
// occupied where its log-odds is at least 0, as OcTree::isNodeOccupied reads it.
OctomapFile binary_octomap(Context* ctx, const KernelMap& map, const Volume& v,
                           const OctomapExportOptions& o, OctomapExportSummary& s) {
  const long bx0 = floor_div(v.first[0], kSide), by0 = floor_div(v.first[1], kSide);
  const long nbx = floor_div(v.first[0] + v.count[0] - 1, kSide) - bx0 + 1;
  const long nby = floor_div(v.first[1] + v.count[1] - 1, kSide) - by0 + 1;
  const std::size_t layer = std::size_t(nbx * kSide * nby * kSide);
  std::vector<std::vector<OctomapState>> slab(kSide);  // empty: a layer with nothing known
  long slab_z = floor_div(v.first[2], kSide);
  std::vector<std::int64_t> index;
  std::vector<OctomapBlockCode> codes;
  std::vector<OctomapState> block(kSide * kSide * kSide);
  auto flush = [&] {
    for (long by = 0; by < nby; ++by)
      for (long bx = 0; bx < nbx; ++bx) {
        for (long k = 0; k < kSide; ++k)
          for (long j = 0; j < kSide; ++j)
            for (long i = 0; i < kSide; ++i)
              block[std::size_t(i + kSide * (j + kSide * k))] =
                  slab[k].empty()
                      ? OctomapState::unknown
                      : slab[k][std::size_t(bx * kSide + i + nbx * kSide * (by * kSide + j))];
        OctomapBlockCode code = encode_octomap_block(block.data());
        if (code.type == 0) continue;
        index.insert(index.end(), {bx0 + bx, by0 + by, slab_z});
        codes.push_back(std::move(code));
      }
    for (auto& l : slab) l.clear();
  };
  s.unknown = each_known_voxel(ctx, map, v, o, [&](long x, long y, long z, float logodds) {
    if (floor_div(z, kSide) != slab_z) {
      flush();
      slab_z = floor_div(z, kSide);
    }
    std::vector<OctomapState>& l = slab[std::size_t(z - slab_z * kSide)];
    if (l.empty()) l.assign(layer, OctomapState::unknown);
    const bool occupied = logodds >= 0;
    l[std::size_t(x - bx0 * kSide + nbx * kSide * (y - by0 * kSide))] =
        occupied ? OctomapState::occupied : OctomapState::free;
    ++(occupied ? s.occupied : s.free);
  });
  flush();
  return octomap_binary_file(o.resolution, index, codes);
}

}  // namespace

OctomapExportSummary write_octomap(Context* ctx, const KernelMap& map, const std::string& path,
                                   const OctomapExportOptions& o) {
  const bool binary = has_extension(path, ".bt");
  if (!binary && !has_extension(path, ".ot"))
    throw ArgumentError("OctoMap export: " + path + " must end in .bt or .ot");
  if (!(o.resolution > 0)) throw ArgumentError("OctoMap export: resolution must be positive");
  if (map.empty()) throw ArgumentError("OctoMap export: the map has no kernels");
  const Volume v = export_volume(map, o);
  OctomapExportSummary s;
  if (binary) {
    const OctomapFile f = binary_octomap(ctx, map, v, o, s);
    write_text_atomically(path, f.bytes);
    s.leaves = std::size_t(f.leaves);
    return s;
  }
  // The .ot keeps every voxel's log-odds: liboctomap's tree and its writer (which prints
  // nothing for .ot).
  octomap::OcTree tree(o.resolution);
  // OctoMap clamps stored log-odds to [0.12, 0.97] by default (a mapping heuristic): widen it
  // so that the .ot keeps the map's probabilities.
  tree.setClampingThresMin(kClamp);
  tree.setClampingThresMax(1 - kClamp);
  s.unknown = each_known_voxel(ctx, map, v, o, [&](long x, long y, long z, float logodds) {
    const octomap::point3d at{float((x + 0.5) * o.resolution), float((y + 0.5) * o.resolution),
                              float((z + 0.5) * o.resolution)};
    tree.setNodeValue(at, logodds, true);
    ++(logodds >= 0 ? s.occupied : s.free);
  });
  tree.updateInnerOccupancy();
  std::ostringstream out;
  if (!tree.write(out))
    throw Error("OctoMap export: liboctomap could not serialise the tree for " + path);
  write_text_atomically(path, out.str());
  s.leaves = tree.getNumLeafNodes();
  return s;
}

}  // namespace potmap::cli
