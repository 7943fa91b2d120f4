// Placement at the target's samples. The barycentric placement moves each atom kernel to the
// plan-weighted mean of the target samples its sample is coupled with; where a sample's mass
// splits between two walls, the kernel lands between them, and the atom's spacing, not the
// target's, decides where the map has kernels. Here the target's own (thinned) samples are the
// kernels' places and the plan is read the other way: each anchor takes the plan-weighted mean
// of the atom's logit at the source samples coupled with it, and a variance that grows with how
// much those samples disagree and how far the plan had to move them.
#include "placement_at_samples.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "spatial/point_grid.hpp"
#include "point_proximity.hpp"
#include "thinning.hpp"

namespace potmap::detail {

std::size_t anchors_at_samples(const Atom& atom, const Sector& sec, const SectorPlans& plans,
                               const PotOptions& o, std::vector<Anchor>& out,
                               const KernelClasses* classes) {
  const int dim = sec.dim;
  const double s = sec.scale;
  // Each atom kernel's class is its nearest atom sample's: kernels at samples sit on one, and a
  // map kernel is wall evidence where it lies nearer the walls than the free space.
  KernelClasses own;
  if (!classes) {
    own = kernel_classes(atom);
    classes = &own;
  }
  const double* gsum = classes->gamma_sum.data();
  const double* gcnt = classes->count.data();
  std::unique_ptr<PointProximity> on_wall;
  if (o.wall_clearance > 0 && sec.num_hits() > 0)
    on_wall = std::make_unique<PointProximity>(sec.hits, dim, o.wall_clearance * s);
  const double c = std::cos(plans.angle), sn = std::sin(plans.angle);
  std::size_t dropped = 0;
  for (int q = 0; q < 2; ++q) {
    if (!plans.coupling[q] || plans.coupling[q]->size() == 0) continue;
    const Eigen::MatrixXd& X = *plans.source[q];
    const Eigen::MatrixXd& Y = *plans.target[q];
    const Eigen::MatrixXd& P = *plans.coupling[q];
    const double gamma = gcnt[q] > 0 ? gsum[q] / gcnt[q] : gsum[1 - q] / std::max(1.0, gcnt[1 - q]);
    if (!(gamma > 0)) continue;
    // The atom's map at its coupled samples (cached per atom when the plans' sources are its
    // cached thinned samples).
    SampleMap own_map;
    const SampleMap* map = plans.source_map[q];
    if (!map || map->mean.size() != X.rows()) {
      own_map = atom_map_at(atom, *classes, q, X, s);
      map = &own_map;
    }
    const Eigen::VectorXd& L = map->mean;
    const Eigen::VectorXd& V = map->variance;
    const std::vector<double>& pts = q == 0 ? sec.hits : sec.free;
    const std::vector<std::size_t> keep = thin_to_cells(pts, dim, o.anchor_spacing * s);
    std::vector<double> ypts(std::size_t(Y.rows()) * dim);
    for (Eigen::Index j = 0; j < Y.rows(); ++j)
      for (int d = 0; d < dim; ++d) ypts[std::size_t(j) * dim + d] = Y(j, d);
    const PointGrid targets(ypts, dim);
    // The source samples turned by the plan's angle, once (each column's read walks them all).
    Eigen::MatrixXd turned = X;
    for (Eigen::Index i = 0; i < X.rows(); ++i) {
      turned(i, 0) = c * X(i, 0) - sn * X(i, 1);
      turned(i, 1) = sn * X(i, 0) + c * X(i, 1);
    }
    // What an anchor reads depends only on the plan's column it reads (the target point of the
    // plan nearest it); several anchors share a column, so each column is read once.
    struct Column {
      bool done = false, valid = false;
      double mean = 0, variance = 0;
    };
    std::vector<Column> columns(std::size_t(Y.rows()));
    auto read_column = [&](Eigen::Index j) -> const Column& {
      Column& out = columns[std::size_t(j)];
      if (out.done) return out;
      out.done = true;
      const auto col = P.col(j);
      const double mass = col.sum();
      if (!(mass > 0)) return out;
      const double mean = col.dot(L) / mass;
      double spread = 0, moved = 0;
      for (Eigen::Index i = 0; i < X.rows(); ++i) {
        spread += col(i) * (L(i) - mean) * (L(i) - mean);
        const double rx = turned(i, 0), ry = turned(i, 1);
        double m2 = (rx - Y(j, 0)) * (rx - Y(j, 0)) + (ry - Y(j, 1)) * (ry - Y(j, 1));
        if (dim == 3) m2 += (X(i, 2) - Y(j, 2)) * (X(i, 2) - Y(j, 2));
        moved += col(i) * m2;
      }
      out.valid = true;
      out.mean = mean;
      out.variance =
          col.dot(V) / mass + spread / mass + o.displacement_variance * (moved / mass) / (s * s);
      return out;
    };
    for (std::size_t a : keep) {
      const double* y = &pts[a * dim];
      if (q == 1 && on_wall && on_wall->near(y)) {
        ++dropped;
        continue;
      }
      double bd = 0;
      const long best = targets.nearest(y, bd);
      if (best < 0) continue;
      const Column& col = read_column(best);
      if (!col.valid) continue;
      Anchor an;
      for (int d = 0; d < dim; ++d) an.position[d] = y[d] / s + sec.centre[d];
      an.gamma = gamma;
      an.value = col.mean;
      an.variance = col.variance;
      an.hit = q == 0;
      out.push_back(an);
    }
  }
  return dropped;
}

void anchors_to_map(const std::vector<Anchor>& anchors, int dim, KernelMap& map) {
  const std::size_t n = anchors.size();
  if (n == 0) return;
  double gmin = HUGE_VAL;
  for (const Anchor& a : anchors) gmin = std::min(gmin, a.gamma);
  // Every anchor within gamma d^2 <= 16 of another lies within this reach of it.
  const double reach = std::sqrt(16.0 / gmin);
  std::vector<double> sum(n, 1.0), sum2(n, 1.0);  // each anchor's own phi = 1
  // Each pair once: phi is symmetric where the two share a width (every pair of a class within
  // a sector), which halves the exps. The anchors of each class are binned in cells of the
  // reach and each cell is paired with itself and the half of its neighbours that come after it
  // in the bins' order: every pair within reach is met once, and only a class's own anchors
  // are looked at (pairs across classes are not summed).
  std::vector<std::size_t> members;
  for (const bool hit : {true, false}) {
    members.clear();
    for (std::size_t i = 0; i < n; ++i)
      if (anchors[i].hit == hit) members.push_back(i);
    if (members.empty()) continue;
    double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    for (int d = 0; d < dim; ++d) {
      lo[d] = hi[d] = anchors[members[0]].position[d];
      for (std::size_t i : members) {
        lo[d] = std::min(lo[d], anchors[i].position[d]);
        hi[d] = std::max(hi[d], anchors[i].position[d]);
      }
    }
    // Cells no smaller than the reach (so one ring of neighbours holds every partner), and no
    // more of them than a few a member (a scan along a line would ask for a sparse grid).
    double cell = reach;
    std::int64_t ext[3] = {1, 1, 1};
    for (;; cell *= 2) {
      double cells = 1;
      for (int d = 0; d < dim; ++d) {
        ext[d] = std::int64_t(std::floor((hi[d] - lo[d]) / cell)) + 1;
        cells *= double(ext[d]);
      }
      if (cells <= 4.0 * double(members.size()) + 64) break;
    }
    auto cell_of = [&](std::size_t i) {
      std::int64_t c = 0;
      for (int d = dim - 1; d >= 0; --d)
        c = c * ext[d] +
            std::min(ext[d] - 1, std::int64_t((anchors[i].position[d] - lo[d]) / cell));
      return std::size_t(c);
    };
    // Members by cell (CSR), in index order within a cell.
    std::vector<std::uint32_t> start(std::size_t(ext[0] * ext[1] * ext[2]) + 1, 0);
    for (std::size_t i : members) ++start[cell_of(i) + 1];
    for (std::size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
    std::vector<std::size_t> binned(members.size());
    {
      std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
      for (std::size_t i : members) binned[fill[cell_of(i)]++] = i;
    }
    auto pair = [&](std::size_t i, std::size_t j) {
      const Anchor &ai = anchors[i], &aj = anchors[j];
      double d2 = 0;
      for (int d = 0; d < dim; ++d)
        d2 += (ai.position[d] - aj.position[d]) * (ai.position[d] - aj.position[d]);
      if (d2 > reach * reach) return;
      const double gj = aj.gamma * d2, gi = ai.gamma * d2;
      const double phi_j = gj <= 16 ? std::exp(-gj) : 0.0;  // anchor j's kernel at i
      const double phi_i = gi == gj ? phi_j : gi <= 16 ? std::exp(-gi) : 0.0;
      sum[i] += phi_j;
      sum2[i] += phi_j * phi_j;
      sum[j] += phi_i;
      sum2[j] += phi_i * phi_i;
    };
    // The neighbour offsets after a cell in (z, y, x) order: 4 in 2D, 13 in 3D.
    std::vector<std::array<std::int64_t, 3>> after;
    for (std::int64_t dz = dim == 3 ? -1 : 0; dz <= (dim == 3 ? 1 : 0); ++dz)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dx = -1; dx <= 1; ++dx)
          if (dz > 0 || (dz == 0 && (dy > 0 || (dy == 0 && dx > 0)))) after.push_back({dx, dy, dz});
    for (std::int64_t z = 0; z < ext[2]; ++z)
      for (std::int64_t y = 0; y < ext[1]; ++y)
        for (std::int64_t x = 0; x < ext[0]; ++x) {
          const std::size_t c = std::size_t((z * ext[1] + y) * ext[0] + x);
          for (std::uint32_t k = start[c]; k < start[c + 1]; ++k) {
            const std::size_t i = binned[k];
            for (std::uint32_t l = k + 1; l < start[c + 1]; ++l) pair(i, binned[l]);
            for (const auto& o : after) {
              const std::int64_t nx = x + o[0], ny = y + o[1], nz = z + o[2];
              if (nx < 0 || nx >= ext[0] || ny < 0 || ny >= ext[1] || nz < 0 || nz >= ext[2])
                continue;
              const std::size_t e = std::size_t((nz * ext[1] + ny) * ext[0] + nx);
              for (std::uint32_t l = start[e]; l < start[e + 1]; ++l) pair(i, binned[l]);
            }
          }
        }
  }
  for (std::size_t i = 0; i < n; ++i)
    map.push_back(anchors[i].position.data(), anchors[i].gamma, anchors[i].value / sum[i],
                  anchors[i].variance / sum2[i]);
}

}  // namespace potmap::detail
