// JointBhm::update on the host: the input checked, the features listed, the rows reached, eta
// and the EM rounds' bounds, outer products and solves (bhm_joint_device.cpp: the same on the
// device).
#include "potmap/learn/bhm_joint.hpp"

#include <cmath>
#include <string>

#include "bhm_detail.hpp"
#include "bhm_joint_device.hpp"
#include "bhm_joint_grid.hpp"
#include "potmap/error.hpp"
#include "runtime/hash.hpp"
#include "runtime/host_team.hpp"

namespace potmap {

using namespace joint_grid;

void JointBhm::check_samples(const LabelledPoints& samples) const {
  if (samples.dim != dim_)
    throw ArgumentError("joint BHM: samples are " + std::to_string(samples.dim) + "D, the map " +
                        std::to_string(dim_) + "D");
  if (samples.position.size() != samples.size() * std::size_t(dim_))
    throw ArgumentError("joint BHM: sample positions and labels disagree in number");
  if (!samples.weight.empty() && samples.weight.size() != samples.size())
    throw ArgumentError("joint BHM: " + std::to_string(samples.weight.size()) + " weights for " +
                        std::to_string(samples.size()) + " samples");
  for (double w : samples.weight)
    if (!(w >= 0) || !std::isfinite(w))
      throw ArgumentError("joint BHM: a sample weight of " + std::to_string(w) +
                          " (weights are finite and not negative)");
}

namespace {

// data_ids(): the scan's bytes as learned (positions, labels, weights), so the same scan fed
// twice, by whatever path, has the same fingerprint. One pass over a few thousand samples.
std::uint64_t scan_fingerprint(const LabelledPoints& s) {
  auto bytes = [](const auto& v) {
    return std::string_view(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v.front()));
  };
  std::uint64_t h = detail::fnv1a64(bytes(s.position));
  h = detail::fnv1a64(bytes(s.label), h);
  return s.weight.empty() ? h : detail::fnv1a64(bytes(s.weight), h);
}

}  // namespace

void JointBhm::update(const LabelledPoints& samples, Context* ctx) {
  check_samples(samples);
  stats_ = {};
  if (samples.empty()) return;
  if (ctx && detail::sums_on_device(o_.sums, ctx->info()))
    detail::JointBhmDevice::update(*this, samples, *ctx);
  else
    update_on_host(samples, ctx);
  // After the update: one that threw left the posterior without this scan.
  data_ids_.push_back(scan_fingerprint(samples));
}

void JointBhm::reach_rows(Scratch& sc) {
  // Rows to solve: the kernels the scan reaches (in the order the features first reach them),
  // grown by the margin (stored kernels only: an unstored one couples to nothing and stays at
  // its prior mean 0).
  std::vector<std::uint32_t>& reached = sc.reached;
  reached.clear();
  for (std::uint32_t k : sc.kernel)
    if (!mark_[k]) {
      mark_[k] = 1;
      // No sample has reached this kernel before, so its natural parameters are the seed's
      // alone (no coupling, no data in eta). Its mean stays as the starting point of this
      // scan's xi (and of the solve) unless the seed yields fully.
      if (seeded_[k] && !touched_[k] && o_.seeds_yield) yield_seed(k, o_.seeds_yield_fully);
      touched_[k] = 1;
      reached.push_back(k);
    }
  for (std::uint32_t a : reached) {
    mark_[a] = 0;
    mark_dirty(a);
  }
  std::vector<std::uint32_t>& rows = sc.rows;
  rows.clear();
  dilate_rows(rows, reached, o_.solve_margin, dim_ == 3 ? o_.solve_margin : 0, sc);
  stats_.active = rows.size();
  // Forgetting: what the solve reads faded to now before this scan's data are added.
  catch_up_around(rows);
  if (o_.seeds_yield && o_.seeds_yield_fully)
    for (std::uint32_t k : rows)
      if (seeded_[k] && !touched_[k]) {
        // A seed in the solve's margin yields too: no sample reached it, so the same reset
        // leaves the kernel as the unseeded model has it (its own seeded_ flag keeps later
        // seeds off, as for any kernel a seed once reached).
        yield_seed(k, true);
        mark_dirty(k);
      }
}

