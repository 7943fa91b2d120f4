#include "potmap/pot/fingerprint.hpp"

#include <cstring>
#include <string>
#include <type_traits>

#include "runtime/hash.hpp"

namespace potmap {

namespace {

// FNV-1a, 64 bits (runtime/hash.hpp), fed values as little-endian bytes.
class Fnv {
 public:
  void u64(std::uint64_t v) {
    char b[8];
    for (int i = 0; i < 8; ++i) b[i] = static_cast<char>(v >> (8 * i));
    h_ = detail::fnv1a64(std::string_view(b, 8), h_);
  }
  void i64(std::int64_t v) { u64(static_cast<std::uint64_t>(v)); }
  void f64(double d) {
    std::uint64_t v;
    std::memcpy(&v, &d, 8);
    u64(v);
  }
  template <class Range>
  void f64s(const Range& r) {
    u64(r.size());
    for (double x : r) f64(x);
  }
  // Each value as the member above its type takes: i64 or u64 (the same bytes for an integer),
  // f64, or f64s for a range of doubles.
  template <class... T>
  void values(const T&... v) {
    (value(v), ...);
  }
  void text(const std::string& s) {
    u64(s.size());
    h_ = detail::fnv1a64(s, h_);
  }
  std::uint64_t value() const { return h_; }

 private:
  template <class T>
  void value(const T& v) {
    if constexpr (std::is_floating_point_v<T>)
      f64(v);
    else if constexpr (std::is_integral_v<T>)
      i64(static_cast<std::int64_t>(v));
    else
      f64s(v);
  }

  std::uint64_t h_ = detail::fnv1a64("");
};

void add(Fnv& f, const KernelMap& k) {
  f.i64(k.dim);
  f.f64s(k.position);
  f.f64s(k.gamma);
  f.f64s(k.w_mean);
  f.f64s(k.w_var);
  f.i64(k.has_bias);
  f.f64(k.bias_mean);
  f.f64(k.bias_var);
}

}  // namespace

std::uint64_t fingerprint(const Dictionary& dict) {
  Fnv f;
  f.i64(dict.dim);
  f.f64(dict.scale);
  f.f64(dict.max_range);
  f.i64(dict.sectors);
  f.u64(dict.atoms.size());
  for (const Atom& a : dict.atoms) {
    const Sector& s = a.sector;
    f.i64(s.dim);
    f.i64(s.index);
    f.f64s(s.centre);
    f.f64s(s.sensor);
    f.f64(s.scale);
    f.f64(s.max_range);
    f.f64s(s.hits);
    f.f64s(s.free);
    add(f, a.kernels);
    f.i64(a.scan_index);
    f.text(a.source);
  }
  return f.value();
}

std::uint64_t fingerprint(const std::vector<Scan>& scans) {
  Fnv f;
  f.u64(scans.size());
  for (const Scan& s : scans) {
    f.i64(s.dim);
    f.f64(s.timestamp);
    f.f64(s.max_range);
    f.f64s(s.pose2d);
    f.f64s(s.pose3d);
    f.f64s(s.hits);
    f.f64s(s.no_return);
  }
  return f.value();
}

std::uint64_t fingerprint(const MapperOptions& o, const OverallMapOptions& overall) {
  Fnv f;
  // The placement the transfer uses: RePOT's persistent map places its seeds by its own fields,
  // so a state keeps its fingerprint whichever field carried the placement when it was saved.
  PotOptions p = o.pot;
  if (persistent_refine(o)) {
    p.placement = o.seed_placement;
    p.displacement_variance = o.seed_displacement_variance;
  }
  f.values(p.sectors, p.max_range, p.min_samples, p.max_sample_distance, p.rotations, p.rank_hits,
           p.rank_free, p.rank_epsilon, p.rank_max_iterations, p.rank_tolerance, p.transport_points,
           p.transport_free_points, p.transport_epsilon, p.transport_max_iterations,
           p.transport_tolerance, p.transport_free, p.wall_clearance, p.displacement_variance);
  if (p.placement != PotPlacement::barycentric) {  // earlier fingerprints stay valid
    f.i64(static_cast<int>(p.placement));
    f.f64(p.anchor_spacing);
    f.f64(p.anchor_clearance);
    f.i64(p.anchor_sweeps);
    f.f64(p.logit_gain);
  }
  f.i64(static_cast<int>(p.ranking));
  f.values(p.candidates, p.index_neighbours, p.index_rotations, p.index_anchors, p.snap_rotations,
           p.coarse_hits, p.coarse_free);
  // The coarse stage solved to rank_tolerance before it had its own: those fingerprints stay.
  if (p.coarse_tolerance != p.rank_tolerance) f.f64(p.coarse_tolerance);
  // The free plan solved to transport_tolerance before it had its own: those fingerprints stay.
  if (p.transport_free_tolerance != p.transport_tolerance) f.f64(p.transport_free_tolerance);
  f.values(p.fine_candidates, p.warm_candidates, p.refine, p.refine_bhm.em_iterations,
           p.refine_bhm.xi_init, p.refine_bhm.tau, p.refine_min_variance, p.refine_joint, p.seed);
  const LabelOptions& l = o.labels;
  f.values(l.free_per_metre, l.max_free_per_beam, l.holdout_fraction, l.seed, o.persistent_refine);
  const JointBhmOptions& j = o.refine_map;
  f.values(j.spacing, j.gamma, j.neighbour_phi, j.prior_var, j.bias, j.em_iterations, j.tau,
           j.cg_tolerance, j.cg_max_iterations, j.solve_margin, j.max_kernels, j.seeds_yield);
  // Appended only when on, so that states saved before it existed keep their fingerprint.
  if (j.seeds_yield_fully) f.i64(7);
  // Forgetting: appended only when on, for the same reason.
  if (j.half_life > 0) {
    f.i64(9);
    f.f64(j.half_life);
  }
  f.values(o.seed_min_variance, overall.merge_radius, overall.gamma_ratio, overall.max_kernels,
           overall.retire_to);
  // Appended only when on, so that states saved before the averaged map keep their fingerprint.
  if (o.average_overall) {
    f.i64(1);
    f.f64(o.averaged.spacing);
    f.f64(o.averaged.min_support);
    f.f64(o.averaged.ridge);
    f.i64(o.averaged.sweeps);
  }
  return f.value();
}

}  // namespace potmap
