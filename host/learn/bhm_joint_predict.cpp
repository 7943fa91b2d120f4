// The joint BHM read between updates: the map at points as the last update left it, and
// whether a sample has reached a point yet (a drive's look-ahead, a planner's query).
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "bhm_joint_grid.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "runtime/host_team.hpp"

namespace potmap {

bool JointBhm::retired_kernel(const std::int32_t cell[3], double& mean, double& var) const {
  if (retired_.empty()) return false;
  std::int64_t t[3] = {0, 0, 0}, l = 0;
  for (int d = 0; d < dim_; ++d) t[d] = joint_grid::floor_div(cell[d], tile_);
  const auto it = retired_index_.find(tile_key(t));
  if (it == retired_index_.end()) return false;
  for (int d = dim_ - 1; d >= 0; --d) l = l * tile_ + (cell[d] - t[d] * tile_);
  const RetiredTile& r = retired_[it->second];
  mean = r.mean[std::size_t(l)];
  var = r.var[std::size_t(l)];
  fade_retired(fade_since(r.clock), mean, var);
  return true;
}

void JointBhm::fade_retired(double a, double& mean, double& var) const {
  if (a == 1.0) return;
  // The retired kernel's evidence (its precision above the prior's) faded by a.
  const double p0 = 1.0 / o_.prior_var;
  const double v = std::min(o_.prior_var, std::max(var, 1e-9));
  const double prec = p0 + a * (1.0 / v - p0);
  mean = a * mean / v / prec;
  var = 1.0 / prec;
}

void JointBhm::predict(const double* points, std::size_t n, double* mean, double* var,
                       Context* ctx) const {
  if (behind()) {  // forgetting: the posterior at time(), faded on a copy
    JointBhm now = *this;
    now.catch_up();
    now.predict(points, n, mean, var, ctx);
    return;
  }
  // The points' features first (features() keeps a cache: one thread), then the exported
  // variance of every kernel they reach whose tile changed since the last export, each once,
  // on ctx's host team (they are most of the work: the last update changed the tiles around
  // the sensor), then the sums.
  std::vector<Feature> all;
  std::vector<std::size_t> start(n + 1, 0);
  std::vector<Feature> f;
  for (std::size_t i = 0; i < n; ++i) {
    features(points + i * dim_, f);
    all.insert(all.end(), f.begin(), f.end());
    start[i + 1] = all.size();
  }
  std::unordered_map<std::uint32_t, std::uint32_t> slot;  // kernel -> index into fresh
  std::vector<const Feature*> todo;
  for (const Feature& k : all)
    if (k.kernel != kNone && tile_dirty_[k.kernel / tile_cells_] &&
        slot.emplace(k.kernel, std::uint32_t(todo.size())).second)
      todo.push_back(&k);
  std::vector<double> fresh(todo.size());
  detail::for_each_item(ctx, todo.size(), [&](std::size_t u) {
    thread_local std::vector<double> scratch;
    const Feature& k = *todo[u];
    const std::int64_t g[3] = {k.cell[0], k.cell[1], k.cell[2]};
    fresh[u] = exported_var(g, std::int64_t(k.kernel), scratch);
  });
  std::vector<double> scratch;
  for (std::size_t i = 0; i < n; ++i) {
    double m = o_.bias ? meanb_ : 0.0, s2 = o_.bias ? 1.0 / pbb_ : 0.0;
    for (std::size_t q = start[i]; q < start[i + 1]; ++q) {
      const Feature& k = all[q];
      double wm = 0, wv = 0;
      if (k.kernel != kNone) {
        wm = mean_[k.kernel];
        wv = tile_dirty_[k.kernel / tile_cells_] ? fresh[slot.at(k.kernel)] : var_[k.kernel];
      } else if (bounded_) {  // a kernel no sample or seed made: its prior's variance
        const std::int64_t g[3] = {k.cell[0], k.cell[1], k.cell[2]};
        wv = exported_var(g, -1, scratch);
      } else if (!retired_kernel(k.cell, wm, wv)) {
        continue;  // a growable map holds no kernel there
      }
      m += k.phi * wm;
      s2 += k.phi * k.phi * wv;
    }
    if (mean) mean[i] = m;
    if (var) var[i] = s2;
  }
}

void JointBhm::reached(const double* points, std::size_t n, std::uint8_t* out) const {
  std::vector<Feature> f;
  double wm = 0, wv = 0;
  for (std::size_t i = 0; i < n; ++i) {
    features(points + i * dim_, f);
    out[i] = 0;
    for (const Feature& k : f)
      if (k.kernel != kNone ? touched_[k.kernel] != 0 : retired_kernel(k.cell, wm, wv)) {
        out[i] = 1;
        break;
      }
  }
}

}  // namespace potmap
