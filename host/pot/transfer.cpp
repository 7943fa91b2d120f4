// One scan through POT (SPEC section 4, steps 2 to 7), in named stages: cut and assemble the
// ranking (prepare_transfer), rank (ranking.cpp), assemble and solve the high-quality transport
// of the winners (one batched launch), place each sector's kernels, refine (RePOT).

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <string>

#include "atom_transport_cache.hpp"
#include "placement_at_samples.hpp"
#include "point_proximity.hpp"
#include "potmap/error.hpp"
#include "potmap/ot/sinkhorn.hpp"
#include "potmap/pot/transfer.hpp"
#include "ranking.hpp"
#include "refine.hpp"
#include "runtime/host_team.hpp"
#include "thinning.hpp"

namespace potmap {

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
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
  if (o.rank_hits < 1 || o.rank_free < 1 || o.transport_points < 1 || o.transport_free_points < 1)
    bad("rank_hits, rank_free, transport_points and transport_free_points must be >= 1");
  if (!(o.rank_epsilon > 0) || !(o.transport_epsilon > 0)) bad("epsilons must be positive");
  if (o.rank_max_iterations < 1 || o.transport_max_iterations < 1)
    bad("iteration limits must be >= 1");
  if (!(o.rank_tolerance > 0) || !(o.transport_tolerance > 0) || !(o.coarse_tolerance > 0) ||
      !(o.transport_free_tolerance > 0))
    bad("tolerances must be positive");
  if (!(o.anchor_clearance >= 0) || !std::isfinite(o.anchor_clearance))
    bad("anchor_clearance must be a finite number >= 0, got " + std::to_string(o.anchor_clearance));
  if (o.anchor_sweeps < 0)
    bad("anchor_sweeps must be >= 0, got " + std::to_string(o.anchor_sweeps));
  if (!(o.logit_gain > 0) || !std::isfinite(o.logit_gain))
    bad("logit_gain must be a positive number, got " + std::to_string(o.logit_gain));
  if (o.ranking == PotRanking::indexed &&
      (o.index_neighbours < 1 || o.index_rotations < 1 || o.coarse_hits < 1 || o.coarse_free < 1))
    bad("index_neighbours, index_rotations, coarse_hits and coarse_free must be >= 1");
  if (o.index && o.index->size() != dict.size())
    bad("PotOptions::index describes " + std::to_string(o.index->size()) +
        " atoms, the dictionary has " + std::to_string(dict.size()));
  if (o.preselector && o.preselector->size() != dict.size())
    bad("PotOptions::preselector describes " + std::to_string(o.preselector->size()) +
        " atoms, the dictionary has " + std::to_string(dict.size()));
}

// The high-quality transports of the winners, one batch for the scan: per sector the index of
// its hits problem and of its free-sample problem (-1: none).
struct Transport {
  SinkhornBatch batch;
  std::vector<std::array<long, 2>> of;
};

// Per sector and class (0 hits, 1 free samples) the target's samples of the high-quality
// transport, thinned evenly to its caps (empty where the sector has none). They depend on the
// scan alone, so they are thinned while the device ranks.
using TransportTargets = std::vector<std::array<Eigen::MatrixXd, 2>>;

TransportTargets transport_targets(const std::vector<Sector>& sectors, int dim,
                                   const PotOptions& o) {
  TransportTargets t(sectors.size());
  for (std::size_t s = 0; s < sectors.size(); ++s) {
    if (sectors[s].num_hits() > 0)
      t[s][0] = detail::subsample_even(sectors[s].hits, dim, o.transport_points);
    if (sectors[s].num_free() > 0)
      t[s][1] = detail::subsample_even(sectors[s].free, dim, o.transport_free_points);
  }
  return t;
}

