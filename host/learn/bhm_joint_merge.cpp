// Merging joint BHM maps in information form (include/potmap/learn/bhm_joint_merge.hpp).
#include "potmap/learn/bhm_joint_merge.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_map>

#include "io/text_io.hpp"
#include "learn/bhm_joint_merge_detail.hpp"
#include "potmap/error.hpp"

namespace potmap::detail {

namespace {

// The shortest text that reads back as the same double.
std::string value_text(double v) {
  return detail::format_double(v);
}

}  // namespace

void JointBhmMerge::check_alone(const JointBhm& m, const std::string& name) {
  if (!m.retired_.empty())
    throw ArgumentError("merge: " + name + " has " + std::to_string(m.retired_.size()) +
                        " retired tiles, whose couplings were folded into their neighbours' "
                        "information vector: its information form is not a sum of data and "
                        "cannot be merged exactly");
  if (!m.o_.seeds_yield)
    for (std::size_t k = 0; k < m.seeded_.size(); ++k)
      if (m.seeded_[k] && m.touched_[k])
        throw ArgumentError("merge: " + name +
                            " keeps seeds under its data (seeds_yield false): its seeded "
                            "kernels' data and seed cannot be told apart");
}

void JointBhmMerge::check_same_lattice(const JointBhm& a, const JointBhm& b, const std::string& na,
                                       const std::string& nb) {
  // Bit-for-bit equality: the kernels must coincide, not nearly coincide.
  auto differ = [&](const char* what, double x, double y) {
    if (std::memcmp(&x, &y, sizeof x) == 0) return;
    throw ArgumentError("merge: " + na + " has " + what + " " + value_text(x) + ", " + nb +
                        " has " + value_text(y) + ": the maps' kernels do not coincide");
  };
  differ("dimension", a.dim_, b.dim_);
  differ("kernel spacing (m)", a.o_.spacing, b.o_.spacing);
  differ("kernel width gamma (1/m^2)", a.gamma_, b.gamma_);
  differ("feature cut-off tau", a.o_.tau, b.o_.tau);
  differ("prior variance", a.o_.prior_var, b.o_.prior_var);
  differ("bias (1 with, 0 without)", a.o_.bias, b.o_.bias);
  differ("bounded grid (1 bounded, 0 growable)", a.bounded_, b.bounded_);
  for (int d = 0; d < a.dim_; ++d) {
    differ("lattice origin", a.lo_[d], b.lo_[d]);
    differ("kernels per axis", double(a.n_[d]), double(b.n_[d]));
  }
  // Derived from the above; checked so a change of the storage's layout fails here.
  differ("tile edge", double(a.tile_), double(b.tile_));
  differ("stencil slots", double(a.half_slots_), double(b.half_slots_));
}

void JointBhmMerge::add(JointBhm& c, const JointBhm& b) {
  // P_C = P_A + P_B - P_0 and eta_C = eta_A + eta_B - P_0 mu_0, kernel by kernel. The prior is
  // diagonal (mean 0, or a seed's), so the couplings are data alone and add as they are; a
  // kernel's diagonal and eta hold its prior plus data where a sample reached it (touched),
  // its prior alone elsewhere (a live seed, or the plain prior).
  const double p0 = 1.0 / c.o_.prior_var;
  const auto hs = static_cast<std::size_t>(c.half_slots_);
  const auto tc = static_cast<std::size_t>(c.tile_cells_);
  for (std::size_t tb = 0; tb < b.tiles_.size(); ++tb) {
    const std::int64_t t[3] = {b.tiles_[tb].coord[0], b.tiles_[tb].coord[1], b.tiles_[tb].coord[2]};
    const std::size_t tcid = c.make_tile(t);
    for (std::size_t l = 0; l < tc; ++l) {
      const std::size_t sb = tb * tc + l, sc = tcid * tc + l;
      double* pc = &c.prec_[sc * hs];
      const double* pb = &b.prec_[sb * hs];
      for (std::size_t j = 1; j < hs; ++j) pc[j] += pb[j];
      c.bcoup_[sc] += b.bcoup_[sb];
      if (b.touched_[sb]) {
        if (c.touched_[sc]) {
          pc[0] += pb[0] - p0;
          c.eta_[sc] += b.eta_[sb];
          c.mean_[sc] = 0.5 * (c.mean_[sc] + b.mean_[sb]);  // the solve's start
        } else {
          // A seed of c's yields to b's data, as it would have to its own.
          pc[0] = pb[0];
          c.eta_[sc] = b.eta_[sb];
          c.mean_[sc] = b.mean_[sb];
          c.touched_[sc] = 1;
        }
      } else if (!c.touched_[sc] && pb[0] > pc[0]) {
        // Neither map has data here: the firmer prior (a live seed of b's) speaks for it.
        pc[0] = pb[0];
        c.eta_[sc] = b.eta_[sb];
        c.mean_[sc] = b.mean_[sb];
      }
      c.seeded_[sc] |= b.seeded_[sb];
    }
  }
  if (c.o_.bias) {
    c.pbb_ += b.pbb_ - p0;
    c.etab_ += b.etab_;
    c.meanb_ = 0.5 * (c.meanb_ + b.meanb_);
  }
  c.data_ids_.insert(c.data_ids_.end(), b.data_ids_.begin(), b.data_ids_.end());
}

void JointBhmMerge::solve_means(JointBhm& c) {
  // Every kernel with data or a seed, as JointBhm::map() polishes them; a few rounds, since
  // the start (the maps' means averaged) is farther from the fused solution than a scan's.
  std::vector<std::uint32_t> rows;
  for (std::size_t a = 0; a < c.touched_.size(); ++a)
    if (c.touched_[a] || c.seeded_[a]) rows.push_back(static_cast<std::uint32_t>(a));
  std::fill(c.tile_dirty_.begin(), c.tile_dirty_.end(), std::uint8_t(1));
  c.scratch_ = JointBhm::Scratch();
  c.stats_ = {};
  if (rows.empty()) return;
  const double tol = 1e-8;
  double residual = 1;
  std::size_t its = 0;
  for (int round = 0; round < 4 && !(residual <= tol); ++round)
    residual = c.solve(rows, c.mean_, c.meanb_, tol, 4 * c.o_.cg_max_iterations, &its, c.scratch_);
  c.stats_.active = rows.size();
  c.stats_.cg_iterations = its;
  c.stats_.residual = residual;
  c.scratch_ = JointBhm::Scratch();
}

}  // namespace potmap::detail

