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

#include "point_grid.hpp"
#include "point_proximity.hpp"
#include "thinning.hpp"

namespace potmap::detail {

std::size_t anchors_at_samples(const Atom& atom, const Sector& sec, const SectorPlans& plans,
                               const PotOptions& o, std::vector<Anchor>& out,
                               const KernelClasses* classes) {
  const int dim = sec.dim;
  const KernelMap& k = atom.kernels;
  const double s = sec.scale;
  // Each atom kernel's class is its nearest atom sample's: kernels at samples sit on one, and a
  // map kernel is wall evidence where it lies nearer the walls than the free space.
  KernelClasses own;
  if (!classes) {
    own = kernel_classes(atom);
    classes = &own;
  }
  const std::vector<std::uint8_t>& cls = classes->cls;
  const double* gsum = classes->gamma_sum.data();
  const double* gcnt = classes->count.data();
  // The kernels by class in a grid whose cells span the widest kernel's reach (gamma d^2 <= 16).
  double gmin[2] = {HUGE_VAL, HUGE_VAL};
  std::vector<double> kpos[2];
  std::vector<std::size_t> kof[2];
  for (std::size_t e = 0; e < k.size(); ++e) {
    gmin[cls[e]] = std::min(gmin[cls[e]], k.gamma[e]);
    kpos[cls[e]].insert(kpos[cls[e]].end(), &k.position[e * dim], &k.position[e * dim] + dim);
    kof[cls[e]].push_back(e);
  }
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
    // The atom's map at its coupled samples, from its kernels of the same class (each class
    // alone reproduces the source map at its own samples).
    Eigen::VectorXd L = Eigen::VectorXd::Zero(X.rows()), V = Eigen::VectorXd::Zero(X.rows());
    if (!kof[q].empty()) {
      const double reach = s * std::sqrt(16.0 / gmin[q]);
      const PointGrid kernels(kpos[q], dim, reach);
      for (Eigen::Index i = 0; i < X.rows(); ++i) {
        double x[3] = {0, 0, 0};
        for (int d = 0; d < dim; ++d) x[d] = X(i, d);
        double m = 0, v = 0;
        kernels.for_each_within(x, reach, [&](std::size_t j, double d2) {
          const std::size_t e = kof[q][j];
          const double g = k.gamma[e] * d2 / (s * s);
          if (g > 16) return;
          const double phi = std::exp(-g);
          m += k.w_mean[e] * phi;
          v += k.w_var[e] * phi * phi;
        });
        L(i) = m;
        V(i) = v;
      }
    }
    const std::vector<double>& pts = q == 0 ? sec.hits : sec.free;
    const std::vector<std::size_t> keep = thin_to_cells(pts, dim, o.anchor_spacing * s);
    std::vector<double> ypts(std::size_t(Y.rows()) * dim);
    for (Eigen::Index j = 0; j < Y.rows(); ++j)
      for (int d = 0; d < dim; ++d) ypts[std::size_t(j) * dim + d] = Y(j, d);
    const PointGrid targets(ypts, dim);
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
        const double rx = c * X(i, 0) - sn * X(i, 1), ry = sn * X(i, 0) + c * X(i, 1);
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
  std::vector<double> pts(n * dim);
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < dim; ++d) pts[i * dim + d] = anchors[i].position[d];
  const PointGrid grid(pts, dim, reach);
  for (std::size_t i = 0; i < n; ++i) {
    const double* p = &pts[i * dim];
    double sum = 0, sum2 = 0;
    grid.for_each_within(p, reach, [&](std::size_t j, double d2) {
      if (anchors[j].hit != anchors[i].hit) return;
      const double g = anchors[j].gamma * d2;
      if (g > 16) return;
      const double phi = std::exp(-g);
      sum += phi;
      sum2 += phi * phi;
    });
    map.push_back(p, anchors[i].gamma, anchors[i].value / sum, anchors[i].variance / sum2);
  }
}

}  // namespace potmap::detail
