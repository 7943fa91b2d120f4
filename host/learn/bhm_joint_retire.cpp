// JointBhm::retire_far and the revival of retired tiles: memory that follows the place a drive's
// sensor is in, not the drive (include/potmap/learn/bhm_joint.hpp).
#include <algorithm>
#include <cmath>

#include "bhm_joint_grid.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "runtime/host_team.hpp"

namespace potmap {

namespace {

// Keeps the elements of v whose block (of `per` elements) stays, in order, moved down in place:
// a drive retires tiles at most keyframes, and a new vector each time cost a copy of the whole
// precision into fresh pages (the page faults as much as the copy). The memory of the blocks
// that go is returned only when the vector would stay less than half full; otherwise the next
// tiles made reuse it.
template <class T>
void keep_blocks(std::vector<T>& v, const std::vector<std::uint8_t>& going, std::size_t per) {
  std::size_t to = 0;
  for (std::size_t t = 0; t < going.size(); ++t) {
    if (going[t]) continue;
    if (to != t)
      std::copy(v.begin() + std::ptrdiff_t(t * per), v.begin() + std::ptrdiff_t((t + 1) * per),
                v.begin() + std::ptrdiff_t(to * per));
    ++to;
  }
  v.resize(to * per);
  if (v.capacity() > 2 * v.size()) v.shrink_to_fit();
}

}  // namespace

void JointBhm::fold_retiring(const std::vector<std::uint8_t>& going) {
  // Every stored coupling between a kernel that goes and one that stays: P_ab sits in the half
  // stencil of the earlier kernel (raster order). The stayed kernel's eta takes -P_ab mean of
  // the other, and the entry is cleared, so that a revived tile does not count it again.
  const auto hs = static_cast<std::size_t>(half_slots_);
  const auto cells = static_cast<std::uint64_t>(tile_cells_);
  for (std::size_t t = 0; t < tiles_.size(); ++t) {
    // Only tiles that go and their neighbours hold such couplings.
    bool near = going[t] != 0;
    for (int n = 0; n < 27 && !near; ++n) near = tiles_[t].nb[n] >= 0 && going[tiles_[t].nb[n]];
    if (!near) continue;
    for (std::uint64_t l = 0; l < cells; ++l) {
      const auto a = static_cast<std::uint32_t>(t * cells + l);
      std::int64_t g[3];
      cell_of(a, g);
      double* row = &prec_[std::size_t(a) * hs];
      for (const HalfRun& h : half_)
        for (std::int32_t j = 0; j < h.len; ++j) {
          double& p = row[h.at + j];
          if (p == 0) continue;
          const std::int64_t c[3] = {g[0] + h.d[0] + j, g[1] + h.d[1], g[2] + h.d[2]};
          const std::int64_t b = in_grid(c) ? find_cell(c, std::int64_t(t)) : -1;
          if (b < 0) continue;
          const bool a_goes = going[t] != 0, b_goes = going[std::size_t(b) / cells] != 0;
          if (a_goes == b_goes) continue;
          if (a_goes)
            eta_[std::size_t(b)] -= p * mean_[a];
          else
            eta_[a] -= p * mean_[std::size_t(b)];
          p = 0;
        }
    }
  }
  // The bias couples to every kernel.
  if (o_.bias)
    for (std::size_t t = 0; t < tiles_.size(); ++t)
      if (going[t])
        for (std::uint64_t l = 0; l < cells; ++l) {
          const std::size_t a = t * cells + l;
          etab_ -= bcoup_[a] * mean_[a];
        }
}

void JointBhm::compact(const std::vector<std::uint8_t>& going) {
  const auto cells = static_cast<std::size_t>(tile_cells_);
  std::vector<Tile> tiles;
  std::vector<std::uint8_t> dirty;
  std::vector<double> clocks;
  for (std::size_t t = 0; t < tiles_.size(); ++t)
    if (!going[t]) {
      tiles.push_back(tiles_[t]);
      dirty.push_back(tile_dirty_[t]);
      clocks.push_back(tile_clock_[t]);
    }
  keep_blocks(prec_, going, cells * static_cast<std::size_t>(half_slots_));
  keep_blocks(eta_, going, cells);
  keep_blocks(mean_, going, cells);
  keep_blocks(bcoup_, going, cells);
  keep_blocks(touched_, going, cells);
  keep_blocks(seeded_, going, cells);
  keep_blocks(mark_, going, cells);
  keep_blocks(var_, going, cells);
  tiles_.swap(tiles);
  tile_dirty_.swap(dirty);
  tile_clock_.swap(clocks);
  tile_index_.clear();
  for (std::size_t t = 0; t < tiles_.size(); ++t) {
    const std::int64_t c[3] = {tiles_[t].coord[0], tiles_[t].coord[1], tiles_[t].coord[2]};
    tile_index_.emplace(tile_key(c), static_cast<std::uint32_t>(t));
  }
  for (Tile& tile : tiles_)
    for (std::int64_t dz = -1; dz <= 1; ++dz)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dx = -1; dx <= 1; ++dx) {
          const std::int64_t dt[3] = {dx, dy, dz};
          const std::int64_t u[3] = {tile.coord[0] + dx, tile.coord[1] + dy, tile.coord[2] + dz};
          tile.nb[joint_grid::nb_slot(dt)] =
              (dim_ == 2 && dz != 0) ? -1 : static_cast<std::int32_t>(find_tile(u));
        }
  std::fill(std::begin(recent_key_), std::end(recent_key_), ~0ull);
  std::fill(std::begin(recent_id_), std::end(recent_id_), -1);
  // The scratch keeps its storage: its lists of storage indices are made anew by every update,
  // and its vectors over all kernels (the solves' r, z, p, q) are zero or rewritten before
  // they are read.
}

