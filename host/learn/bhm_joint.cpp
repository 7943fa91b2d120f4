// The joint BHM's storage: options, the tiles of kernels (made when first reached, found by
// hash or through neighbours) and the cells in them.
#include "potmap/learn/bhm_joint.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "bhm_joint_grid.hpp"
#include "potmap/error.hpp"

namespace potmap {

using namespace joint_grid;

void JointBhm::init(int dim, const JointBhmOptions& o) {
  o_ = o;
  dim_ = dim;
  if (dim != 2 && dim != 3) throw ArgumentError("joint BHM: dimension must be 2 or 3");
  if (!(o.spacing > 0) || !std::isfinite(o.spacing))
    throw ArgumentError("joint BHM: spacing must be positive, got " + std::to_string(o.spacing));
  if (o.gamma < 0 || !std::isfinite(o.gamma)) throw ArgumentError("joint BHM: gamma must be >= 0");
  if (o.gamma == 0 && !(o.neighbour_phi > 0 && o.neighbour_phi < 1))
    throw ArgumentError("joint BHM: neighbour_phi must be in (0, 1)");
  if (!(o.prior_var > 0) || !std::isfinite(o.prior_var))
    throw ArgumentError("joint BHM: prior_var must be positive");
  if (o.em_iterations < 1) throw ArgumentError("joint BHM: em_iterations must be at least 1");
  if (!(o.tau > 0) || !std::isfinite(o.tau)) throw ArgumentError("joint BHM: tau must be positive");
  if (!(o.cg_tolerance > 0) || o.cg_max_iterations < 1 || o.solve_margin < 0)
    throw ArgumentError("joint BHM: bad conjugate-gradient settings");
  if (!(o.half_life >= 0) || !std::isfinite(o.half_life))
    throw ArgumentError("joint BHM: half_life must be finite and not negative, got " +
                        std::to_string(o.half_life) + " s");
  gamma_ = o.gamma > 0 ? o.gamma : -std::log(o.neighbour_phi) / (o.spacing * o.spacing);
  rcut_ = std::sqrt(o.tau / gamma_);
  step_q_ = std::exp(-2 * gamma_ * o.spacing * o.spacing);
  // Two kernels couple when one sample reaches both: at most 2 rcut apart.
  const double pad = std::ceil(2 * rcut_ / o.spacing);
  if (!(pad < 64)) throw ArgumentError("joint BHM: kernels too wide for their spacing");
  pad_ = static_cast<std::int64_t>(pad);
  box_ = 2 * pad_ + 1;
  hb_ = static_cast<std::int64_t>(std::ceil(rcut_ / o.spacing));
  // Every neighbour lookup (stencil, margin, variance block) stays within one tile.
  tile_ = std::max<std::int64_t>({dim == 3 ? 8 : 32, pad_, o.solve_margin});
  if (tile_ > 4096) throw ArgumentError("joint BHM: solve_margin too large");
  tile_cells_ = 1;
  slots_ = 1;
  for (int d = 0; d < dim; ++d) {
    tile_cells_ *= tile_;
    slots_ *= box_;
  }
  // The stencil's slots that can hold a coupling: two kernels couple only through a sample
  // within rcut of both, so at most 2 rcut apart (a relative margin for the rounding of the
  // features' cut-off). Per stencil row (dy, dz) they form one run of dx; a kernel stores the
  // diagonal and the runs after it in raster order (P is symmetric: the rest mirrors them),
  // a third of the box in 2D, less in 3D, and the products stream them.
  half_.clear();
  half_at_.assign(static_cast<std::size_t>(slots_), -1);
  half_slots_ = 1;
  half_at_[static_cast<std::size_t>(slots_ / 2)] = 0;
  const double reach2 = 4 * rcut_ * rcut_ / (o.spacing * o.spacing) * (1 + 1e-6);
  const std::int64_t rz = dim == 3 ? pad_ : 0;
  for (std::int64_t dz = -rz; dz <= rz; ++dz)
    for (std::int64_t dy = -pad_; dy <= pad_; ++dy) {
      std::int64_t m = -1;
      for (std::int64_t dx = 0; dx <= pad_; ++dx)
        if (double(dx * dx + dy * dy + dz * dz) <= reach2) m = dx;
      const bool after = dz > 0 || (dz == 0 && dy > 0);
      if (m < 0 || (!after && !(dz == 0 && dy == 0 && m > 0))) continue;
      const std::int64_t slot0 = ((dz + (dim == 3 ? pad_ : 0)) * box_ + (dy + pad_)) * box_ + pad_;
      HalfRun h;
      const std::int64_t first = after ? -m : 1;
      h.slot = static_cast<std::int32_t>(slot0 + first);
      h.len = static_cast<std::int32_t>(m - first + 1);
      h.at = static_cast<std::int32_t>(half_slots_);
      h.d[0] = static_cast<std::int32_t>(first);
      h.d[1] = static_cast<std::int32_t>(dy);
      h.d[2] = static_cast<std::int32_t>(dz);
      for (std::int32_t j = 0; j < h.len; ++j)
        half_at_[static_cast<std::size_t>(h.slot + j)] = h.at + j;
      half_.push_back(h);
      half_slots_ += h.len;
    }
  centre_lin_ = 0;
  for (int d = 0; d < dim; ++d) centre_lin_ = centre_lin_ * box_ + pad_;
  // The variance block (the kernels within the cut-off of a kernel's centre): the grid's sums
  // of phi and phi^2 at an interior kernel, and its cells and the places of their couplings,
  // tabled once: every exported variance reads the same pairs (a retiring tile's 512 kernels,
  // a drive's final map's hundreds of thousands), and finding each pair's slot per kernel cost
  // as much as the dense solve.
  grid_sum_ = grid_sum2_ = sum_phi2_ = 0;
  vb_off_.clear();
  vb_phi_.clear();
  const std::int64_t hz = dim == 3 ? hb_ : 0;
  for (std::int64_t dk = -hz; dk <= hz; ++dk)
    for (std::int64_t dj = -hb_; dj <= hb_; ++dj)
      for (std::int64_t di = -hb_; di <= hb_; ++di) {
        const double d2 =
            (double(di * di) + double(dj * dj) + double(dk * dk)) * o.spacing * o.spacing;
        if (gamma_ * d2 > o.tau) continue;
        grid_sum_ += std::exp(-gamma_ * d2);
        grid_sum2_ += std::exp(-2 * gamma_ * d2);
        vb_off_.insert(vb_off_.end(), {di, dj, dk});
        vb_phi_.push_back(std::exp(-gamma_ * d2));
      }
  sum_phi2_ = grid_sum2_;
  if (o.bias) pbb_ = 1.0 / o.prior_var;
  const std::size_t nb = vb_phi_.size();
  vb_at_.assign(nb * nb, -1);
  vb_u_first_.assign(nb * nb, 0);
  for (std::size_t u = 0; u < nb; ++u)
    for (std::size_t v = 0; v < nb; ++v) {
      std::int64_t slot = 0;
      for (int d = dim - 1; d >= 0; --d)
        slot = slot * box_ + (vb_off_[3 * v + d] - vb_off_[3 * u + d]);
      vb_u_first_[u * nb + v] = slot >= 0;
      vb_at_[u * nb + v] =
          slot == 0 ? 0
                    : half_at_[static_cast<std::size_t>(centre_lin_ + (slot > 0 ? slot : -slot))];
    }
}

JointBhm::JointBhm(int dim, const JointBhmOptions& o) {
  init(dim, o);
  bounded_ = false;
}

JointBhm::JointBhm(int dim, const double lo[3], const double hi[3], const JointBhmOptions& o) {
  init(dim, o);
  bounded_ = true;
  std::int64_t total = 1;
  for (int d = 0; d < dim; ++d) {
    if (!std::isfinite(lo[d]) || !std::isfinite(hi[d]) || !(hi[d] >= lo[d]))
      throw ArgumentError("joint BHM: bounds must be finite with lo <= hi");
    const double cells = std::floor((hi[d] - lo[d]) / o.spacing + 1e-9) + 1;
    if (!(cells < double(kMaxKernels) + 1)) throw ArgumentError("joint BHM: too many kernels");
    lo_[d] = lo[d];
    n_[d] = static_cast<std::int64_t>(cells);
    total *= n_[d];
    if (total > kMaxKernels) throw ArgumentError("joint BHM: too many kernels");
  }
}

std::size_t JointBhm::size() const {
  if (!bounded_) return (tiles_.size() + retired_.size()) * static_cast<std::size_t>(tile_cells_);
  std::size_t m = 1;
  for (int d = 0; d < dim_; ++d) m *= static_cast<std::size_t>(n_[d]);
  return m;
}

std::size_t JointBhm::memory_bytes() const {
  auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  std::size_t b = sizeof(*this) + bytes(half_) + bytes(half_at_) + bytes(tiles_) + bytes(prec_) +
                  bytes(eta_) + bytes(mean_) + bytes(bcoup_) + bytes(touched_) + bytes(seeded_) +
                  bytes(mark_) + bytes(var_) + bytes(tile_dirty_) + bytes(tile_clock_) +
                  scratch_.bytes();
  // The hash map: its buckets and one node per tile (key, value, next pointer, hash).
  b += tile_index_.bucket_count() * sizeof(void*) +
       tile_index_.size() * (sizeof(std::uint64_t) + sizeof(std::uint32_t) + 2 * sizeof(void*));
  b += bytes(retired_) + retired_index_.bucket_count() * sizeof(void*) +
       retired_index_.size() * (sizeof(std::uint64_t) + sizeof(std::uint32_t) + 2 * sizeof(void*));
  for (const RetiredTile& r : retired_) b += bytes(r.mean) + bytes(r.var);
  return b;
}

std::size_t JointBhm::FeatureList::bytes() const {
  auto b = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return b(kernel) + b(start) + b(runs) + b(run_start) + b(phi) + b(yc) + b(w) + b(lin);
}

std::size_t JointBhm::Scratch::bytes() const {
  auto b = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return FeatureList::bytes() + second.bytes() + b(sample_tiles) + b(r) + b(z) + b(p) + b(q) +
         b(rows_tmp) + b(mu) + b(reached) + b(rows) + b(lambda) + b(next) + b(bits) + b(bits_tmp) +
         b(pbox) + b(box_off) + b(box_len) + b(sample_parts) + b(ybox[0]) + b(ybox[1]) +
         b(part_rows[0]) + b(part_rows[1]) + b(part_around[0]) + b(part_around[1]) + b(part_at[0]) +
         b(part_at[1]) + b(part_around_at[0]) + b(part_around_at[1]);
}

std::uint64_t JointBhm::tile_key(const std::int64_t t[3]) {
  constexpr std::int64_t half = std::int64_t(1) << 20;
  std::uint64_t k = 0;
  for (int d = 0; d < 3; ++d) k = (k << 21) | std::uint64_t(t[d] + half);
  return k;
}

std::int64_t JointBhm::find_tile(const std::int64_t t[3]) const {
  const auto it = tile_index_.find(tile_key(t));
  return it == tile_index_.end() ? -1 : std::int64_t(it->second);
}

std::uint32_t JointBhm::make_tile(const std::int64_t t[3]) {
  const std::int64_t have = find_tile(t);
  if (have >= 0) return static_cast<std::uint32_t>(have);
  const std::size_t cap = std::min<std::size_t>(o_.max_kernels, std::size_t(kMaxKernels));
  if ((tiles_.size() + 1) * static_cast<std::size_t>(tile_cells_) > cap)
    throw ArgumentError("joint BHM: the samples reach more than max_kernels (" +
                        std::to_string(cap) + ") kernels");
  const auto id = static_cast<std::uint32_t>(tiles_.size());
  Tile tile;
  for (int d = 0; d < 3; ++d) tile.coord[d] = static_cast<std::int32_t>(t[d]);
  std::fill(std::begin(tile.nb), std::end(tile.nb), -1);
  const std::int64_t rz = dim_ == 3 ? 1 : 0;
  for (std::int64_t dz = -rz; dz <= rz; ++dz)
    for (std::int64_t dy = -1; dy <= 1; ++dy)
      for (std::int64_t dx = -1; dx <= 1; ++dx) {
        const std::int64_t dt[3] = {dx, dy, dz};
        if (dx == 0 && dy == 0 && dz == 0) {
          tile.nb[nb_slot(dt)] = static_cast<std::int32_t>(id);
          continue;
        }
        const std::int64_t u[3] = {t[0] + dx, t[1] + dy, t[2] + dz};
        const std::int64_t other = find_tile(u);
        if (other < 0) continue;
        tile.nb[nb_slot(dt)] = static_cast<std::int32_t>(other);
        const std::int64_t back[3] = {-dx, -dy, -dz};
        tiles_[std::size_t(other)].nb[nb_slot(back)] = static_cast<std::int32_t>(id);
      }
  tiles_.push_back(tile);
  tile_dirty_.push_back(1);
  tile_clock_.push_back(clock_);  // nothing learned in it yet: up to date
  tile_index_.emplace(tile_key(t), id);
  // Grow the storage by about a quarter at a time: memory follows the stored area closely.
  const std::size_t cells = tiles_.size() * static_cast<std::size_t>(tile_cells_);
  auto grow = [cells](auto& v, std::size_t per, auto value) {
    if (v.capacity() < cells * per) v.reserve(std::max(cells, cells / 4 * 5) * per);
    v.resize(cells * per, value);
  };
  const std::size_t first = std::size_t(id) * static_cast<std::size_t>(tile_cells_);
  grow(prec_, static_cast<std::size_t>(half_slots_), 0.0);
  grow(eta_, 1, 0.0);
  grow(mean_, 1, 0.0);
  grow(bcoup_, 1, 0.0);
  grow(touched_, 1, std::uint8_t(0));
  grow(seeded_, 1, std::uint8_t(0));
  grow(mark_, 1, std::uint8_t(0));
  grow(var_, 1, o_.prior_var);
  for (std::size_t s = first; s < cells; ++s)
    prec_[s * static_cast<std::size_t>(half_slots_)] = 1.0 / o_.prior_var;  // the diagonal
  if (!retired_.empty()) revive(id, tile_key(t));
  return id;
}

void JointBhm::cell_of(std::uint32_t s, std::int64_t g[3]) const {
  const Tile& t = tiles_[s / static_cast<std::uint64_t>(tile_cells_)];
  std::int64_t l = std::int64_t(s % static_cast<std::uint64_t>(tile_cells_));
  for (int d = 0; d < 3; ++d) {
    if (d < dim_) {
      g[d] = std::int64_t(t.coord[d]) * tile_ + l % tile_;
      l /= tile_;
    } else {
      g[d] = 0;
    }
  }
}

void JointBhm::cell_bounds(const std::vector<std::uint32_t>& kernels, std::int64_t lo[3],
                           std::int64_t hi[3]) const {
  for (int d = 0; d < 3; ++d) {
    lo[d] = std::numeric_limits<std::int64_t>::max();
    hi[d] = std::numeric_limits<std::int64_t>::min();
  }
  for (std::uint32_t a : kernels) {
    std::int64_t c[3];
    cell_of(a, c);
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], c[d]);
      hi[d] = std::max(hi[d], c[d]);
    }
  }
}

