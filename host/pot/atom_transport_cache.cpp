// The per-atom cache of the transport and the placement (atom_transport_cache.hpp).
#include "atom_transport_cache.hpp"

#include <algorithm>
#include <cmath>

#include "spatial/point_grid.hpp"
#include "thinning.hpp"

namespace potmap {

namespace detail {

KernelClasses kernel_classes(const Atom& atom) {
  const int dim = atom.sector.dim;
  const KernelMap& k = atom.kernels;
  KernelClasses out;
  out.cls.assign(k.size(), 0);
  const PointGrid hits(atom.sector.hits, dim), free(atom.sector.free, dim);
  for (std::size_t e = 0; e < k.size(); ++e) {
    const double* h = &k.position[e * dim];
    double dh = HUGE_VAL, df = HUGE_VAL;
    hits.nearest(h, dh);
    free.nearest(h, df);
    const int c = dh <= df ? 0 : 1;
    out.cls[e] = static_cast<std::uint8_t>(c);
    out.gamma_sum[c] += k.gamma[e];
    out.count[c] += 1;
  }
  return out;
}

SampleMap atom_map_at(const Atom& atom, const KernelClasses& classes, int cls,
                      const Eigen::MatrixXd& X, double s) {
  const int dim = atom.sector.dim;
  const KernelMap& k = atom.kernels;
  SampleMap out;
  out.mean = Eigen::VectorXd::Zero(X.rows());
  out.variance = Eigen::VectorXd::Zero(X.rows());
  // The class's kernels in a grid whose cells span the widest kernel's reach (gamma d^2 <= 16).
  double gmin = HUGE_VAL;
  std::vector<double> kpos;
  std::vector<std::size_t> kof;
  for (std::size_t e = 0; e < k.size(); ++e) {
    if (classes.cls[e] != cls) continue;
    gmin = std::min(gmin, k.gamma[e]);
    kpos.insert(kpos.end(), &k.position[e * dim], &k.position[e * dim] + dim);
    kof.push_back(e);
  }
  if (kof.empty()) return out;
  const double reach = s * std::sqrt(16.0 / gmin);
  const PointGrid kernels(kpos, dim, reach);
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    double x[3] = {0, 0, 0};
    for (int d = 0; d < dim; ++d) x[d] = X(i, d);
    double m = 0, v = 0;
    kernels.for_each_within(x, reach, [&](std::size_t j, double d2) {
      const std::size_t e = kof[j];
      const double g = k.gamma[e] * d2 / (s * s);
      if (g > 16) return;
      const double phi = std::exp(-g);
      m += k.w_mean[e] * phi;
      v += k.w_var[e] * phi * phi;
    });
    out.mean(i) = m;
    out.variance(i) = v;
  }
  return out;
}

}  // namespace detail

AtomTransportCache::AtomTransportCache(std::size_t atoms)
    : class_once_(atoms), classes_(atoms), thinned_(atoms) {}

const detail::KernelClasses& AtomTransportCache::classes(const Atom& atom, std::size_t a) {
  std::call_once(class_once_.at(a), [&] { classes_[a] = detail::kernel_classes(atom); });
  return classes_[a];
}

Eigen::MatrixXd AtomTransportCache::thinned(const Atom& atom, std::size_t a, int cls,
                                            std::size_t cap) {
  const std::vector<double>& pts = cls == 0 ? atom.sector.hits : atom.sector.free;
  const int dim = atom.sector.dim;
  Thinned& t = thinned_.at(a)[cls == 0 ? 0 : 1];
  std::call_once(t.once, [&] {
    t.cap = cap;
    for (std::size_t i : detail::even_indices(pts, dim, cap))
      t.keep.push_back(static_cast<std::uint32_t>(i));
  });
  if (t.cap != cap) return detail::subsample_even(pts, dim, cap);
  Eigen::MatrixXd out(t.keep.size(), dim);
  for (std::size_t i = 0; i < t.keep.size(); ++i)
    for (int d = 0; d < dim; ++d) out(i, d) = pts[std::size_t(t.keep[i]) * dim + d];
  return out;
}

const detail::SampleMap* AtomTransportCache::sample_map(const Atom& atom, std::size_t a, int cls,
                                                        std::size_t cap, double scale) {
  Thinned& t = thinned_.at(a)[cls == 0 ? 0 : 1];
  std::call_once(t.map_once, [&] {
    t.map_cap = cap;
    t.map_scale = scale;
    t.map = detail::atom_map_at(atom, classes(atom, a), cls, thinned(atom, a, cls, cap), scale);
  });
  return t.map_cap == cap && t.map_scale == scale ? &t.map : nullptr;
}

}  // namespace potmap