std::size_t JointBhm::retire_far(const double centre[3], double radius, Context* ctx) {
  if (bounded_ || !(radius > 0) || tiles_.empty()) return 0;
  const auto cells = static_cast<std::size_t>(tile_cells_);
  const double edge = double(tile_) * o_.spacing;
  std::vector<std::uint8_t> going(tiles_.size(), 0);
  std::size_t n = 0;
  for (std::size_t t = 0; t < tiles_.size(); ++t) {
    double d2 = 0;
    for (int d = 0; d < std::min(dim_, 2); ++d) {
      const double c = lo_[d] + (double(tiles_[t].coord[d]) + 0.5) * edge - o_.spacing / 2;
      d2 += (c - centre[d]) * (c - centre[d]);
    }
    if (d2 > radius * radius) {
      going[t] = 1;
      ++n;
    }
  }
  if (n == 0) return 0;
  // Forgetting: the tiles that go, and the neighbours whose couplings to them fold into eta
  // (and whose precision their variance blocks read), faded to now first.
  if (o_.half_life > 0)
    for (std::size_t t = 0; t < tiles_.size(); ++t) {
      bool near = going[t] != 0;
      for (int k = 0; k < 27 && !near; ++k) near = tiles_[t].nb[k] >= 0 && going[tiles_[t].nb[k]];
      if (near) catch_up_tile(t);
    }
  // What a query needs of them, while their neighbours are all still there: the exported
  // variances of map(), a dense solve a kernel, in chunks over this thread and the helper
  // (each kernel's value does not depend on who computes it).
  std::vector<std::uint32_t> stale;
  for (std::size_t t = 0; t < tiles_.size(); ++t) {
    if (!going[t] || !tile_dirty_[t]) continue;
    for (std::size_t l = 0; l < cells; ++l)
      stale.push_back(static_cast<std::uint32_t>(t * cells + l));
    tile_dirty_[t] = 0;
  }
  constexpr std::size_t kChunk = 256;
  const detail::HelperHold hold(ctx);
  detail::for_each_item(ctx, (stale.size() + kChunk - 1) / kChunk, [&](std::size_t c) {
    thread_local std::vector<double> scratch;
    for (std::size_t u = c * kChunk; u < std::min(stale.size(), (c + 1) * kChunk); ++u) {
      std::int64_t g[3];
      cell_of(stale[u], g);
      var_[stale[u]] = exported_var(g, stale[u], scratch);
    }
  });
  fold_retiring(going);
  for (std::size_t t = 0; t < tiles_.size(); ++t) {
    if (!going[t]) continue;
    RetiredTile r;
    std::copy(std::begin(tiles_[t].coord), std::end(tiles_[t].coord), r.coord);
    r.mean.assign(mean_.begin() + std::ptrdiff_t(t * cells),
                  mean_.begin() + std::ptrdiff_t((t + 1) * cells));
    r.var.assign(var_.begin() + std::ptrdiff_t(t * cells),
                 var_.begin() + std::ptrdiff_t((t + 1) * cells));
    r.clock = clock_;
    const std::int64_t c[3] = {r.coord[0], r.coord[1], r.coord[2]};
    retired_index_[tile_key(c)] = static_cast<std::uint32_t>(retired_.size());
    retired_.push_back(std::move(r));
    // The neighbours that stay lose couplings: their exported variances change.
    for (int k = 0; k < 27; ++k)
      if (tiles_[t].nb[k] >= 0 && !going[std::size_t(tiles_[t].nb[k])])
        tile_dirty_[std::size_t(tiles_[t].nb[k])] = 1;
  }
  compact(going);
  return n;
}

void JointBhm::revive(std::uint32_t id, std::uint64_t key) {
  const auto it = retired_index_.find(key);
  if (it == retired_index_.end()) return;
  const std::uint32_t r = it->second;
  const RetiredTile& rt = retired_[r];
  const auto cells = static_cast<std::size_t>(tile_cells_);
  const auto hs = static_cast<std::size_t>(half_slots_);
  // Forgetting: the retired means and variances faded since the tile retired (its diagonal
  // prior's data part, 1/v - 1/prior_var and mean/v, as any kernel's).
  const double a = fade_since(rt.clock), p0 = 1.0 / o_.prior_var;
  for (std::size_t l = 0; l < cells; ++l) {
    const std::size_t s = std::size_t(id) * cells + l;
    const double v = std::min(o_.prior_var, std::max(double(rt.var[l]), 1e-9));
    prec_[s * hs] = p0 + a * (1.0 / v - p0);
    eta_[s] = a * rt.mean[l] / v;
    mean_[s] = eta_[s] / prec_[s * hs];
    // Only kernels that held data come back as reached (the rest are at their prior).
    touched_[s] = rt.mean[l] != 0 || v < o_.prior_var;
  }
  tile_dirty_[id] = 1;
  // The last retired tile takes the revived one's place.
  if (r + 1 != retired_.size()) {
    retired_[r] = std::move(retired_.back());
    const std::int64_t c[3] = {retired_[r].coord[0], retired_[r].coord[1], retired_[r].coord[2]};
    retired_index_[tile_key(c)] = r;
  }
  retired_.pop_back();
  retired_index_.erase(it);
}

}  // namespace potmap
