// One scan through POT (SPEC section 4, steps 2 to 7). The ranking of every (sector, atom,
// rotation) candidate is one batched Sinkhorn solve, the high-quality transport of the winners
// another; everything else is bookkeeping on the host.

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <string>

#include "data/sim_rng.hpp"
#include "point_proximity.hpp"
#include "potmap/error.hpp"
#include "potmap/ot/sinkhorn.hpp"
#include "potmap/pot/transfer.hpp"
#include "refine.hpp"

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

// At most `cap` points spread evenly over the cloud: one point (the first in input order) per
// cell of the finest square (cubic) grid that has at most `cap` occupied cells, found by
// bisection on the cell size. A random subsample keeps the cloud's density, so two random
// subsamples of matching places differ point by point and their plan is noisy and slow to
// converge; evenly spread ones look alike (measured on the built-in towns: at 200 free samples
// a side the transport converged in a third of the time and the maps scored as well as with
// every sample).
Eigen::MatrixXd subsample_even(const std::vector<double>& pts, int dim, std::size_t cap) {
  const std::size_t n = pts.size() / dim;
  std::vector<std::size_t> keep;
  if (n > cap) {
    double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    for (int d = 0; d < dim; ++d) lo[d] = hi[d] = pts[d];
    for (std::size_t i = 0; i < n; ++i)
      for (int d = 0; d < dim; ++d) {
        lo[d] = std::min(lo[d], pts[i * dim + d]);
        hi[d] = std::max(hi[d], pts[i * dim + d]);
      }
    double extent = 0;
    for (int d = 0; d < dim; ++d) extent = std::max(extent, hi[d] - lo[d]);
    // Occupied cells (and the first point of each, in input order) for a cell size, counted in
    // an open-addressing table: this runs a dozen times per call, twice per sector and scan.
    std::size_t slots = 1;
    while (slots < 2 * n) slots <<= 1;
    std::vector<std::uint64_t> table(slots);
    auto cells = [&](double cell, std::vector<std::size_t>* firsts) {
      std::fill(table.begin(), table.end(), 0);
      std::size_t count = 0;
      for (std::size_t i = 0; i < n; ++i) {
        std::uint64_t key = 1;  // 0 marks an empty slot
        for (int d = 0; d < dim; ++d)
          key = (key << 21) | static_cast<std::uint64_t>((pts[i * dim + d] - lo[d]) / cell);
        std::size_t h = static_cast<std::size_t>((key * 0x9e3779b97f4a7c15ULL) >> 20) & (slots - 1);
        while (table[h] != 0 && table[h] != key) h = (h + 1) & (slots - 1);
        if (table[h] == 0) {
          table[h] = key;
          ++count;
          if (firsts) firsts->push_back(i);
        }
      }
      return count;
    };
    // Cells of extent / 2^20 keep every distinct point apart; a cell of the whole extent holds
    // them all. Bisect the cell size between the two on a log scale.
    double small = extent / (1 << 20), large = extent * 1.0001;
    if (extent > 0) {
      for (int round = 0; round < 24 && large / small > 1.03; ++round) {
        const double mid = std::sqrt(small * large);
        (cells(mid, nullptr) > cap ? small : large) = mid;
      }
      cells(large, &keep);
    } else {
      keep.push_back(0);  // every point at the same place
    }
  } else {
    keep.resize(n);
    std::iota(keep.begin(), keep.end(), std::size_t{0});
  }
  Eigen::MatrixXd out(keep.size(), dim);
  for (std::size_t i = 0; i < keep.size(); ++i)
    for (int d = 0; d < dim; ++d) out(i, d) = pts[keep[i] * dim + d];
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
  if (o.rank_hits < 1 || o.rank_free < 1 || o.transport_points < 1 || o.transport_free_points < 1)
    bad("rank_hits, rank_free, transport_points and transport_free_points must be >= 1");
  if (!(o.rank_epsilon > 0) || !(o.transport_epsilon > 0)) bad("epsilons must be positive");
  if (o.rank_max_iterations < 1 || o.transport_max_iterations < 1)
    bad("iteration limits must be >= 1");
  if (!(o.rank_tolerance > 0) || !(o.transport_tolerance > 0)) bad("tolerances must be positive");
  if (o.preselector && o.preselector->size() != dict.size())
    bad("PotOptions::preselector describes " + std::to_string(o.preselector->size()) +
        " atoms, the dictionary has " + std::to_string(dict.size()));
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

}  // namespace

