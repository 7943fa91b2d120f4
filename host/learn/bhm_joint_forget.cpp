// Forgetting in the joint BHM (SPEC section 9): the data's part of the posterior fades toward
// the prior with a half-life in sensor time. A fade applied to every kernel at every scan would
// cost a pass over the whole map a scan, so each tile keeps the time it was last faded to and
// is brought up to date when a scan's solve, a retirement or an export reads it: every stored
// value is faded exactly once for each stretch of time, whoever asks first.
#include <cmath>
#include <string>

#include "bhm_joint_grid.hpp"
#include "potmap/error.hpp"
#include "potmap/learn/bhm_joint.hpp"

namespace potmap {

double JointBhm::fade_since(double since) const {
  if (!(o_.half_life > 0) || !(clock_ > since)) return 1.0;
  return std::exp2(-(clock_ - since) / o_.half_life);
}

void JointBhm::set_time(double seconds) {
  if (!std::isfinite(seconds))
    throw ArgumentError("joint BHM: a sensor time of " + std::to_string(seconds) + " s");
  if (!clock_set_) {
    // The first time: nothing learned before it has a time, so nothing fades; tiles made
    // before (seeds) start their clock here.
    clock_ = seconds;
    clock_set_ = true;
    for (double& t : tile_clock_) t = seconds;
    for (RetiredTile& r : retired_) r.clock = seconds;
    return;
  }
  if (!(seconds > clock_)) return;
  const double before = clock_;
  clock_ = seconds;
  // The bias is one weight every scan reaches: faded at once.
  if (o_.bias && o_.half_life > 0) {
    const double a = fade_since(before), p0 = 1.0 / o_.prior_var;
    pbb_ = p0 + a * (pbb_ - p0);
    etab_ *= a;
  }
}

void JointBhm::catch_up_tile(std::size_t t) {
  const double a = fade_since(tile_clock_[t]);
  tile_clock_[t] = clock_;
  if (a == 1.0) return;
  // The prior is diagonal (precision 1/prior_var, mean 0) under the data of every kernel a
  // sample reached: seeds yield to data. A kernel no sample reached holds its prior or a seed
  // alone, which do not fade; its couplings are zero.
  const double p0 = 1.0 / o_.prior_var;
  const auto hs = static_cast<std::size_t>(half_slots_);
  const auto cells = static_cast<std::size_t>(tile_cells_);
  for (std::size_t s = t * cells; s < (t + 1) * cells; ++s) {
    if (!touched_[s]) continue;
    double* row = &prec_[s * hs];
    row[0] = p0 + a * (row[0] - p0);
    for (std::size_t j = 1; j < hs; ++j) row[j] *= a;
    eta_[s] *= a;
    bcoup_[s] *= a;
  }
  // Variances of every kernel whose block reaches into this tile.
  for (int k = 0; k < 27; ++k)
    if (tiles_[t].nb[k] >= 0) tile_dirty_[std::size_t(tiles_[t].nb[k])] = 1;
}

void JointBhm::catch_up_around(const std::vector<std::uint32_t>& rows) {
  if (!(o_.half_life > 0)) return;
  const auto cells = static_cast<std::uint64_t>(tile_cells_);
  std::size_t last = ~std::size_t(0);
  for (std::uint32_t k : rows) {
    const std::size_t t = k / cells;
    if (t == last) continue;  // rows are sorted: a tile's rows come together
    last = t;
    for (int n = 0; n < 27; ++n) {
      const std::int32_t u = tiles_[t].nb[n];
      if (u >= 0 && tile_clock_[std::size_t(u)] < clock_) catch_up_tile(std::size_t(u));
    }
  }
}

void JointBhm::catch_up() {
  if (!(o_.half_life > 0)) return;
  for (std::size_t t = 0; t < tiles_.size(); ++t)
    if (tile_clock_[t] < clock_) catch_up_tile(t);
}

bool JointBhm::behind() const {
  if (!(o_.half_life > 0)) return false;
  for (double t : tile_clock_)
    if (t < clock_) return true;
  return false;
}

}  // namespace potmap