double JointBhm::prepare_solve(Scratch& sc) {
  // The bias row's products with the kernels outside the rows, whose means and couplings the
  // scan leaves as they are: once, not once a solve (a pass over every stored kernel). Then
  // the box of the solves (the rows are those of every EM iteration): box_rows() says whether
  // it took them.
  double bias_outside = 0;
  if (o_.bias) {
    for (std::uint32_t k : sc.rows) mark_[k] = 1;
    if (o_.half_life > 0) {
      // A tile not yet faded to now holds its couplings as they were: faded here as a sum.
      const auto cells = static_cast<std::size_t>(tile_cells_);
      for (std::size_t t = 0; t < tiles_.size(); ++t) {
        double sum = 0;
        for (std::size_t a = t * cells; a < (t + 1) * cells; ++a)
          if (!mark_[a]) sum += bcoup_[a] * mean_[a];
        bias_outside += fade_since(tile_clock_[t]) * sum;
      }
    } else {
      for (std::size_t a = 0; a < mean_.size(); ++a)
        if (!mark_[a]) bias_outside += bcoup_[a] * mean_[a];
    }
    for (std::uint32_t k : sc.rows) mark_[k] = 0;
  }
  return bias_outside;
}

void JointBhm::update_on_host(const LabelledPoints& samples, Context* ctx) {
  // The update runs some fifty short parts on the helper, with host work between them.
  const detail::HelperHold hold(ctx);
  Scratch& sc = scratch_;
  list_features(samples, ctx);
  const std::size_t n = sc.yc.size();
  stats_.samples = n;
  if (n == 0) return;
  reach_rows(sc);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::uint32_t u = sc.start[i]; u < sc.start[i + 1]; ++u)
      eta_[sc.kernel[u]] += sc.yc[i] * sc.phi[u];
    if (o_.bias) etab_ += sc.yc[i];
  }
  const double bias_outside = prepare_solve(sc);
  em_on_host(bias_outside, box_rows(sc.rows, sc), ctx);
}