PreparedTransfer prepare_transfer(const Dictionary& dict, LabelledPoints train,
                                  const std::array<double, 3>& sensor, double heading,
                                  std::int64_t scan_index, const PotOptions& o) {
  check(dict, train, o);
  const int dim = dict.dim;
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

  SinkhornProblem proto;
  proto.epsilon = o.rank_epsilon;
  proto.max_iterations = o.rank_max_iterations;
  proto.tolerance = o.rank_tolerance;
  pt.candidates.resize(pt.sectors.size());
  const bool preselect = o.candidates > 0 && o.candidates < dict.size();
  std::shared_ptr<const AtomPreselector> pre = o.preselector;
  if (preselect && !pre) pre = std::make_shared<const AtomPreselector>(dict);
  std::vector<std::size_t> every;
  if (!preselect) {
    every.resize(dict.size());
    std::iota(every.begin(), every.end(), std::size_t{0});
  }
  for (std::size_t s = 0; s < pt.sectors.size(); ++s) {
    const Sector& sec = pt.sectors[s];
    std::vector<std::size_t> selected;
    if (preselect) selected = pre->select(sec, o.candidates);
    const std::vector<std::size_t>& chosen = preselect ? selected : every;
    const Eigen::MatrixXd th =
        subsample(sec.hits, dim, o.rank_hits, mix(o.seed ^ 0x5eed, t_index, 2 * sec.index));
    const Eigen::MatrixXd tf =
        subsample(sec.free, dim, o.rank_free, mix(o.seed ^ 0x5eed, t_index, 2 * sec.index + 1));
    // Each term (hits, free) is an OT problem when both sides have such samples. When only one
    // side has them the shapes disagree as much as they can: the term scores its largest
    // normalised value, 1 (a target sector without hits prefers atoms without hits).
    for (std::size_t a : chosen) {
      const AtomSample& as = sample_of(a);
      const bool hm = (th.rows() > 0) != (as.hits.rows() > 0);
      const bool fm = (tf.rows() > 0) != (as.free.rows() > 0);
      const bool hp = th.rows() > 0 && as.hits.rows() > 0;
      const bool fp = tf.rows() > 0 && as.free.rows() > 0;
      if (!hp && !fp) continue;  // nothing to match the atom with
      for (double angle : o.rotations) {
        PreparedTransfer::Candidate c;
        c.atom = a;
        c.angle = angle;
        c.hits_mismatch = hm;
        c.free_mismatch = fm;
        SinkhornProblem p = proto;
        p.angle = angle;
        if (hp) {
          p.source = as.hits;
          p.target = th;
          c.hits_problem = static_cast<long>(pt.ranking.add(p));
        }
        if (fp) {
          p.source = as.free;
          p.target = tf;
          c.free_problem = static_cast<long>(pt.ranking.add(std::move(p)));
        }
        pt.candidates[s].push_back(c);
      }
    }
  }
  pt.train = std::move(train);
  pt.timing.prepare_ms = ms_since(t0);
  return pt;
}

