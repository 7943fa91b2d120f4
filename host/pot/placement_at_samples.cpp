// Placement at the target's samples. The barycentric placement moves each atom kernel to the
// plan-weighted mean of the target samples its sample is coupled with; where a sample's mass
// splits between two walls, the kernel lands between them, and the atom's spacing, not the
// target's, decides where the map has kernels. Here the target's own (thinned) samples are the
// kernels' places and the plan is read the other way: each anchor takes the plan-weighted mean
// of the atom's logit at the source samples coupled with it, and a variance that grows with how
// much those samples disagree and how far the plan had to move them.
#include "placement_at_samples.hpp"

#include <algorithm>
#include <cmath>

#include "point_proximity.hpp"
#include "potmap/error.hpp"
#include "spatial/point_grid.hpp"
#include "thinning.hpp"

namespace potmap::detail {

AnchorSites anchor_sites(const Sector& sec, const std::array<const Eigen::MatrixXd*, 2>& targets,
                         const PotOptions& o) {
  const int dim = sec.dim;
  const double s = sec.scale;
  AnchorSites sites;
  std::unique_ptr<PointProximity> on_wall;
  if (o.anchor_clearance > 0 && sec.num_hits() > 0 && targets[1])
    on_wall = std::make_unique<PointProximity>(sec.hits, dim, o.anchor_clearance * s);
  for (int q = 0; q < 2; ++q) {
    if (!targets[q] || targets[q]->rows() == 0) continue;
    const Eigen::MatrixXd& Y = *targets[q];
    const std::vector<double>& pts = q == 0 ? sec.hits : sec.free;
    sites.sample[q] = thin_to_cells(pts, dim, o.anchor_spacing * s);
    std::vector<double> ypts(std::size_t(Y.rows()) * dim);
    for (Eigen::Index j = 0; j < Y.rows(); ++j)
      for (int d = 0; d < dim; ++d) ypts[std::size_t(j) * dim + d] = Y(j, d);
    const PointGrid grid(ypts, dim);
    std::vector<long>& column = sites.column[q];
    column.reserve(sites.sample[q].size());
    for (std::size_t a : sites.sample[q]) {
      const double* y = &pts[a * dim];
      if (q == 1 && on_wall && on_wall->near(y)) {
        column.push_back(AnchorSites::kDroppedByWall);
        continue;
      }
      double bd = 0;
      const long j = grid.nearest(y, bd);
      column.push_back(j >= 0 ? j : AnchorSites::kNoColumn);
    }
  }
  return sites;
}

std::size_t anchors_at_samples(const Atom& atom, const Sector& sec, const SectorPlans& plans,
                               const AnchorSites& sites, const PotOptions& o,
                               std::vector<Anchor>& out, const KernelClasses* classes) {
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
    const std::vector<std::size_t>& keep = sites.sample[q];
    const std::vector<long>& column = sites.column[q];
    if (column.size() != keep.size())
      throw ArgumentError("anchors_at_samples: the sites' samples and columns differ in number");
    for (std::size_t k = 0; k < keep.size(); ++k) {
      if (column[k] == AnchorSites::kDroppedByWall) {
        ++dropped;
        continue;
      }
      if (column[k] < 0 || column[k] >= Y.rows()) continue;
      const Column& col = read_column(column[k]);
      if (!col.valid) continue;
      const double* y = &pts[keep[k] * dim];
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

namespace {

// The anchors' neighbours within a kernel's cut (gamma d^2 <= 16), both classes together, as
// rows: row i holds each anchor j != i with phi_j(x_i), the term j adds to the map at anchor i.
struct AnchorRows {
  std::vector<std::size_t> start, column;
  std::vector<double> phi;
};

AnchorRows anchor_rows(const std::vector<Anchor>& anchors, int dim, double reach) {
  const std::size_t n = anchors.size();
  std::vector<double> pts;
  pts.reserve(n * std::size_t(dim));
  for (const Anchor& a : anchors)
    pts.insert(pts.end(), a.position.begin(), a.position.begin() + dim);
  struct Pair {
    std::size_t i, j;
    double phi_j, phi_i;  // j's kernel at i, i's at j
  };
  std::vector<Pair> pairs;
  const PointGrid grid(pts, dim, reach);
  grid.for_each_pair_within(reach, [&](std::size_t i, std::size_t j, double d2) {
    const double gj = anchors[j].gamma * d2, gi = anchors[i].gamma * d2;
    if (gj > 16 && gi > 16) return;
    pairs.push_back({i, j, gj <= 16 ? std::exp(-gj) : 0.0, gi <= 16 ? std::exp(-gi) : 0.0});
  });
  AnchorRows rows;
  rows.start.assign(n + 1, 0);
  for (const Pair& p : pairs) {
    ++rows.start[p.i + 1];
    ++rows.start[p.j + 1];
  }
  for (std::size_t i = 0; i < n; ++i) rows.start[i + 1] += rows.start[i];
  rows.column.resize(rows.start[n]);
  rows.phi.resize(rows.start[n]);
  std::vector<std::size_t> at(rows.start.begin(), rows.start.end() - 1);
  for (const Pair& p : pairs) {
    rows.column[at[p.i]] = p.j;
    rows.phi[at[p.i]++] = p.phi_j;
    rows.column[at[p.j]] = p.i;
    rows.phi[at[p.j]++] = p.phi_i;
  }
  return rows;
}

// Each class's Nadaraya-Watson partition at its anchors, added into sum and sum2 (phi and phi^2
// of the class's other anchors). Each pair once: phi is symmetric where the two share a width
// (every pair of a class within a sector), which halves the exps. Each class on a grid of its
// own, in cells of the reach: pairs across classes are not summed, and are not looked at.
void class_partition(const std::vector<Anchor>& anchors, int dim, double reach,
                     std::vector<double>& sum, std::vector<double>& sum2) {
  std::vector<std::size_t> members;
  std::vector<double> pts;
  for (const bool hit : {true, false}) {
    members.clear();
    pts.clear();
    for (std::size_t i = 0; i < anchors.size(); ++i)
      if (anchors[i].hit == hit) {
        members.push_back(i);
        pts.insert(pts.end(), anchors[i].position.begin(), anchors[i].position.begin() + dim);
      }
    const PointGrid grid(pts, dim, reach);
    grid.for_each_pair_within(reach, [&](std::size_t a, std::size_t b, double d2) {
      const std::size_t i = members[a], j = members[b];
      const double gj = anchors[j].gamma * d2, gi = anchors[i].gamma * d2;
      const double phi_j = gj <= 16 ? std::exp(-gj) : 0.0;  // anchor j's kernel at i
      const double phi_i = gi == gj ? phi_j : gi <= 16 ? std::exp(-gi) : 0.0;
      sum[i] += phi_j;
      sum2[i] += phi_j * phi_j;
      sum[j] += phi_i;
      sum2[j] += phi_i * phi_i;
    });
  }
}

}  // namespace

void anchors_to_map(const std::vector<Anchor>& anchors, int dim, KernelMap& map, int sweeps,
                    double gain) {
  const std::size_t n = anchors.size();
  if (n == 0) return;
  double gmin = HUGE_VAL;
  for (const Anchor& a : anchors) gmin = std::min(gmin, a.gamma);
  // Every anchor within gamma d^2 <= 16 of another lies within this reach of it.
  const double reach = std::sqrt(16.0 / gmin);
  std::vector<double> sum(n, 1.0), sum2(n, 1.0);  // each anchor's own phi = 1
  AnchorRows rows;
  if (sweeps > 0) {
    // The solve's rows hold every pair within the cut: each class's partition is their
    // same-class part, so the pairs are found once.
    rows = anchor_rows(anchors, dim, reach);
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t e = rows.start[i]; e < rows.start[i + 1]; ++e)
        if (anchors[rows.column[e]].hit == anchors[i].hit) {
          sum[i] += rows.phi[e];
          sum2[i] += rows.phi[e] * rows.phi[e];
        }
  } else {
    class_partition(anchors, dim, reach, sum, sum2);
  }
  // The partition's weights, and with sweeps the solve started from them: projected
  // Gauss-Seidel in the anchors' order, each weight kept to its value's sign, as the averaged
  // map keeps its weights (a weight of the other sign would only cancel a neighbour's tail, and
  // past the last anchor it rings into space the scan did not see).
  std::vector<double> w(n);
  for (std::size_t i = 0; i < n; ++i) w[i] = gain * anchors[i].value / sum[i];
  for (int t = 0; t < sweeps; ++t)
    for (std::size_t i = 0; i < n; ++i) {
      const double v = gain * anchors[i].value;
      double r = v;
      for (std::size_t e = rows.start[i]; e < rows.start[i + 1]; ++e)
        r -= rows.phi[e] * w[rows.column[e]];
      w[i] = v >= 0 ? std::max(r, 0.0) : std::min(r, 0.0);
    }
  for (std::size_t i = 0; i < n; ++i)
    map.push_back(anchors[i].position.data(), anchors[i].gamma, w[i],
                  anchors[i].variance / sum2[i]);
}

}  // namespace potmap::detail
