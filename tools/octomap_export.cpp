#include "octomap_export.hpp"

#include <octomap/OcTree.h>

#include <cmath>
#include <sstream>
#include <vector>

#include "potmap/error.hpp"
#include "progress.hpp"

namespace potmap::cli {

namespace {

constexpr double kClamp = 1e-3;  // probabilities stored within [kClamp, 1 - kClamp]

bool has_extension(const std::string& path, const std::string& ext) {
  return path.size() > ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0;
}

}  // namespace

OctomapExportSummary write_octomap(Context* ctx, const KernelMap& map, const std::string& path,
                                   const OctomapExportOptions& o) {
  const bool binary = has_extension(path, ".bt");
  if (!binary && !has_extension(path, ".ot"))
    throw ArgumentError("OctoMap export: " + path + " must end in .bt or .ot");
  if (!(o.resolution > 0)) throw ArgumentError("OctoMap export: resolution must be positive");
  if (map.empty()) throw ArgumentError("OctoMap export: the map has no kernels");
  double lo[3], hi[3];
  map.bounds(lo, hi);
  // Voxel centres where OctoMap puts them, (k + 0.5) * resolution, so each lands in one voxel.
  long first[3], count[3] = {1, 1, 1};
  for (int d = 0; d < 3; ++d) {
    const bool spans = d < 2 || map.dim == 3;
    const double a = spans ? lo[d] - o.margin : o.z, b = spans ? hi[d] + o.margin : o.z;
    first[d] = static_cast<long>(std::floor(a / o.resolution));
    if (spans) count[d] = static_cast<long>(std::floor(b / o.resolution)) - first[d] + 1;
  }
  const double voxels = double(count[0]) * double(count[1]) * double(count[2]);
  if (voxels > double(o.max_voxels))
    throw ArgumentError("OctoMap export: " + std::to_string(count[0]) + " x " +
                        std::to_string(count[1]) + " x " + std::to_string(count[2]) +
                        " voxels at " + std::to_string(o.resolution) +
                        " m is over the limit: choose a coarser resolution");
  octomap::OcTree tree(o.resolution);
  // OctoMap clamps stored log-odds to [0.12, 0.97] by default (a mapping heuristic): widen it
  // so that the .ot keeps the map's probabilities.
  tree.setClampingThresMin(kClamp);
  tree.setClampingThresMax(1 - kClamp);
  OctomapExportSummary s;
  auto progress = count[2] > 1 ? terminal_progress("octomap") : std::function<void(double)>();
  for (long k = 0; k < count[2]; ++k) {
    const double z = (first[2] + k + 0.5) * o.resolution;
    std::vector<double> pts;
    pts.reserve(std::size_t(count[0] * count[1]) * map.dim);
    for (long j = 0; j < count[1]; ++j)
      for (long i = 0; i < count[0]; ++i) {
        pts.push_back((first[0] + i + 0.5) * o.resolution);
        pts.push_back((first[1] + j + 0.5) * o.resolution);
        if (map.dim == 3) pts.push_back(z);
      }
    const KnownValues v = known_values(ctx, map, pts, o.known);
    for (std::size_t c = 0; c < v.prob.size(); ++c) {
      if (!v.known[c]) {
        ++s.unknown;
        continue;
      }
      const double p = std::min(std::max(v.prob[c], kClamp), 1 - kClamp);
      const octomap::point3d at{float(pts[c * map.dim]), float(pts[c * map.dim + 1]), float(z)};
      tree.setNodeValue(at, float(std::log(p / (1 - p))), true);
      ++(p > 0.5 ? s.occupied : s.free);
    }
    if (progress) progress(double(k + 1) / double(count[2]));
  }
  tree.updateInnerOccupancy();
  std::ostringstream out;
  const bool ok = binary ? tree.writeBinary(out) : tree.write(out);
  if (!ok) throw Error("OctoMap export: liboctomap could not serialise the tree for " + path);
  write_text_atomically(path, out.str());
  s.leaves = tree.getNumLeafNodes();
  return s;
}

}  // namespace potmap::cli