void JointBhm::em_on_host(double bias_outside, bool boxed, Context* ctx) {
  Scratch& sc = scratch_;
  const std::size_t n = sc.yc.size();
  const auto hs = static_cast<std::size_t>(half_slots_);
  // xi from the posterior before this scan; variances by the diagonal of the precision (a lower
  // bound of the marginal ones, cheap, and enough for the bound's curvature).
  // (Sample i's mean logit phi_i . x is kept in sc.mu: the carried residual below needs it.)
  auto xi_of = [&](std::size_t i) {
    double mu = o_.bias ? meanb_ : 0.0, s2 = o_.bias ? 1.0 / pbb_ : 0.0;
    for (std::uint32_t u = sc.start[i]; u < sc.start[i + 1]; ++u) {
      const double phi = sc.phi[u];
      mu += mean_[sc.kernel[u]] * phi;
      s2 += phi * phi / prec_[std::size_t(sc.kernel[u]) * hs];
    }
    sc.mu[i] = mu;
    return std::sqrt(mu * mu + s2);
  };
  // The box's two parts: each row's part in mark_ (zero again at the end), and each sample's
  // parts (the parts of its features' kernels: every one is a row). Each part adds the
  // products to its own rows of P, each in the order of the samples, so the precision is the
  // same whoever runs which part.
  std::vector<std::uint8_t>& parts = sc.sample_parts;
  parts.assign(n, 1);
  if (boxed && ctx) {  // (alone, the outer products take every sample in one pass)
    for (std::uint32_t k : sc.part_rows[1]) mark_[k] = 1;
    for (std::size_t i = 0; i < n; ++i) {
      std::uint8_t m = 0;
      for (std::uint32_t u = sc.start[i]; u < sc.start[i + 1]; ++u)
        m |= std::uint8_t(1u << mark_[sc.kernel[u]]);
      parts[i] = m;
    }
  }
  const int nparts = boxed ? 2 : 1;
  std::vector<double>&lambda = sc.lambda, &next = sc.next;
  lambda.assign(n, 0.0);
  next.resize(n);
  sc.mu.resize(n);
  try {
    for (int it = 0; it < o_.em_iterations; ++it) {
      // Every xi from the same posterior, then the precision.
      detail::for_each_item(ctx, 2, [&](std::size_t h) {
        for (std::size_t i = h * n / 2; i < (h + 1) * n / 2; ++i)
          next[i] = detail::jj_lambda(xi_of(i));
      });
      // Each entry of P sums the samples in their order either way.
      if (!ctx)
        for (std::size_t i = 0; i < n; ++i)
          add_outer(sc, i, 2.0 * sc.w[i] * (next[i] - lambda[i]), -1);
      else
        detail::for_each_item(ctx, std::size_t(nparts), [&](std::size_t p) {
          const auto bit = std::uint8_t(1u << p);
          for (std::size_t i = 0; i < n; ++i)
            if (parts[i] & bit)
              add_outer(sc, i, 2.0 * sc.w[i] * (next[i] - lambda[i]),
                        parts[i] == bit ? -1 : int(p));
        });
      // After the first solve its residual is carried: eta is the same, and P changed by
      // sum_i c_i phi_i phi_i^T (the bias a feature of phi 1), so r -= c_i phi_i (phi_i . x)
      // per sample (phi_i . x from xi's pass: x has not changed since), in place of a product
      // over every kernel around the rows.
      const bool carry = it > 0;
      for (std::size_t i = 0; i < n; ++i) {
        const double c = 2.0 * sc.w[i] * (next[i] - lambda[i]);
        pbb_ += c;
        lambda[i] = next[i];
        if (!carry) continue;
        const double cs = c * sc.mu[i];
        for (std::uint32_t u = sc.start[i]; u < sc.start[i + 1]; ++u)
          sc.r[sc.kernel[u]] -= cs * sc.phi[u];
        if (o_.bias) sc.rb -= cs;
      }
      stats_.residual = solve(sc.rows, mean_, meanb_, o_.cg_tolerance, o_.cg_max_iterations,
                              &stats_.cg_iterations, sc, true, ctx, &bias_outside, carry);
    }
  } catch (...) {
    for (std::uint32_t k : sc.part_rows[1]) mark_[k] = 0;
    throw;
  }
  if (boxed)
    for (std::uint32_t k : sc.part_rows[1]) mark_[k] = 0;
}

void JointBhm::update_by_scan(const LabelledPoints& samples, Context* ctx,
                              const std::function<void(std::int64_t scan)>& before_scan) {
  std::map<std::int64_t, std::vector<std::size_t>> by_scan;
  const bool has_scan = samples.scan.size() == samples.size();
  for (std::size_t i = 0; i < samples.size(); ++i)
    by_scan[has_scan ? samples.scan[i] : 0].push_back(i);
  LabelledPoints s;
  s.dim = samples.dim;
  for (const auto& [t, idx] : by_scan) {
    s.position.clear();
    s.label.clear();
    s.scan.clear();
    s.weight.clear();
    for (std::size_t i : idx) {
      for (int d = 0; d < s.dim; ++d) s.position.push_back(samples.position[i * s.dim + d]);
      s.label.push_back(samples.label[i]);
      if (!samples.weight.empty()) s.weight.push_back(samples.weight[i]);
      s.scan.push_back(t);
    }
    if (before_scan) before_scan(t);
    update(s, ctx);
  }
}

}  // namespace potmap