bool JointBhm::in_grid(const std::int64_t g[3]) const {
  for (int d = 0; d < dim_; ++d) {
    if (bounded_ ? (g[d] < 0 || g[d] >= n_[d]) : (g[d] <= -kCellLimit || g[d] >= kCellLimit))
      return false;
  }
  return true;
}

std::int64_t JointBhm::find_cell(const std::int64_t g[3], std::int64_t hint) const {
  std::int64_t t[3] = {0, 0, 0}, local = 0, stride = 1;
  for (int d = 0; d < dim_; ++d) {
    t[d] = floor_div(g[d], tile_);
    local += (g[d] - t[d] * tile_) * stride;
    stride *= tile_;
  }
  std::int64_t id = -1;
  if (hint >= 0) {
    const Tile& h = tiles_[std::size_t(hint)];
    std::int64_t dt[3] = {0, 0, 0};
    bool near = true;
    for (int d = 0; d < dim_; ++d) {
      dt[d] = t[d] - h.coord[d];
      near = near && dt[d] >= -1 && dt[d] <= 1;
    }
    id = near ? h.nb[nb_slot(dt)] : find_tile(t);
  } else {
    id = find_tile(t);
  }
  return id < 0 ? -1 : id * tile_cells_ + local;
}

void JointBhm::yield_seed(std::uint32_t k, bool with_mean) {
  // A seeded kernel no sample reached holds the seed alone: resetting its precision and eta
  // gives the prior it had before the seed, exactly.
  prec_[std::size_t(k) * static_cast<std::size_t>(half_slots_)] = 1.0 / o_.prior_var;
  eta_[k] = 0;
  if (with_mean) mean_[k] = 0;
}

void JointBhm::mark_dirty(std::uint32_t s) {
  // The exported variance of every kernel whose block holds s: s's tile, and the neighbours
  // its block reaches into.
  const std::uint64_t tid = s / static_cast<std::uint64_t>(tile_cells_);
  const Tile& t = tiles_[tid];
  std::int64_t l = std::int64_t(s % static_cast<std::uint64_t>(tile_cells_));
  std::int64_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) {
    const std::int64_t c = l % tile_;
    l /= tile_;
    lo[d] = c < hb_ ? -1 : 0;
    hi[d] = c >= tile_ - hb_ ? 1 : 0;
  }
  for (std::int64_t dz = lo[2]; dz <= hi[2]; ++dz)
    for (std::int64_t dy = lo[1]; dy <= hi[1]; ++dy)
      for (std::int64_t dx = lo[0]; dx <= hi[0]; ++dx) {
        const std::int64_t dt[3] = {dx, dy, dz};
        const std::int32_t n = t.nb[nb_slot(dt)];
        if (n >= 0) tile_dirty_[std::size_t(n)] = 1;
      }
}

}  // namespace potmap
