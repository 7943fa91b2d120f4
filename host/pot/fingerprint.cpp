#include "potmap/pot/fingerprint.hpp"

#include <cstring>
#include <string>

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
  void text(const std::string& s) {
    u64(s.size());
    h_ = detail::fnv1a64(s, h_);
  }
  std::uint64_t value() const { return h_; }

 private:
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
  const PotOptions& p = o.pot;
  f.i64(p.sectors);
  f.f64(p.max_range);
  f.u64(p.min_samples);
  f.f64(p.max_sample_distance);
  f.f64s(p.rotations);
  f.u64(p.rank_hits);
  f.u64(p.rank_free);
  f.f64(p.rank_epsilon);
  f.i64(p.rank_max_iterations);
  f.f64(p.rank_tolerance);
  f.u64(p.transport_points);
  f.u64(p.transport_free_points);
  f.f64(p.transport_epsilon);
  f.i64(p.transport_max_iterations);
  f.f64(p.transport_tolerance);
  f.i64(p.transport_free);
  f.f64(p.wall_clearance);
  f.f64(p.displacement_variance);
  if (p.placement != PotPlacement::barycentric) {  // earlier fingerprints stay valid
    f.i64(static_cast<int>(p.placement));
    f.f64(p.anchor_spacing);
  }
  f.i64(static_cast<int>(p.ranking));
  f.u64(p.candidates);
  f.u64(p.index_neighbours);
  f.i64(p.index_rotations);
  f.i64(p.index_anchors);
  f.i64(p.snap_rotations);
  f.u64(p.coarse_hits);
  f.u64(p.coarse_free);
  // The coarse stage solved to rank_tolerance before it had its own: those fingerprints stay.
  if (p.coarse_tolerance != p.rank_tolerance) f.f64(p.coarse_tolerance);
  // The free plan solved to transport_tolerance before it had its own: those fingerprints stay.
  if (p.transport_free_tolerance != p.transport_tolerance) f.f64(p.transport_free_tolerance);
  f.u64(p.fine_candidates);
  f.i64(p.warm_candidates);
  f.i64(p.refine);
  f.i64(p.refine_bhm.em_iterations);
  f.f64(p.refine_bhm.xi_init);
  f.f64(p.refine_bhm.tau);
  f.f64(p.refine_min_variance);
  f.i64(p.refine_joint);
  f.u64(p.seed);
  const LabelOptions& l = o.labels;
  f.f64(l.free_per_metre);
  f.i64(l.max_free_per_beam);
  f.f64(l.holdout_fraction);
  f.u64(l.seed);
  f.i64(o.persistent_refine);
  const JointBhmOptions& j = o.refine_map;
  f.f64(j.spacing);
  f.f64(j.gamma);
  f.f64(j.neighbour_phi);
  f.f64(j.prior_var);
  f.i64(j.bias);
  f.i64(j.em_iterations);
  f.f64(j.tau);
  f.f64(j.cg_tolerance);
  f.i64(j.cg_max_iterations);
  f.i64(j.solve_margin);
  f.u64(j.max_kernels);
  f.i64(j.seeds_yield);
  // Appended only when on, so that states saved before it existed keep their fingerprint.
  if (j.seeds_yield_fully) f.i64(7);
  f.f64(o.seed_min_variance);
  f.f64(overall.merge_radius);
  f.f64(overall.gamma_ratio);
  f.u64(overall.max_kernels);
  f.f64(overall.retire_to);
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