namespace potmap {

JointBhm merge_joint_bhm(const std::vector<const JointBhm*>& maps,
                         const JointBhmMergeOptions& options) {
  using detail::JointBhmMerge;
  if (maps.empty()) throw ArgumentError("merge: no maps to merge");
  auto name = [&](std::size_t i) {
    return i < options.names.size() ? options.names[i] : "map " + std::to_string(i + 1);
  };
  for (std::size_t i = 0; i < maps.size(); ++i) {
    if (!maps[i]) throw ArgumentError("merge: " + name(i) + " is null");
    JointBhmMerge::check_alone(*maps[i], name(i));
    if (i > 0) JointBhmMerge::check_same_lattice(*maps[0], *maps[i], name(0), name(i));
  }
  if (!options.allow_overlap) {
    std::unordered_map<std::uint64_t, std::size_t> owner;
    for (std::size_t i = 0; i < maps.size(); ++i) {
      std::size_t shared = 0, first_other = 0;
      for (std::uint64_t id : maps[i]->data_ids()) {
        const auto [it, fresh] = owner.emplace(id, i);
        if (!fresh && it->second != i && shared++ == 0) first_other = it->second;
      }
      if (shared > 0)
        throw ArgumentError(
            "merge: " + name(i) + " and " + name(first_other) + " share " + std::to_string(shared) +
            " of " + std::to_string(maps[i]->data_ids().size()) +
            " scan fingerprints (a map merged with itself, or maps of the same scans): merged, "
            "those scans would count twice (allow_overlap merges them anyway)");
    }
  }
  // Forgetting: every map faded to the latest clock among them (the maps of one drive's parts
  // share its clock; one run over the whole would have faded the earlier parts as much).
  bool fading = false;
  double clock = maps[0]->time();
  for (const JointBhm* m : maps) {
    fading = fading || m->options().half_life > 0;
    clock = std::max(clock, m->time());
  }
  std::vector<JointBhm> now;
  if (fading) {
    now.reserve(maps.size());
    for (const JointBhm* m : maps) {
      now.push_back(*m);
      now.back().set_time(clock);
      now.back().catch_up();
    }
  }
  auto at = [&](std::size_t i) -> const JointBhm& { return fading ? now[i] : *maps[i]; };
  JointBhm c = at(0);
  for (std::size_t i = 1; i < maps.size(); ++i) JointBhmMerge::add(c, at(i));
  JointBhmMerge::solve_means(c);
  return c;
}

}  // namespace potmap