// High-quality transport between hits and, with transport_free, between free samples too (free
// samples alone where either side has no hits). `targets`: transport_targets(sectors), moved
// into the problems.
Transport assemble_transport(const Dictionary& dict, const std::vector<Sector>& sectors,
                             const std::vector<detail::Winner>& winners, const PotOptions& o,
                             TransportTargets&& targets) {
  Transport t;
  t.of.assign(sectors.size(), {-1, -1});
  AtomTransportCache* cache = o.index ? o.index->transport_cache() : nullptr;
  for (std::size_t s = 0; s < sectors.size(); ++s) {
    if (winners[s].atom < 0) continue;
    const Atom& atom = dict.atoms[winners[s].atom];
    const Sector& sec = sectors[s];
    if (atom.kernels.empty()) continue;
    const bool hits = sec.num_hits() > 0 && atom.sector.num_hits() > 0;
    const bool frees = sec.num_free() > 0 && atom.sector.num_free() > 0;
    auto add = [&](int cls, std::size_t cap, double tolerance) {
      SinkhornProblem p;
      const std::size_t a = static_cast<std::size_t>(winners[s].atom);
      p.source = cache ? cache->thinned(atom, a, cls, cap)
                       : detail::subsample_even(cls == 0 ? atom.sector.hits : atom.sector.free,
                                                dict.dim, cap);
      p.target = std::move(targets[s][cls]);
      p.angle = winners[s].angle;
      p.epsilon = o.transport_epsilon;
      p.max_iterations = o.transport_max_iterations;
      p.tolerance = tolerance;
      p.normalise_cost = true;
      return static_cast<long>(t.batch.add(std::move(p)));
    };
    if (hits) t.of[s][0] = add(0, o.transport_points, o.transport_tolerance);
    if (frees && (o.transport_free || !hits))
      t.of[s][1] = add(1, o.transport_free_points, o.transport_free_tolerance);
  }
  return t;
}

// Placement of one sector (SPEC step 5): the out-of-sample map over the union of the
// transported samples (a kernel follows the sample nearest to it, hit or free, through that
// sample's own plan), the filters, unscaling, the move to the target sector's centre, and the
// drop of what lands beyond max_range of the sensor.
void place_sector(const Dictionary& dict, const Sector& sec, const Transport& t,
                  const std::array<long, 2>& problems, const std::vector<SinkhornResult>& moved,
                  const PreparedTransfer& pt, const PotOptions& o, SectorTransfer& st,
                  KernelMap& out) {
  const int dim = dict.dim;
  st.transport_converged = true;
  SinkhornProblem joint;
  Eigen::MatrixXd bary;
  for (long i : problems) {
    if (i < 0) continue;
    const SinkhornResult& r = moved[i];
    const SinkhornProblem& p = t.batch.problem(i);
    st.transport_converged = st.transport_converged && r.converged;
    st.transport_iterations = std::max(st.transport_iterations, r.iterations);
    joint.angle = p.angle;
    const Eigen::Index n0 = joint.source.rows();
    joint.source.conservativeResize(n0 + p.source.rows(), dim);
    joint.source.bottomRows(p.source.rows()) = p.source;
    bary.conservativeResize(n0 + r.barycentric.rows(), dim);
    bary.bottomRows(r.barycentric.rows()) = r.barycentric;
  }
  const KernelMap& k = dict.atoms[st.atom].kernels;
  const Eigen::MatrixXd kpos = kernel_positions(k);
  const Eigen::MatrixXd mapped = out_of_sample_map(joint, bary, kpos);
  std::vector<double> samples;
  std::unique_ptr<detail::PointProximity> near;
  if (o.max_sample_distance > 0) {
    samples = sec.hits;
    samples.insert(samples.end(), sec.free.begin(), sec.free.end());
    near =
        std::make_unique<detail::PointProximity>(samples, dim, o.max_sample_distance * sec.scale);
  }
  std::unique_ptr<detail::PointProximity> on_wall;
  if (o.wall_clearance > 0 && sec.num_hits() > 0)
    on_wall = std::make_unique<detail::PointProximity>(sec.hits, dim, o.wall_clearance * sec.scale);
  const double r2max = pt.max_range * pt.max_range;
  const double c = std::cos(joint.angle), sn = std::sin(joint.angle);
  double w[3];
  for (Eigen::Index e = 0; e < mapped.rows(); ++e) {
    double q[3] = {0, 0, 0};
    for (int d = 0; d < dim; ++d) q[d] = mapped(e, d);
    // Free-space evidence (a negative weight) landing on a wall the scan sees, or wall evidence
    // landing where the scan sees no wall, is a wrong transfer.
    const bool wrong_side = on_wall && (k.w_mean[e] < 0) == on_wall->near(q);
    if (wrong_side || (near && !near->near(q))) {
      ++st.kernels_dropped;
      continue;
    }
    double r2 = 0;
    for (int d = 0; d < dim; ++d) {
      w[d] = mapped(e, d) / sec.scale + sec.centre[d];
      if (d < 2) r2 += (w[d] - pt.sensor[d]) * (w[d] - pt.sensor[d]);
    }
    if (!(r2 <= r2max)) {
      ++st.kernels_dropped;
      continue;
    }
    double var = k.w_var[e];
    if (o.displacement_variance > 0) {
      // How far the plan had to move the kernel beyond the candidate's rotation: a kernel that
      // needed a long move came from a place that does not look like this one.
      const double hx = kpos(e, 0), hy = kpos(e, 1);
      double m2 = std::pow(mapped(e, 0) - (c * hx - sn * hy), 2) +
                  std::pow(mapped(e, 1) - (sn * hx + c * hy), 2);
      if (dim == 3) m2 += std::pow(mapped(e, 2) - kpos(e, 2), 2);
      var += o.displacement_variance * m2 / (sec.scale * sec.scale);
    }
    out.push_back(w, k.gamma[e], k.w_mean[e], var);
    ++st.kernels_placed;
  }
}

