// One scan through POT (SPEC section 4, steps 2 to 7). The ranking of every (sector, atom,
// rotation) candidate is one batched Sinkhorn solve, the high-quality transport of the winners
// another; everything else is bookkeeping on the host.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include "data/sim_rng.hpp"
#include "potmap/error.hpp"
#include "potmap/pot.hpp"
#include "potmap/sinkhorn.hpp"

namespace potmap {

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

std::uint64_t mix(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  data::SimRng r{a * 0x9e3779b97f4a7c15ULL ^ (b + 0x632be59bd9b4e019ULL) * 0xbf58476d1ce4e5b9ULL ^
                 c * 0x94d049bb133111ebULL};
  return r.next();
}

// At most `cap` of the points (dim per point), chosen by a seeded partial Fisher-Yates shuffle;
// all of them, in order, when there are few enough.
Eigen::MatrixXd subsample(const std::vector<double>& pts, int dim, std::size_t cap,
                          std::uint64_t seed) {
  const std::size_t n = pts.size() / dim;
  const std::size_t k = std::min(n, cap);
  std::vector<std::size_t> idx(n);
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  if (k < n) {
    data::SimRng rng{seed};
    for (std::size_t i = 0; i < k; ++i) std::swap(idx[i], idx[i + rng.below(n - i)]);
    std::sort(idx.begin(), idx.begin() + k);
  }
  Eigen::MatrixXd out(k, dim);
  for (std::size_t i = 0; i < k; ++i)
    for (int d = 0; d < dim; ++d) out(i, d) = pts[idx[i] * dim + d];
  return out;
}

Eigen::MatrixXd kernel_positions(const KernelMap& k) {
  Eigen::MatrixXd out(k.size(), k.dim);
  for (std::size_t i = 0; i < k.size(); ++i)
    for (int d = 0; d < k.dim; ++d) out(i, d) = k.position[i * k.dim + d];
  return out;
}

void check(const Dictionary& dict, const LabelledPoints& train, const PotOptions& o) {
  auto bad = [](const std::string& what) { throw ArgumentError("transfer_scan: " + what); };
  if (dict.empty()) bad("the dictionary has no atoms");
  if (dict.dim != train.dim)
    bad("the dictionary is " + std::to_string(dict.dim) + "D, the scan " +
        std::to_string(train.dim) + "D");
  if (o.rotations.empty()) bad("no rotations given");
  for (double a : o.rotations)
    if (!std::isfinite(a)) bad("a rotation is not finite");
  if (o.rank_hits < 1 || o.rank_free < 1 || o.transport_points < 1)
    bad("rank_hits, rank_free and transport_points must be >= 1");
  if (!(o.rank_epsilon > 0) || !(o.transport_epsilon > 0)) bad("epsilons must be positive");
  if (o.rank_max_iterations < 1 || o.transport_max_iterations < 1)
    bad("iteration limits must be >= 1");
  if (!(o.rank_tolerance > 0) || !(o.transport_tolerance > 0)) bad("tolerances must be positive");
  if (o.candidates > 0 && o.candidates < dict.size())
    bad("PotOptions::candidates (descriptor pre-selection) is not available in this build");
}

// Solves a batch on the device, or one problem at a time on the CPU reference.
std::vector<SinkhornResult> solve(Context* ctx, const SinkhornBatch& batch,
                                  const SinkhornOptions& opt) {
  if (batch.size() == 0) return {};
  if (ctx) return batch.run(*ctx, opt);
  std::vector<SinkhornResult> out;
  out.reserve(batch.size());
  for (std::size_t i = 0; i < batch.size(); ++i)
    out.push_back(sinkhorn_reference(batch.problem(i)));
  return out;
}

// Subsamples of one atom, the same for every scan (seeded by the atom index only).
struct AtomSample {
  bool ready = false;
  Eigen::MatrixXd hits, free;
};

struct Candidate {
  std::size_t atom = 0;
  double angle = 0;
  long hits_problem = -1, free_problem = -1;
};

}  // namespace

