// The ranking stage (see ranking.hpp). Exhaustive: every (atom, rotation) candidate solved once
// per score term, terms normalised by their largest value over the sector's candidates.
// Indexed: the index's nearest atoms (and the recent winners) at their estimated rotations,
// solved on small evenly thinned samples, the best few solved again at the ranking's caps.
#include "ranking.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <numeric>

#include "runtime/host_team.hpp"
#include "thinning.hpp"

namespace potmap::detail {

namespace {

using Clock = std::chrono::steady_clock;
using Candidate = PreparedTransfer::Candidate;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Subsamples of one atom, made on first use: the ranking's (seeded by the atom index only, the
// same for every scan) or the coarse stage's (evenly thinned).
struct AtomSamples {
  const Dictionary& dict;
  std::size_t hit_cap, free_cap;
  bool even;
  std::uint64_t seed;
  std::vector<std::unique_ptr<std::pair<Eigen::MatrixXd, Eigen::MatrixXd>>> cache;

  AtomSamples(const Dictionary& d, std::size_t hc, std::size_t fc, bool ev, std::uint64_t s)
      : dict(d), hit_cap(hc), free_cap(fc), even(ev), seed(s), cache(d.size()) {}

  const std::pair<Eigen::MatrixXd, Eigen::MatrixXd>& operator()(std::size_t a) {
    auto& c = cache[a];
    if (!c) {
      const Sector& src = dict.atoms[a].sector;
      c = std::make_unique<std::pair<Eigen::MatrixXd, Eigen::MatrixXd>>();
      c->first = even ? subsample_even(src.hits, dict.dim, hit_cap)
                      : subsample(src.hits, dict.dim, hit_cap, mix(seed, a, 1));
      c->second = even ? subsample_even(src.free, dict.dim, free_cap)
                       : subsample(src.free, dict.dim, free_cap, mix(seed, a, 2));
    }
    return *c;
  }
};

// The target sector's samples at the ranking's caps (seeded by scan and sector).
Eigen::MatrixXd target_sample(const Sector& sec, const PotOptions& o, std::int64_t scan,
                              bool hits) {
  const auto t = static_cast<std::uint64_t>(scan);
  return subsample(hits ? sec.hits : sec.free, sec.dim, hits ? o.rank_hits : o.rank_free,
                   mix(o.seed ^ 0x5eed, t, 2 * sec.index + (hits ? 0 : 1)));
}

// Adds a candidate's problems (one per term both sides have) to `batch`. Each term is an OT
// problem when both sides have such samples. When only one side has them the shapes disagree
// as much as they can: the term scores its largest normalised value, 1 (a target sector
// without hits prefers atoms without hits). Returns false when nothing can be matched.
template <class Batch>
bool add_candidate(std::size_t atom, double angle, const Eigen::MatrixXd& ah,
                   const Eigen::MatrixXd& af, const Eigen::MatrixXd& th, const Eigen::MatrixXd& tf,
                   const SinkhornProblem& proto, Batch& batch, Candidate& c) {
  const bool hp = th.rows() > 0 && ah.rows() > 0;
  const bool fp = tf.rows() > 0 && af.rows() > 0;
  if (!hp && !fp) return false;
  c = Candidate{};
  c.atom = atom;
  c.angle = angle;
  c.hits_mismatch = (th.rows() > 0) != (ah.rows() > 0);
  c.free_mismatch = (tf.rows() > 0) != (af.rows() > 0);
  SinkhornProblem p = proto;
  p.angle = angle;
  if (hp) {
    p.source = ah;
    p.target = th;
    c.hits_problem = static_cast<long>(batch.add(p));
  }
  if (fp) {
    p.source = af;
    p.target = tf;
    c.free_problem = static_cast<long>(batch.add(std::move(p)));
  }
  return true;
}

// A sector's problems, gathered apart from the other sectors' and added to the batch after.
struct ProblemList {
  std::vector<SinkhornProblem> problems;
  std::size_t add(SinkhornProblem p) {
    problems.push_back(std::move(p));
    return problems.size() - 1;
  }
};

// The ranking compares costs: the duals stay on the device.
SinkhornOptions costs_only() {
  SinkhornOptions o;
  o.want_duals = false;
  return o;
}

SinkhornProblem ranking_problem(const PotOptions& o) {
  SinkhornProblem p;
  p.epsilon = o.rank_epsilon;
  p.max_iterations = o.rank_max_iterations;
  p.tolerance = o.rank_tolerance;
  return p;
}

// Largest cost of each term over candidates.
std::array<double, 2> term_maxima(const std::vector<Candidate>& cands,
                                  const std::vector<SinkhornResult>& r) {
  std::array<double, 2> m{0, 0};
  for (const Candidate& c : cands) {
    if (c.hits_problem >= 0) m[0] = std::max(m[0], r[c.hits_problem].cost);
    if (c.free_problem >= 0) m[1] = std::max(m[1], r[c.free_problem].cost);
  }
  return m;
}

// Eq. 7 with the SPEC's score: each term divided by its normaliser, summed, plus 1 for each
// term only one side has. Smaller is better.
double score_of(const Candidate& c, const std::vector<SinkhornResult>& r,
                const std::array<double, 2>& norm) {
  double s = static_cast<double>(c.hits_mismatch) + static_cast<double>(c.free_mismatch);
  if (c.hits_problem >= 0) s += norm[0] > 0 ? r[c.hits_problem].cost / norm[0] : 0;
  if (c.free_problem >= 0) s += norm[1] > 0 ? r[c.free_problem].cost / norm[1] : 0;
  return s;
}

bool converged(const Candidate& c, const std::vector<SinkhornResult>& r) {
  return (c.hits_problem < 0 || r[c.hits_problem].converged) &&
         (c.free_problem < 0 || r[c.free_problem].converged);
}

// Best candidate of a sector under `norm`.
Winner best_of(const std::vector<Candidate>& cands, const std::vector<SinkhornResult>& r,
               const std::array<double, 2>& norm) {
  Winner w;
  w.score = std::numeric_limits<double>::infinity();
  for (const Candidate& c : cands) {
    const double s = score_of(c, r, norm);
    if (s < w.score) {
      w.atom = static_cast<long>(c.atom);
      w.angle = c.angle;
      w.score = s;
      w.converged = converged(c, r);
    }
  }
  return w;
}

void assemble_exhaustive(const Dictionary& dict, const PotOptions& o, PreparedTransfer& pt) {
  const bool preselect = o.candidates > 0 && o.candidates < dict.size();
  std::shared_ptr<const AtomPreselector> pre = o.preselector;
  if (preselect && !pre) pre = std::make_shared<const AtomPreselector>(dict);
  std::vector<std::size_t> every;
  if (!preselect) {
    every.resize(dict.size());
    std::iota(every.begin(), every.end(), std::size_t{0});
  }
  AtomSamples atoms(dict, o.rank_hits, o.rank_free, false, o.seed);
  const SinkhornProblem proto = ranking_problem(o);
  for (std::size_t s = 0; s < pt.sectors.size(); ++s) {
    const Sector& sec = pt.sectors[s];
    const std::vector<std::size_t> selected =
        preselect ? pre->select(sec, o.candidates) : std::vector<std::size_t>{};
    const Eigen::MatrixXd th = target_sample(sec, o, pt.scan_index, true);
    const Eigen::MatrixXd tf = target_sample(sec, o, pt.scan_index, false);
    for (std::size_t a : preselect ? selected : every) {
      const auto& as = atoms(a);
      for (double angle : o.rotations) {
        Candidate c;
        if (!add_candidate(a, angle, as.first, as.second, th, tf, proto, pt.ranking, c)) break;
        pt.candidates[s].push_back(c);
      }
    }
  }
}

// The angle of `grid` closest to `angle` on the circle.
double nearest_rotation(double angle, const std::vector<double>& grid) {
  double best = grid.front(), gap = 1e300;
  for (double g : grid) {
    double d = std::fmod(std::abs(angle - g), 2 * M_PI);
    d = std::min(d, 2 * M_PI - d);
    if (d < gap) {
      gap = d;
      best = g;
    }
  }
  return best;
}

void assemble_indexed(Context* ctx, const Dictionary& dict, const PotOptions& o,
                      const std::vector<long>& warm_atoms, PreparedTransfer& pt) {
  std::shared_ptr<const AtomIndex> index = o.index;
  if (!index) index = std::make_shared<const AtomIndex>(dict);
  std::vector<std::size_t> warm;
  if (o.warm_candidates)
    for (long a : warm_atoms)
      if (a >= 0 && static_cast<std::size_t>(a) < dict.size() &&
          std::find(warm.begin(), warm.end(), std::size_t(a)) == warm.end())
        warm.push_back(static_cast<std::size_t>(a));
  AtomSamples atoms(dict, o.coarse_hits, o.coarse_free, true, o.seed);
  std::mutex atoms_mutex;  // its lazy cache, read only when the index lacks these caps
  SinkhornProblem proto = ranking_problem(o);
  proto.tolerance = o.coarse_tolerance;
  const std::size_t ns = pt.sectors.size();
  pt.rank_hits.resize(ns);
  pt.rank_free.resize(ns);
  // Each sector's candidates and problems on their own (the sectors in parallel), then joined
  // in sector order: the same batch as one sector after the other.
  std::vector<ProblemList> batches(ns);
  for_each_item(ctx, ns, [&](std::size_t s) {
    const Sector& sec = pt.sectors[s];
    pt.rank_hits[s] = target_sample(sec, o, pt.scan_index, true);
    pt.rank_free[s] = target_sample(sec, o, pt.scan_index, false);
    const Eigen::MatrixXd th = subsample_even(sec.hits, sec.dim, o.coarse_hits);
    const Eigen::MatrixXd tf = subsample_even(sec.free, sec.dim, o.coarse_free);
    const SectorSignature sig = index->signature(sec);
    std::vector<std::size_t> chosen = index->nearest(sig, o.index_neighbours);
    for (std::size_t a : warm)
      if (std::find(chosen.begin(), chosen.end(), a) == chosen.end()) chosen.push_back(a);
    const std::size_t near = chosen.size();
    // The farthest atoms at their worst estimated angle (the best one turned half a circle)
    // stand for the exhaustive ranking's worst candidates, which set its normalisers.
    if (o.index_anchors)
      for (std::size_t a : index->farthest(sig))
        if (std::find(chosen.begin(), chosen.end(), a) == chosen.end()) chosen.push_back(a);
    const bool stored = index->options().coarse_hits == o.coarse_hits &&
                        index->options().coarse_free == o.coarse_free;
    for (std::size_t i = 0; i < chosen.size(); ++i) {
      const std::size_t a = chosen[i];
      const Eigen::MatrixXd* ah = stored ? &index->coarse_hits(a) : nullptr;
      const Eigen::MatrixXd* af = stored ? &index->coarse_free(a) : nullptr;
      if (!stored) {
        std::lock_guard<std::mutex> lock(atoms_mutex);
        ah = &atoms(a).first;
        af = &atoms(a).second;
      }
      std::vector<double> angles;
      for (const RotationEstimate& r : index->rotations(sig, a, std::max(o.index_rotations, 1))) {
        double angle = i < near ? r.angle : std::fmod(r.angle + M_PI, 2 * M_PI);
        if (o.snap_rotations) angle = nearest_rotation(angle, o.rotations);
        if (std::find(angles.begin(), angles.end(), angle) != angles.end()) continue;
        angles.push_back(angle);
        Candidate c;
        if (!add_candidate(a, angle, *ah, *af, th, tf, proto, batches[s], c)) break;
        pt.candidates[s].push_back(c);
        if (i >= near) break;  // one angle for an anchor
      }
    }
  });
  for (std::size_t s = 0; s < ns; ++s) {
    const auto first = static_cast<long>(pt.ranking.size());
    for (SinkhornProblem& p : batches[s].problems) pt.ranking.add(std::move(p));
    for (Candidate& c : pt.candidates[s]) {
      if (c.hits_problem >= 0) c.hits_problem += first;
      if (c.free_problem >= 0) c.free_problem += first;
    }
  }
}

std::vector<Winner> rank_exhaustive(Context* ctx, const PreparedTransfer& pt, PotTiming& timing,
                                    const std::function<void()>& beside) {
  auto t0 = Clock::now();
  PendingSolve pending(ctx, pt.ranking, costs_only());
  if (beside) beside();
  const std::vector<SinkhornResult> ranked = pending.wait();
  timing.ranking_ms += ms_since(t0);
  std::vector<Winner> out(pt.sectors.size());
  for (std::size_t s = 0; s < pt.sectors.size(); ++s)
    if (!pt.candidates[s].empty())
      out[s] = best_of(pt.candidates[s], ranked, term_maxima(pt.candidates[s], ranked));
  return out;
}

std::vector<Winner> rank_indexed(Context* ctx, const Dictionary& dict, const PreparedTransfer& pt,
                                 const PotOptions& o, PotTiming& timing,
                                 const std::function<void()>& beside) {
  auto t0 = Clock::now();
  SinkhornOptions coarse_options = costs_only();
  coarse_options.double_sums = !single_sums_reach(o.coarse_tolerance);
  PendingSolve pending(ctx, pt.ranking, coarse_options);
  if (beside) beside();
  const std::vector<SinkhornResult> coarse = pending.wait();
  timing.ranking_ms += ms_since(t0);
  const std::size_t ns = pt.sectors.size();
  std::vector<Winner> out(ns);
  std::vector<std::array<double, 2>> norm(ns);
  if (o.fine_candidates == 0) {
    for (std::size_t s = 0; s < ns; ++s)
      if (!pt.candidates[s].empty())
        out[s] = best_of(pt.candidates[s], coarse, term_maxima(pt.candidates[s], coarse));
    return out;
  }

  // The best coarse candidates of each sector, solved again at the ranking's caps.
  t0 = Clock::now();
  AtomSamples atoms(dict, o.rank_hits, o.rank_free, false, o.seed);
  const SinkhornProblem proto = ranking_problem(o);
  SinkhornBatch fine;
  std::vector<std::vector<Candidate>> kept(ns), kept_fine(ns);
  for (std::size_t s = 0; s < ns; ++s) {
    const std::vector<Candidate>& cands = pt.candidates[s];
    if (cands.empty()) continue;
    norm[s] = term_maxima(cands, coarse);
    std::vector<std::size_t> order(cands.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::vector<double> sc(cands.size());
    for (std::size_t i = 0; i < cands.size(); ++i) sc[i] = score_of(cands[i], coarse, norm[s]);
    const std::size_t keep = std::min(o.fine_candidates, cands.size());
    std::partial_sort(
        order.begin(), order.begin() + keep, order.end(),
        [&](std::size_t a, std::size_t b) { return sc[a] != sc[b] ? sc[a] < sc[b] : a < b; });
    for (std::size_t i = 0; i < keep; ++i) {
      const Candidate& c = cands[order[i]];
      const auto& as = atoms(c.atom);
      Candidate f;
      if (!add_candidate(c.atom, c.angle, as.first, as.second, pt.rank_hits[s], pt.rank_free[s],
                         proto, fine, f))
        continue;
      kept[s].push_back(c);
      kept_fine[s].push_back(f);
    }
  }
  timing.prepare_ms += ms_since(t0);
  t0 = Clock::now();
  const std::vector<SinkhornResult> refined = solve(ctx, fine, costs_only());
  timing.ranking_ms += ms_since(t0);

  // The coarse maxima stand for the largest values over the candidates, as the exhaustive
  // ranking normalises; the fine costs are on a scale of their own (more points), so each
  // maximum is rescaled by the survivors' fine over coarse cost.
  for (std::size_t s = 0; s < ns; ++s) {
    if (kept[s].empty()) continue;
    std::array<double, 2> sum_c{0, 0}, sum_f{0, 0};
    for (std::size_t i = 0; i < kept[s].size(); ++i) {
      const Candidate &c = kept[s][i], &f = kept_fine[s][i];
      if (c.hits_problem >= 0 && f.hits_problem >= 0) {
        sum_c[0] += coarse[c.hits_problem].cost;
        sum_f[0] += refined[f.hits_problem].cost;
      }
      if (c.free_problem >= 0 && f.free_problem >= 0) {
        sum_c[1] += coarse[c.free_problem].cost;
        sum_f[1] += refined[f.free_problem].cost;
      }
    }
    std::array<double, 2> n = norm[s];
    for (int k = 0; k < 2; ++k)
      if (sum_c[k] > 0) n[k] *= sum_f[k] / sum_c[k];
    out[s] = best_of(kept_fine[s], refined, n);
  }
  return out;
}

}  // namespace

std::vector<SinkhornResult> solve(Context* ctx, const SinkhornBatch& batch,
                                  const SinkhornOptions& opt) {
  return PendingSolve(ctx, batch, opt).wait();
}

PendingSolve::PendingSolve(Context* ctx, const SinkhornBatch& batch, const SinkhornOptions& opt)
    : batch_(batch), on_device_(ctx && batch.size() > 0) {
  if (on_device_) run_ = batch.start(*ctx, opt);
}

std::vector<SinkhornResult> PendingSolve::wait() {
  if (on_device_) return run_.wait();
  std::vector<SinkhornResult> out;
  out.reserve(batch_.size());
  for (std::size_t i = 0; i < batch_.size(); ++i)
    out.push_back(sinkhorn_reference(batch_.problem(i)));
  return out;
}

void assemble_ranking(Context* ctx, const Dictionary& dict, const PotOptions& o,
                      const std::vector<long>& warm_atoms, PreparedTransfer& pt) {
  pt.ranking_mode = o.ranking;
  pt.candidates.assign(pt.sectors.size(), {});
  if (o.ranking == PotRanking::indexed)
    assemble_indexed(ctx, dict, o, warm_atoms, pt);
  else
    assemble_exhaustive(dict, o, pt);
}

std::vector<Winner> rank_sectors(Context* ctx, const Dictionary& dict, const PreparedTransfer& pt,
                                 const PotOptions& o, PotTiming& timing,
                                 const std::function<void()>& beside) {
  if (pt.ranking_mode == PotRanking::indexed) return rank_indexed(ctx, dict, pt, o, timing, beside);
  return rank_exhaustive(ctx, pt, timing, beside);
}

}  // namespace potmap::detail