// The anchor sites of sector s for its transport problems (none where it has none).
AnchorSites sector_sites(const Sector& sec, const SinkhornBatch& batch,
                         const std::array<long, 2>& of, const PotOptions& o) {
  std::array<const Eigen::MatrixXd*, 2> targets{nullptr, nullptr};
  for (int q = 0; q < 2; ++q)
    if (of[q] >= 0) targets[q] = &batch.problem(of[q]).target;
  return detail::anchor_sites(sec, targets, o);
}

// The anchors of sector s on the target's samples (PotPlacement::target_samples) at `sites`,
// its transport's convergence and counts into st.
void anchor_sector(const Dictionary& dict, const Sector& sec, const Transport& transport,
                   const std::vector<SinkhornResult>& moved, std::size_t s, const PotOptions& o,
                   AtomTransportCache* cache, const AnchorSites& sites, SectorTransfer& st,
                   std::vector<detail::Anchor>& anchors) {
  const auto& of = transport.of[s];
  if (of[0] < 0 && of[1] < 0) return;
  detail::SectorPlans plans;
  st.transport_converged = true;
  for (int q = 0; q < 2; ++q) {
    if (of[q] < 0) continue;
    const SinkhornProblem& p = transport.batch.problem(of[q]);
    plans.source[q] = &p.source;
    plans.target[q] = &p.target;
    plans.coupling[q] = &moved[of[q]].coupling;
    plans.angle = p.angle;
    st.transport_converged = st.transport_converged && moved[of[q]].converged;
    st.transport_iterations = std::max(st.transport_iterations, moved[of[q]].iterations);
  }
  const Atom& atom = dict.atoms[st.atom];
  const auto a = static_cast<std::size_t>(st.atom);
  const detail::KernelClasses* classes = cache ? &cache->classes(atom, a) : nullptr;
  for (int q = 0; q < 2 && cache; ++q)
    if (of[q] >= 0)
      plans.source_map[q] = cache->sample_map(
          atom, a, q, q == 0 ? o.transport_points : o.transport_free_points, sec.scale);
  st.kernels_dropped += detail::anchors_at_samples(atom, sec, plans, sites, o, anchors, classes);
  st.kernels_placed += anchors.size();
}