ScanTransfer transfer_scan(Context* ctx, const Dictionary& dict, const LabelledPoints& train,
                           const std::array<double, 3>& sensor, double heading,
                           std::int64_t scan_index, const PotOptions& o) {
  check(dict, train, o);
  const int dim = dict.dim;
  ScanTransfer out;
  out.map.dim = dim;
  auto t0 = Clock::now();

  SectorOptions so;
  so.sectors = o.sectors;
  so.max_range = o.max_range > 0 ? o.max_range : dict.max_range;
  so.scale = dict.scale;
  so.min_samples = o.min_samples;
  const std::vector<Sector> sectors = cut_sectors(train, sensor, heading, so);
  const auto t_index = static_cast<std::uint64_t>(scan_index);

  std::vector<AtomSample> atom_sample(dict.size());
  auto sample_of = [&](std::size_t a) -> const AtomSample& {
    AtomSample& s = atom_sample[a];
    if (!s.ready) {
      const Sector& src = dict.atoms[a].sector;
      s.hits = subsample(src.hits, dim, o.rank_hits, mix(o.seed, a, 1));
      s.free = subsample(src.free, dim, o.rank_free, mix(o.seed, a, 2));
      s.ready = true;
    }
    return s;
  };

  // Ranking problems of every sector in one batch.
  SinkhornBatch rank;
  SinkhornProblem proto;
  proto.epsilon = o.rank_epsilon;
  proto.max_iterations = o.rank_max_iterations;
  proto.tolerance = o.rank_tolerance;
  std::vector<std::vector<Candidate>> cands(sectors.size());
  std::vector<bool> use_hits(sectors.size()), use_free(sectors.size());
  for (std::size_t s = 0; s < sectors.size(); ++s) {
    const Sector& sec = sectors[s];
    SectorTransfer st;
    st.sector = sec.index;
    st.target_hits = sec.num_hits();
    st.target_free = sec.num_free();
    out.sectors.push_back(st);
    const Eigen::MatrixXd th =
        subsample(sec.hits, dim, o.rank_hits, mix(o.seed ^ 0x5eed, t_index, 2 * sec.index));
    const Eigen::MatrixXd tf =
        subsample(sec.free, dim, o.rank_free, mix(o.seed ^ 0x5eed, t_index, 2 * sec.index + 1));
    // A term is ranked when the target has it; a candidate must have every ranked term. When
    // no atom has both, hits alone decide (free space carries less shape), then free alone.
    bool any_both = false, any_hits = false, any_free = false;
    for (std::size_t a = 0; a < dict.size(); ++a) {
      const Sector& src = dict.atoms[a].sector;
      any_hits |= src.num_hits() > 0;
      any_free |= src.num_free() > 0;
      any_both |= src.num_hits() > 0 && src.num_free() > 0;
    }
    bool uh = th.rows() > 0 && any_hits, uf = tf.rows() > 0 && any_free;
    if (uh && uf && !any_both) uf = false;
    use_hits[s] = uh;
    use_free[s] = uf;
    if (!uh && !uf) continue;
    for (std::size_t a = 0; a < dict.size(); ++a) {
      const AtomSample& as = sample_of(a);
      if ((uh && as.hits.rows() == 0) || (uf && as.free.rows() == 0)) continue;
      for (double angle : o.rotations) {
        Candidate c;
        c.atom = a;
        c.angle = angle;
        SinkhornProblem p = proto;
        p.angle = angle;
        if (uh) {
          p.source = as.hits;
          p.target = th;
          c.hits_problem = static_cast<long>(rank.add(p));
        }
        if (uf) {
          p.source = as.free;
          p.target = tf;
          c.free_problem = static_cast<long>(rank.add(std::move(p)));
        }
        cands[s].push_back(c);
      }
    }
  }
  out.timing.prepare_ms = ms_since(t0);

  t0 = Clock::now();
  const std::vector<SinkhornResult> ranked = solve(ctx, rank, SinkhornOptions{});
  out.timing.ranking_ms = ms_since(t0);

  // Eq. 7 with the SPEC's score: each term divided by its largest value over the sector's
  // candidates, summed; the smallest wins.
  t0 = Clock::now();
  SinkhornBatch transport;
  std::vector<long> transport_of(sectors.size(), -1);
  std::vector<bool> transport_hits(sectors.size(), false);
  for (std::size_t s = 0; s < sectors.size(); ++s) {
    if (cands[s].empty()) continue;
    double hmax = 0, fmax = 0;
    for (const Candidate& c : cands[s]) {
      if (c.hits_problem >= 0) hmax = std::max(hmax, ranked[c.hits_problem].cost);
      if (c.free_problem >= 0) fmax = std::max(fmax, ranked[c.free_problem].cost);
    }
    double best = std::numeric_limits<double>::infinity();
    const Candidate* win = nullptr;
    for (const Candidate& c : cands[s]) {
      double score = 0;
      if (c.hits_problem >= 0) score += hmax > 0 ? ranked[c.hits_problem].cost / hmax : 0;
      if (c.free_problem >= 0) score += fmax > 0 ? ranked[c.free_problem].cost / fmax : 0;
      if (score < best) {
        best = score;
        win = &c;
      }
    }
    SectorTransfer& st = out.sectors[s];
    st.atom = static_cast<long>(win->atom);
    st.rotation = win->angle;
    st.score = best;
    st.rank_converged = (win->hits_problem < 0 || ranked[win->hits_problem].converged) &&
                        (win->free_problem < 0 || ranked[win->free_problem].converged);

    // High-quality transport between hits, or free samples where either side has none.
    const Atom& atom = dict.atoms[win->atom];
    const Sector& sec = sectors[s];
    const bool hits = sec.num_hits() > 0 && atom.sector.num_hits() > 0;
    const auto& src_pts = hits ? atom.sector.hits : atom.sector.free;
    const auto& tgt_pts = hits ? sec.hits : sec.free;
    if (src_pts.empty() || tgt_pts.empty() || atom.kernels.empty()) continue;
    SinkhornProblem p;
    p.source = subsample(src_pts, dim, o.transport_points, mix(o.seed, win->atom, 3));
    p.target = subsample(tgt_pts, dim, o.transport_points,
                         mix(o.seed ^ 0x7a5, t_index, 2 * sec.index + (hits ? 0 : 1)));
    p.angle = win->angle;
    p.epsilon = o.transport_epsilon;
    p.max_iterations = o.transport_max_iterations;
    p.tolerance = o.transport_tolerance;
    p.normalise_cost = true;
    p.extra_points = kernel_positions(atom.kernels);
    transport_of[s] = static_cast<long>(transport.add(std::move(p)));
    transport_hits[s] = hits;
  }
  out.timing.prepare_ms += ms_since(t0);

  t0 = Clock::now();
  SinkhornOptions topt;
  topt.want_barycentric = true;
  const std::vector<SinkhornResult> moved = solve(ctx, transport, topt);
  out.timing.transport_ms = ms_since(t0);

  // Placement (SPEC step 5): unscale, move to the target sector's centre, drop what lands
  // beyond max_range of the sensor.
  t0 = Clock::now();
  const double r2max = so.max_range * so.max_range;
  double w[3];
  for (std::size_t s = 0; s < sectors.size(); ++s) {
    if (transport_of[s] < 0) continue;
    const SinkhornResult& r = moved[transport_of[s]];
    SectorTransfer& st = out.sectors[s];
    st.transport_converged = r.converged;
    st.transport_iterations = r.iterations;
    const Sector& sec = sectors[s];
    const KernelMap& k = dict.atoms[st.atom].kernels;
    for (Eigen::Index e = 0; e < r.extra_mapped.rows(); ++e) {
      double r2 = 0;
      for (int d = 0; d < dim; ++d) {
        w[d] = r.extra_mapped(e, d) / sec.scale + sec.centre[d];
        if (d < 2) r2 += (w[d] - sensor[d]) * (w[d] - sensor[d]);
      }
      if (!(r2 <= r2max)) {
        ++st.kernels_dropped;
        continue;
      }
      out.map.push_back(w, k.gamma[e], k.w_mean[e], k.w_var[e]);
      ++st.kernels_placed;
    }
  }
  out.timing.placement_ms = ms_since(t0);

  if (o.refine && !out.map.empty() && !train.empty()) {
    t0 = Clock::now();
    if (ctx)
      bhm_update(*ctx, out.map, train, o.refine_bhm);
    else
      bhm_update_reference(out.map, train, o.refine_bhm);
    out.timing.refine_ms = ms_since(t0);
  }
  return out;
}

}  // namespace potmap
