// Rotation-invariant atom descriptors and pre-selection (see
// include/potmap/pot/atom_descriptor.hpp).
#include "potmap/pot/atom_descriptor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "class_ranking.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

using Quantiles = std::array<float, AtomDescriptor::kQuantiles>;

void quantiles(std::vector<double>& v, Quantiles& q) {
  if (v.empty()) return;
  const std::size_t n = v.size();
  // Each level's order statistic in turn, the next searched above the last: the values of a
  // full sort at a fraction of its cost (a target sector's thousand free samples, every scan).
  auto from = v.begin();
  for (int i = 0; i < AtomDescriptor::kQuantiles; ++i) {
    const double level = (i + 0.5) / AtomDescriptor::kQuantiles;
    const auto at =
        v.begin() + std::ptrdiff_t(std::min(n - 1, static_cast<std::size_t>(level * n)));
    if (at >= from) {
      std::nth_element(from, at, v.end());
      from = at + 1;
    }
    q[i] = static_cast<float>(*at);
  }
}

void describe_class(const std::vector<double>& pts, int dim, Quantiles& radius, Quantiles& z) {
  const std::size_t n = pts.size() / dim;
  std::vector<double> r(n), h;
  for (std::size_t i = 0; i < n; ++i) r[i] = std::hypot(pts[i * dim], pts[i * dim + 1]);
  quantiles(r, radius);
  if (dim == 3) {
    h.resize(n);
    for (std::size_t i = 0; i < n; ++i) h[i] = pts[i * dim + 2];
    quantiles(h, z);
  }
}

double squared_gap(const Quantiles& a, const Quantiles& b) {
  double s = 0;
  for (int i = 0; i < AtomDescriptor::kQuantiles; ++i) {
    const double d = double(a[i]) - double(b[i]);
    s += d * d;
  }
  return s / AtomDescriptor::kQuantiles;
}

}  // namespace

AtomDescriptor describe_sector(const Sector& s) {
  if (s.dim != 2 && s.dim != 3)
    throw ArgumentError("describe_sector: dimension " + std::to_string(s.dim));
  AtomDescriptor d;
  d.dim = s.dim;
  d.hits = s.num_hits();
  d.free = s.num_free();
  describe_class(s.hits, s.dim, d.hit_radius, d.hit_z);
  describe_class(s.free, s.dim, d.free_radius, d.free_z);
  return d;
}

double descriptor_distance(const AtomDescriptor& a, const AtomDescriptor& b, bool hits) {
  if (hits) {
    const double r = squared_gap(a.hit_radius, b.hit_radius);
    return a.dim == 3 ? r + squared_gap(a.hit_z, b.hit_z) : r;
  }
  const double r = squared_gap(a.free_radius, b.free_radius);
  return a.dim == 3 ? r + squared_gap(a.free_z, b.free_z) : r;
}

AtomPreselector::AtomPreselector(const Dictionary& dict) : dim_(dict.dim) {
  desc_.reserve(dict.size());
  for (const Atom& a : dict.atoms) desc_.push_back(describe_sector(a.sector));
}

std::vector<std::size_t> AtomPreselector::select(const Sector& target, std::size_t k) const {
  if (target.dim != dim_)
    throw ArgumentError("preselect_atoms: a " + std::to_string(target.dim) +
                        "D target sector for a " + std::to_string(dim_) + "D dictionary");
  return select(describe_sector(target), k);
}

std::vector<std::size_t> AtomPreselector::select(const AtomDescriptor& t, std::size_t k) const {
  if (t.dim != dim_)
    throw ArgumentError("preselect_atoms: a " + std::to_string(t.dim) +
                        "D target descriptor for a " + std::to_string(dim_) + "D dictionary");
  const std::size_t n = desc_.size();
  // Per class: raw distance, or -1 where the atom lacks a class the target has.
  std::vector<double> dh(n, 0), df(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const AtomDescriptor& a = desc_[i];
    if (t.hits) dh[i] = a.hits ? descriptor_distance(t, a, true) : -1;
    if (t.free) df[i] = a.free ? descriptor_distance(t, a, false) : -1;
  }
  return detail::order_by_class_distance(dh, df, k);
}

std::vector<std::size_t> preselect_atoms(const Dictionary& dict, const Sector& target,
                                         std::size_t k) {
  return AtomPreselector(dict).select(target, k);
}

}  // namespace potmap
