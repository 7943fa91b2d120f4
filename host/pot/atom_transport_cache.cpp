// The per-atom cache of the transport and the placement (atom_transport_cache.hpp).
#include "atom_transport_cache.hpp"

#include <cmath>

#include "point_grid.hpp"
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

}  // namespace potmap