// RePOT (SPEC step 7): the transported weights refined on the scan's own training samples.
void refine_weights(Context* ctx, const LabelledPoints& train, const PotOptions& o,
                    KernelMap& map) {
  for (double& v : map.w_var) v = std::max(v, o.refine_min_variance);
  if (o.refine_joint)
    detail::refine_joint(map, train, o.refine_bhm);
  else if (ctx)
    bhm_update(*ctx, map, train, o.refine_bhm);
  else
    bhm_update_reference(map, train, o.refine_bhm);
}

}  // namespace

PreparedTransfer prepare_transfer(const Dictionary& dict, LabelledPoints train,
                                  const std::array<double, 3>& sensor, double heading,
                                  std::int64_t scan_index, const PotOptions& o,
                                  const std::vector<long>& warm_atoms, Context* ctx) {
  check(dict, train, o);
  const auto t0 = Clock::now();
  PreparedTransfer pt;
  pt.sensor = sensor;
  pt.scan_index = scan_index;
  SectorOptions so;
  so.sectors = o.sectors;
  so.max_range = o.max_range > 0 ? o.max_range : dict.max_range;
  so.scale = dict.scale;
  so.min_samples = o.min_samples;
  pt.max_range = so.max_range;
  pt.sectors = cut_sectors(train, sensor, heading, so);
  detail::assemble_ranking(ctx, dict, o, warm_atoms, pt);
  pt.train = std::move(train);
  pt.timing.prepare_ms = ms_since(t0);
  return pt;
}

SolvedTransfer solve_transfer(Context* ctx, const Dictionary& dict, PreparedTransfer&& pt,
                              const PotOptions& o) {
  SolvedTransfer sv;
  ScanTransfer& out = sv.transfer;
  out.map.dim = dict.dim;
  out.timing = pt.timing;
  const std::vector<Sector>& sectors = pt.sectors;
  TransportTargets targets;
  const std::vector<detail::Winner> winners = detail::rank_sectors(
      ctx, dict, pt, o, out.timing, [&] { targets = transport_targets(sectors, dict.dim, o); });
  for (std::size_t s = 0; s < sectors.size(); ++s) {
    SectorTransfer st;
    st.sector = sectors[s].index;
    st.target_hits = sectors[s].num_hits();
    st.target_free = sectors[s].num_free();
    st.atom = winners[s].atom;
    st.rotation = winners[s].angle;
    st.score = winners[s].atom >= 0 ? winners[s].score : 0;
    st.rank_converged = winners[s].converged;
    out.sectors.push_back(st);
  }

  auto t0 = Clock::now();
  Transport transport = assemble_transport(dict, sectors, winners, o, std::move(targets));
  out.timing.prepare_ms += ms_since(t0);
  t0 = Clock::now();
  SinkhornOptions topt;
  const bool at_samples = o.placement == PotPlacement::target_samples;
  topt.want_barycentric = !at_samples;
  topt.want_coupling = at_samples;
  topt.want_duals = false;  // the placement reads the plans, never the potentials
  topt.double_sums =
      !single_sums_reach(std::min(o.transport_tolerance, o.transport_free_tolerance));
  detail::PendingSolve moving(ctx, transport.batch, topt);
  // Where the kernels will sit does not depend on the plans: found while the device solves.
  if (at_samples)
    for (std::size_t s = 0; s < sectors.size(); ++s)
      sv.anchor_sites.push_back(sector_sites(sectors[s], transport.batch, transport.of[s], o));
  sv.plans = moving.wait();
  out.timing.transport_ms = ms_since(t0);
  sv.transport = std::move(transport.batch);
  sv.problem_of = std::move(transport.of);
  sv.prepared = std::move(pt);
  return sv;
}