ScanTransfer finish_transfer(Context* ctx, const Dictionary& dict, PreparedTransfer&& pt,
                             const PotOptions& o) {
  const int dim = dict.dim;
  ScanTransfer out;
  out.map.dim = dim;
  out.timing = pt.timing;
  const auto& sectors = pt.sectors;
  const auto& cands = pt.candidates;
  for (const Sector& sec : sectors) {
    SectorTransfer st;
    st.sector = sec.index;
    st.target_hits = sec.num_hits();
    st.target_free = sec.num_free();
    out.sectors.push_back(st);
  }

  auto t0 = Clock::now();
  const std::vector<SinkhornResult> ranked = solve(ctx, pt.ranking, SinkhornOptions{});
  out.timing.ranking_ms = ms_since(t0);
  // Eq. 7 with the SPEC's score: each term divided by its largest value over the sector's
  // candidates, summed; the smallest wins.
  t0 = Clock::now();
  SinkhornBatch transport;
  std::vector<std::array<long, 2>> transport_of(sectors.size(), {-1, -1});  // hits, free
  for (std::size_t s = 0; s < sectors.size(); ++s) {
    if (cands[s].empty()) continue;
    double hmax = 0, fmax = 0;
    for (const PreparedTransfer::Candidate& c : cands[s]) {
      if (c.hits_problem >= 0) hmax = std::max(hmax, ranked[c.hits_problem].cost);
      if (c.free_problem >= 0) fmax = std::max(fmax, ranked[c.free_problem].cost);
    }
    double best = std::numeric_limits<double>::infinity();
    const PreparedTransfer::Candidate* win = nullptr;
    for (const PreparedTransfer::Candidate& c : cands[s]) {
      double score = 0;
      if (c.hits_problem >= 0) score += hmax > 0 ? ranked[c.hits_problem].cost / hmax : 0;
      if (c.free_problem >= 0) score += fmax > 0 ? ranked[c.free_problem].cost / fmax : 0;
      score += static_cast<double>(c.hits_mismatch) + static_cast<double>(c.free_mismatch);
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

    // High-quality transport between hits and, with transport_free, between free samples too
    // (free samples alone where either side has no hits).
    const Atom& atom = dict.atoms[win->atom];
    const Sector& sec = sectors[s];
    if (atom.kernels.empty()) continue;
    const bool hits = sec.num_hits() > 0 && atom.sector.num_hits() > 0;
    const bool frees = sec.num_free() > 0 && atom.sector.num_free() > 0;
    auto add = [&](const std::vector<double>& src_pts, const std::vector<double>& tgt_pts,
                   int which) {
      SinkhornProblem p;
      const std::size_t cap = which == 1 ? o.transport_free_points : o.transport_points;
      p.source = subsample_even(src_pts, dim, cap);
      p.target = subsample_even(tgt_pts, dim, cap);
      p.angle = win->angle;
      p.epsilon = o.transport_epsilon;
      p.max_iterations = o.transport_max_iterations;
      p.tolerance = o.transport_tolerance;
      p.normalise_cost = true;
      return static_cast<long>(transport.add(std::move(p)));
    };
    if (hits) transport_of[s][0] = add(atom.sector.hits, sec.hits, 0);
    if (frees && (o.transport_free || !hits))
      transport_of[s][1] = add(atom.sector.free, sec.free, 1);
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
  const double r2max = pt.max_range * pt.max_range;
  double w[3];
  for (std::size_t s = 0; s < sectors.size(); ++s) {
    const auto& tp = transport_of[s];
    if (tp[0] < 0 && tp[1] < 0) continue;
    SectorTransfer& st = out.sectors[s];
    st.transport_converged = true;
    // The out-of-sample map over the union of the transported samples: a kernel follows the
    // sample nearest to it, hit or free, through that sample's own plan.
    SinkhornProblem joint;
    Eigen::MatrixXd bary;
    for (long i : tp) {
      if (i < 0) continue;
      const SinkhornResult& r = moved[i];
      const SinkhornProblem& p = transport.problem(i);
      st.transport_converged = st.transport_converged && r.converged;
      st.transport_iterations = std::max(st.transport_iterations, r.iterations);
      joint.angle = p.angle;
      const Eigen::Index n0 = joint.source.rows();
      joint.source.conservativeResize(n0 + p.source.rows(), dim);
      joint.source.bottomRows(p.source.rows()) = p.source;
      bary.conservativeResize(n0 + r.barycentric.rows(), dim);
      bary.bottomRows(r.barycentric.rows()) = r.barycentric;
    }
    const Sector& sec = sectors[s];
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
      on_wall =
          std::make_unique<detail::PointProximity>(sec.hits, dim, o.wall_clearance * sec.scale);
    for (Eigen::Index e = 0; e < mapped.rows(); ++e) {
      if (on_wall) {
        double q[3] = {0, 0, 0};
        for (int d = 0; d < dim; ++d) q[d] = mapped(e, d);
        // Free-space evidence (a negative weight) landing on a wall the scan sees, or wall
        // evidence landing where the scan sees no wall, is a wrong transfer.
        if ((k.w_mean[e] < 0) == on_wall->near(q)) {
          ++st.kernels_dropped;
          continue;
        }
      }
      if (near) {
        double q[3] = {0, 0, 0};
        for (int d = 0; d < dim; ++d) q[d] = mapped(e, d);
        if (!near->near(q)) {
          ++st.kernels_dropped;
          continue;
        }
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
        // How far the plan had to move the kernel beyond the candidate's rotation: a kernel
        // that needed a long move came from a place that does not look like this one.
        const double c = std::cos(joint.angle), sn = std::sin(joint.angle);
        const double hx = kpos(e, 0), hy = kpos(e, 1);
        double m2 = std::pow(mapped(e, 0) - (c * hx - sn * hy), 2) +
                    std::pow(mapped(e, 1) - (sn * hx + c * hy), 2);
        if (dim == 3) m2 += std::pow(mapped(e, 2) - kpos(e, 2), 2);
        var += o.displacement_variance * m2 / (sec.scale * sec.scale);
      }
      out.map.push_back(w, k.gamma[e], k.w_mean[e], var);
      ++st.kernels_placed;
    }
  }
  out.timing.placement_ms = ms_since(t0);

  const LabelledPoints& train = pt.train;
  if (o.refine && !out.map.empty() && !train.empty()) {
    t0 = Clock::now();
    for (double& v : out.map.w_var) v = std::max(v, o.refine_min_variance);
    if (o.refine_joint)
      detail::refine_joint(out.map, train, o.refine_bhm);
    else if (ctx)
      bhm_update(*ctx, out.map, train, o.refine_bhm);
    else
      bhm_update_reference(out.map, train, o.refine_bhm);
    out.timing.refine_ms = ms_since(t0);
  }
  return out;
}

ScanTransfer transfer_scan(Context* ctx, const Dictionary& dict, const LabelledPoints& train,
                           const std::array<double, 3>& sensor, double heading,
                           std::int64_t scan_index, const PotOptions& options) {
  return finish_transfer(
      ctx, dict, prepare_transfer(dict, train, sensor, heading, scan_index, options), options);
}

}  // namespace potmap
