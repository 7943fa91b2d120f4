// OctoMap does the ray casting and the log-odds bookkeeping; this file only translates scans.
#include "potmap/experiments/ogm.hpp"

#include <octomap/OcTree.h>

#include <cmath>

#include "potmap/error.hpp"

namespace potmap {

struct OccupancyGrid::Impl {
  int dim;
  OgmOptions opt;
  octomap::OcTree tree;
  Impl(int d, const OgmOptions& o) : dim(d), opt(o), tree(o.resolution) {
    tree.setProbHit(o.prob_hit);
    tree.setProbMiss(o.prob_miss);
  }
  octomap::point3d point(const double* p) const {
    return octomap::point3d(float(p[0]), float(p[1]), dim == 3 ? float(p[2]) : 0.0f);
  }
};

OccupancyGrid::OccupancyGrid(int dim, const OgmOptions& o) {
  if (dim != 2 && dim != 3) throw ArgumentError("OccupancyGrid: dim must be 2 or 3");
  if (!(o.resolution > 0) || !std::isfinite(o.resolution))
    throw ArgumentError("OccupancyGrid: resolution must be > 0 metres, got " +
                        std::to_string(o.resolution));
  if (!(o.prob_hit > 0 && o.prob_hit < 1 && o.prob_miss > 0 && o.prob_miss < 1))
    throw ArgumentError("OccupancyGrid: hit and miss probabilities must lie in (0, 1)");
  if (!(o.max_range >= 0)) throw ArgumentError("OccupancyGrid: max_range must be >= 0");
  impl_ = std::make_unique<Impl>(dim, o);
}

OccupancyGrid::~OccupancyGrid() = default;
OccupancyGrid::OccupancyGrid(OccupancyGrid&&) noexcept = default;
OccupancyGrid& OccupancyGrid::operator=(OccupancyGrid&&) noexcept = default;

void OccupancyGrid::insert(const Scan& scan) {
  Impl& m = *impl_;
  if (scan.dim != m.dim) throw ArgumentError("OccupancyGrid::insert: scan dim differs from grid's");
  const double rmax = m.opt.max_range > 0 ? m.opt.max_range : scan.max_range;
  const auto o = scan.origin();
  const octomap::point3d origin = m.point(o.data());
  octomap::Pointcloud cloud;
  cloud.reserve(scan.num_beams());
  for (std::size_t i = 0; i < scan.num_hits(); ++i) {
    const double* p = &scan.hits[i * m.dim];
    bool finite = true;
    for (int k = 0; k < m.dim; ++k) finite = finite && std::isfinite(p[k]);
    if (finite) cloud.push_back(m.point(p));
  }
  // A no-return beam is given an end point past the maximum range: insertPointCloud then cuts
  // the ray at maxrange and marks only free cells, which is what an empty beam says.
  if (rmax > 0 && std::isfinite(rmax)) {
    const double far = rmax * 1.01 + 2 * m.opt.resolution;
    for (std::size_t i = 0; i < scan.num_no_return(); ++i) {
      const double* u = &scan.no_return[i * m.dim];
      double n2 = 0;
      for (int k = 0; k < m.dim; ++k) n2 += u[k] * u[k];
      if (!(n2 > 0) || !std::isfinite(n2)) continue;
      double e[3] = {0, 0, 0};
      for (int k = 0; k < m.dim; ++k) e[k] = o[k] + far * u[k] / std::sqrt(n2);
      cloud.push_back(m.point(e));
    }
  }
  m.tree.insertPointCloud(cloud, origin, rmax > 0 && std::isfinite(rmax) ? rmax : -1.0);
}

void OccupancyGrid::probability(const double* points, std::size_t n, double* prob) const {
  const Impl& m = *impl_;
  for (std::size_t i = 0; i < n; ++i) {
    const octomap::OcTreeNode* node = m.tree.search(m.point(points + i * m.dim));
    prob[i] = node ? node->getOccupancy() : 0.5;
  }
}

void OccupancyGrid::observed(const double* points, std::size_t n, std::uint8_t* observed) const {
  const Impl& m = *impl_;
  for (std::size_t i = 0; i < n; ++i)
    observed[i] = m.tree.search(m.point(points + i * m.dim)) != nullptr ? 1 : 0;
}

int OccupancyGrid::dim() const {
  return impl_->dim;
}
double OccupancyGrid::resolution() const {
  return impl_->opt.resolution;
}
std::size_t OccupancyGrid::leaf_count() const {
  return impl_->tree.getNumLeafNodes();
}
std::size_t OccupancyGrid::memory_bytes() const {
  return impl_->tree.memoryUsage();
}

}  // namespace potmap