ScanTransfer place_transfer(Context* ctx, const Dictionary& dict, SolvedTransfer&& sv,
                            const PotOptions& o) {
  ScanTransfer out = std::move(sv.transfer);
  const PreparedTransfer& pt = sv.prepared;
  const std::vector<Sector>& sectors = pt.sectors;
  if (sectors.size() != out.sectors.size() || sv.problem_of.size() != sectors.size() ||
      sv.plans.size() != sv.transport.size())
    throw ArgumentError("place_transfer: the solved transfer's parts disagree in size");
  const bool at_samples = o.placement == PotPlacement::target_samples;
  const Transport transport{std::move(sv.transport), std::move(sv.problem_of)};
  const std::vector<SinkhornResult>& moved = sv.plans;
  const auto t0 = Clock::now();
  if (!at_samples) {
    for (std::size_t s = 0; s < sectors.size(); ++s) {
      const auto& of = transport.of[s];
      if (of[0] < 0 && of[1] < 0) continue;
      place_sector(dict, sectors[s], transport, of, moved, pt, o, out.sectors[s], out.map);
    }
  } else {
    // Each sector's anchors on the context's host team, joined in sector order: the anchors
    // one sector after the other would give.
    std::vector<std::vector<detail::Anchor>> anchors(sectors.size());
    AtomTransportCache* cache = o.index ? o.index->transport_cache() : nullptr;
    // Sites not found beside the transport (a SolvedTransfer made elsewhere) are found here.
    const bool found = sv.anchor_sites.size() == sectors.size();
    if (!found) sv.anchor_sites.assign(sectors.size(), AnchorSites{});
    detail::for_each_item(ctx, sectors.size(), [&](std::size_t s) {
      if (!found)
        sv.anchor_sites[s] = sector_sites(sectors[s], transport.batch, transport.of[s], o);
      anchor_sector(dict, sectors[s], transport, moved, s, o, cache, sv.anchor_sites[s],
                    out.sectors[s], anchors[s]);
    });
    std::vector<detail::Anchor> all;
    for (const auto& a : anchors) all.insert(all.end(), a.begin(), a.end());
    detail::anchors_to_map(all, dict.dim, out.map, o.anchor_sweeps, o.logit_gain);
  }
  out.timing.placement_ms = ms_since(t0);

  if (o.refine && !out.map.empty() && !pt.train.empty()) {
    const auto t1 = Clock::now();
    refine_weights(ctx, pt.train, o, out.map);
    out.timing.refine_ms = ms_since(t1);
  }
  return out;
}

ScanTransfer finish_transfer(Context* ctx, const Dictionary& dict, PreparedTransfer&& pt,
                             const PotOptions& o) {
  return place_transfer(ctx, dict, solve_transfer(ctx, dict, std::move(pt), o), o);
}

std::vector<long> chosen_atoms(const SolvedTransfer& solved) {
  return chosen_atoms(solved.transfer);
}

std::vector<long> chosen_atoms(const ScanTransfer& transfer) {
  std::vector<long> out;
  for (const SectorTransfer& s : transfer.sectors)
    if (s.atom >= 0) out.push_back(s.atom);
  return out;
}

ScanTransfer transfer_scan(Context* ctx, const Dictionary& dict, const LabelledPoints& train,
                           const std::array<double, 3>& sensor, double heading,
                           std::int64_t scan_index, const PotOptions& options) {
  return finish_transfer(
      ctx, dict, prepare_transfer(dict, train, sensor, heading, scan_index, options, {}, ctx),
      options);
}

PotOptions PotOptions::paper() {
  PotOptions p;
  p.ranking = PotRanking::exhaustive;
  p.placement = PotPlacement::barycentric;
  p.wall_clearance = 0;
  return p;
}

std::vector<double> evenly_spaced_rotations(int n) {
  std::vector<double> r;
  for (int i = 0; i < n; ++i) r.push_back(2 * 3.14159265358979323846 * i / n);
  return r;
}

}  // namespace potmap
