#include "potmap/learn/bhm_joint.hpp"

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <string>

#include "bhm_detail.hpp"
#include "bhm_joint_device.hpp"
#include "map/kernel_index.hpp"
#include "potmap/error.hpp"
#include "runtime/host_team.hpp"

namespace potmap {

namespace {

// Grid cells farther than this from the origin are out of reach (tile coordinates, and those of
// their neighbours' neighbours, then fit in 21 bits each of the hash key).
constexpr std::int64_t kCellLimit = std::int64_t(1) << 22;
constexpr std::int64_t kMaxKernels = std::int64_t(1) << 26;

std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  const std::int64_t q = a / b;
  return (a % b != 0 && (a < 0) != (b < 0)) ? q - 1 : q;
}

int nb_slot(const std::int64_t dt[3]) {
  return int((dt[0] + 1) + 3 * (dt[1] + 1) + 9 * (dt[2] + 1));
}

}  // namespace

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
  grid_sum_ = grid_sum2_ = sum_phi2_ = 0;
  const std::int64_t hz = dim == 3 ? hb_ : 0;
  for (std::int64_t dk = -hz; dk <= hz; ++dk)
    for (std::int64_t dj = -hb_; dj <= hb_; ++dj)
      for (std::int64_t di = -hb_; di <= hb_; ++di) {
        const double d2 =
            (double(di * di) + double(dj * dj) + double(dk * dk)) * o.spacing * o.spacing;
        if (gamma_ * d2 > o.tau) continue;
        grid_sum_ += std::exp(-gamma_ * d2);
        grid_sum2_ += std::exp(-2 * gamma_ * d2);
      }
  sum_phi2_ = grid_sum2_;
  if (o.bias) pbb_ = 1.0 / o.prior_var;
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
                  bytes(mark_) + bytes(var_) + bytes(tile_dirty_) + scratch_.bytes();
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

template <class F>
void JointBhm::for_each_tile_part(const std::int64_t a[3], const std::int64_t b[3], F f) const {
  std::int64_t ta[3] = {0, 0, 0}, tb[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) {
    ta[d] = floor_div(a[d], tile_);
    tb[d] = floor_div(b[d], tile_);
  }
  for (std::int64_t tz = ta[2]; tz <= tb[2]; ++tz)
    for (std::int64_t ty = ta[1]; ty <= tb[1]; ++ty)
      for (std::int64_t tx = ta[0]; tx <= tb[0]; ++tx) {
        const std::int64_t t[3] = {tx, ty, tz};
        std::int64_t ca[3] = {0, 0, 0}, cb[3] = {0, 0, 0};
        for (int d = 0; d < dim_; ++d) {
          ca[d] = std::max(a[d], t[d] * tile_);
          cb[d] = std::min(b[d], t[d] * tile_ + tile_ - 1);
        }
        f(t, ca, cb);
      }
}

bool JointBhm::sample_span(const double* x, std::int64_t a[3], std::int64_t b[3]) const {
  bool finite = true;
  for (int d = 0; d < dim_; ++d) finite = finite && std::isfinite(x[d]);
  return finite && feature_span(x, a, b);
}

bool JointBhm::feature_span(const double* x, std::int64_t a[3], std::int64_t b[3]) const {
  for (int d = 0; d < 3; ++d) a[d] = b[d] = 0;
  for (int d = 0; d < dim_; ++d) {
    const double u = (x[d] - lo_[d]) / o_.spacing;
    const double r = rcut_ / o_.spacing;
    const double ua = std::ceil(u - r), ub = std::floor(u + r);
    const double lim_lo = bounded_ ? 0.0 : double(1 - kCellLimit);
    const double lim_hi = bounded_ ? double(n_[d] - 1) : double(kCellLimit - 1);
    if (!(ua <= lim_hi && ub >= lim_lo)) return false;  // also NaN
    a[d] = static_cast<std::int64_t>(std::max(ua, lim_lo));
    b[d] = static_cast<std::int64_t>(std::min(ub, lim_hi));
    if (a[d] > b[d]) return false;
  }
  return true;
}

void JointBhm::span_tiles(const double* x, const std::int64_t a[3], const std::int64_t b[3],
                          bool create, std::int32_t tile_id[8]) {
  // The tiles the span reaches (at most two an axis: a span is at most pad + 1 cells, a tile at
  // least pad), each found, or made, only when the cut-off reaches a kernel position of it.
  std::int64_t ta[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) ta[d] = floor_div(a[d], tile_);
  std::fill(tile_id, tile_id + 8, -1);
  for_each_tile_part(
      a, b, [&](const std::int64_t t[3], const std::int64_t ca[3], const std::int64_t cb[3]) {
        double d2min = 0;  // from x to the nearest kernel of the tile within [a, b]
        for (int d = 0; d < dim_; ++d) {
          const double pa = lo_[d] + double(ca[d]) * o_.spacing;
          const double pb = lo_[d] + double(cb[d]) * o_.spacing;
          const double e = x[d] < pa ? pa - x[d] : (x[d] > pb ? x[d] - pb : 0.0);
          d2min += e * e;
        }
        if (gamma_ * d2min > o_.tau) return;  // no kernel of it within the cut-off
        // Consecutive samples mostly reach the tiles the last ones reached: those are
        // remembered, and only a new one is hashed.
        const std::uint64_t key = tile_key(t);
        std::int64_t id = -1;
        int hit = -1;
        for (int c = 0; c < 4; ++c)
          if (recent_key_[c] == key) hit = c;
        if (hit >= 0) {
          id = recent_id_[hit];
        } else {
          id = find_tile(t);
          if (id < 0 && create) id = make_tile(t);
          if (id >= 0) {
            recent_key_[recent_next_] = key;
            recent_id_[recent_next_] = id;
            recent_next_ = (recent_next_ + 1) & 3;
          }
        }
        tile_id[((t[2] - ta[2]) * 2 + (t[1] - ta[1])) * 2 + (t[0] - ta[0])] =
            static_cast<std::int32_t>(id);
      });
}

template <class Emit>
void JointBhm::span_features(const double* x, const std::int64_t a[3], const std::int64_t b[3],
                             const std::int32_t tile_id[8], Emit emit) const {
  // phi is separable, exp(-gamma d^2) = prod_d exp(-gamma s_d^2), and along an axis, with s
  // the offset from the span's first cell, exp(-gamma (s - c h)^2) is the previous cell's
  // value times R_c, with R_0 = exp(gamma h (2 s - h)) and R_c = R_(c-1) exp(-2 gamma h^2):
  // two exps an axis instead of one per kernel (a few ulps apart; the cut-off test below
  // stays on d^2).
  constexpr std::int64_t kSpan = 72;  // > 2 rcut / spacing + 1, as pad < 64
  double ex[3][kSpan];
  ex[2][0] = 1.0;
  const double h = o_.spacing;
  for (int d = 0; d < dim_; ++d) {
    const double s = x[d] - (lo_[d] + double(a[d]) * h);
    double e = std::exp(-gamma_ * (s * s)), r = std::exp(gamma_ * h * (2 * s - h));
    for (std::int64_t c = 0; c <= b[d] - a[d]; ++c) {
      ex[d][c] = e;
      e *= r;
      r *= step_q_;
    }
  }
  std::int64_t ta[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) ta[d] = floor_div(a[d], tile_);
  // The kernels within the cut-off in raster order (z, y, x): add_outer() adds each pair of a
  // sample's features once, to the first of the two.
  for (std::int64_t k = a[2]; k <= b[2]; ++k) {
    const std::int64_t tz = dim_ == 3 ? floor_div(k, tile_) : 0;
    for (std::int64_t j = a[1]; j <= b[1]; ++j) {
      const std::int64_t ty = floor_div(j, tile_);
      for (std::int64_t tx = ta[0]; tx * tile_ <= b[0]; ++tx) {
        const std::int64_t id = tile_id[((tz - ta[2]) * 2 + (ty - ta[1])) * 2 + (tx - ta[0])];
        const std::int64_t row = ((k - tz * tile_) * tile_ + (j - ty * tile_)) * tile_ - tx * tile_;
        for (std::int64_t i = std::max(a[0], tx * tile_);
             i <= std::min(b[0], tx * tile_ + tile_ - 1); ++i) {
          const std::int64_t g[3] = {i, j, k};
          double d2 = 0;
          for (int d = 0; d < dim_; ++d) {
            const double sd = x[d] - (lo_[d] + double(g[d]) * o_.spacing);
            d2 += sd * sd;
          }
          if (gamma_ * d2 > o_.tau) continue;
          emit(id < 0 ? kNone : static_cast<std::uint32_t>(id * tile_cells_ + row + i), g,
               ex[0][i - a[0]] * ex[1][j - a[1]] * ex[2][k - a[2]]);
        }
      }
    }
  }
}

void JointBhm::features(const double* x, std::vector<Feature>& out, bool create) {
  out.clear();
  std::int64_t a[3], b[3];
  if (!feature_span(x, a, b)) return;
  std::int32_t tile_id[8];
  span_tiles(x, a, b, create, tile_id);
  span_features(x, a, b, tile_id,
                [&out](std::uint32_t kernel, const std::int64_t g[3], double phi) {
                  Feature f;
                  for (int d = 0; d < 3; ++d) f.cell[d] = static_cast<std::int32_t>(g[d]);
                  f.kernel = kernel;
                  f.phi = phi;
                  out.push_back(f);
                });
}

void JointBhm::features(const double* x, std::vector<Feature>& out) const {
  const_cast<JointBhm*>(this)->features(x, out, false);  // creates nothing
}

void JointBhm::add_outer(const Scratch& f, std::size_t i, double c, int part) {
  // The sample's features are in raster order, in runs of consecutive cells along x (a run a
  // line of cells: the cut-off's span is far narrower than the stencil's box). Each feature u
  // adds its products with itself and the features after it to its own half stencil:
  // slot(v - u) = lin(v) - lin(u) + lin(pad, pad, pad). A later run lands on consecutive slots
  // of one of the half's runs, and one cell further along u's run, one slot earlier: its slot
  // is found once per run pair, not once per feature.
  const std::uint32_t r0 = f.run_start[i], r1 = f.run_start[i + 1];
  const double* phi = f.phi.data();
  const std::int64_t* lin = f.lin.data();
  const std::uint32_t* run = f.runs.data();
  const std::int32_t* half_at = half_at_.data() + centre_lin_;
  const auto hs = static_cast<std::size_t>(half_slots_);
  const std::int32_t next_at = half_at[1];
  for (std::uint32_t ra = r0; ra < r1; ++ra) {
    const std::uint32_t u0 = run[2 * ra], la = run[2 * ra + 1];
    for (std::uint32_t k = 0; k < la; ++k) {
      const std::uint32_t u = u0 + k;
      const std::uint32_t ku = f.kernel[u];
      if (part >= 0 && mark_[ku] != part) continue;
      double* row = &prec_[std::size_t(ku) * hs];
      const double ca = c * phi[u];
      row[0] += ca * phi[u];
      // The rest of u's own run: dx = 1, 2, ... on the centre row.
      {
        double* dst = row + next_at;
        const double* src = phi + u + 1;
        for (std::uint32_t m = 0; m + k + 1 < la; ++m) dst[m] += ca * src[m];
      }
      for (std::uint32_t rb = ra + 1; rb < r1; ++rb) {
        const std::uint32_t v0 = run[2 * rb], lb = run[2 * rb + 1];
        double* dst = row + (half_at[lin[v0] - lin[u0]] - std::int32_t(k));
        const double* src = phi + v0;
        for (std::uint32_t m = 0; m < lb; ++m) dst[m] += ca * src[m];
      }
      bcoup_[ku] += ca;
    }
  }
}

void JointBhm::yield_seed(std::uint32_t k, bool with_mean) {
  // A seeded kernel no sample reached holds the seed alone: resetting its precision and eta
  // gives the prior it had before the seed, exactly.
  prec_[std::size_t(k) * static_cast<std::size_t>(half_slots_)] = 1.0 / o_.prior_var;
  eta_[k] = 0;
  if (with_mean) mean_[k] = 0;
}

void JointBhm::dilate_rows(std::vector<std::uint32_t>& rows,
                           const std::vector<std::uint32_t>& reached, std::int64_t mg,
                           std::int64_t mz, Scratch& sc) {
  // The stored kernels within mg cells (mz in z) of a reached one, along every axis at once
  // (the box around each): on a bitmap of the reached kernels' bounding box, dilated one axis
  // at a time, when the box is small beside the kernels' own boxes; otherwise kernel by
  // kernel. The same set either way.
  const std::int64_t r[3] = {mg, mg, mz};
  std::int64_t lo[3], hi[3];
  cell_bounds(reached, lo, hi);
  std::int64_t n[3] = {1, 1, 1}, volume = 1, per = 1;
  for (int d = 0; d < dim_; ++d) {
    const std::int64_t glo = bounded_ ? 0 : 1 - kCellLimit;
    const std::int64_t ghi = bounded_ ? n_[d] - 1 : kCellLimit - 1;
    lo[d] = std::max(lo[d] - r[d], glo);
    hi[d] = std::min(hi[d] + r[d], ghi);
    n[d] = hi[d] - lo[d] + 1;
    volume *= n[d];
    per *= 2 * r[d] + 1;
  }
  if (volume > 4 * per * std::int64_t(reached.size()) + 65536) {
    for (std::uint32_t a : reached) {
      std::int64_t c[3];
      cell_of(a, c);
      const std::int64_t home = a / tile_cells_;
      for (std::int64_t dk = -r[2]; dk <= r[2]; ++dk)
        for (std::int64_t dj = -r[1]; dj <= r[1]; ++dj)
          for (std::int64_t di = -r[0]; di <= r[0]; ++di) {
            const std::int64_t g[3] = {c[0] + di, c[1] + dj, c[2] + dk};
            if (!in_grid(g)) continue;
            const std::int64_t s = find_cell(g, home);
            if (s < 0 || mark_[std::size_t(s)] == 2) continue;
            mark_[std::size_t(s)] = 2;
            rows.push_back(static_cast<std::uint32_t>(s));
          }
    }
    for (std::uint32_t a : rows) mark_[a] = 0;
    std::sort(rows.begin(), rows.end());
    return;
  }
  std::vector<std::uint8_t>&bits = sc.bits, &tmp = sc.bits_tmp;
  bits.assign(std::size_t(volume), 0);
  for (std::uint32_t a : reached) {
    std::int64_t c[3];
    cell_of(a, c);
    bits[std::size_t(((c[2] - lo[2]) * n[1] + (c[1] - lo[1])) * n[0] + (c[0] - lo[0]))] = 1;
  }
  const std::int64_t stride[3] = {1, n[0], n[0] * n[1]};
  for (int axis = 0; axis < dim_; ++axis) {
    const std::int64_t w = r[axis], len = n[axis], st = stride[axis];
    if (w == 0) continue;
    tmp.assign(bits.size(), 0);
    // Lines along `axis`: every cell whose coordinate on it is 0.
    const int p = axis == 0 ? 1 : 0, q = axis == 2 ? 1 : 2;
    for (std::int64_t cq = 0; cq < n[q]; ++cq)
      for (std::int64_t cp = 0; cp < n[p]; ++cp) {
        const std::int64_t start = cp * stride[p] + cq * stride[q];
        const std::uint8_t* in = bits.data() + start;
        std::uint8_t* out = tmp.data() + start;
        std::int64_t count = 0;  // set cells in [i - w, i + w]
        for (std::int64_t k = 0; k < std::min(w, len); ++k) count += in[k * st];
        for (std::int64_t i = 0; i < len; ++i) {
          if (i + w < len) count += in[(i + w) * st];
          if (i - w - 1 >= 0) count -= in[(i - w - 1) * st];
          out[i * st] = count > 0;
        }
      }
    bits.swap(tmp);
  }
  // The stored cells of the box, a run along x at a time (a tile found once, not per cell),
  // tile by tile. A tile's rows come out in storage order and its storage is one range, so
  // putting the tiles in order sorts the rows.
  struct Chunk {
    std::uint32_t tile;
    std::size_t begin, end;
  };
  std::vector<Chunk> chunks;
  const std::size_t base = rows.size();
  for_each_stored_line(lo, hi, [&](std::int64_t s, const std::int64_t g[3], std::int64_t l) {
    const auto tile = static_cast<std::uint32_t>(s / tile_cells_);
    if (chunks.empty() || chunks.back().tile != tile)
      chunks.push_back({tile, rows.size(), rows.size()});
    const std::uint8_t* line =
        bits.data() + ((g[2] - lo[2]) * n[1] + (g[1] - lo[1])) * n[0] + (g[0] - lo[0]);
    for (std::int64_t i = 0; i < l; ++i)
      if (line[i]) rows.push_back(static_cast<std::uint32_t>(s + i));
    chunks.back().end = rows.size();
  });
  auto by_tile = [](const Chunk& x, const Chunk& y) { return x.tile < y.tile; };
  if (std::is_sorted(chunks.begin(), chunks.end(), by_tile)) return;
  std::sort(chunks.begin(), chunks.end(), by_tile);
  std::vector<std::uint32_t>& tmp_rows = sc.rows_tmp;
  tmp_rows.assign(rows.begin() + std::ptrdiff_t(base), rows.end());
  std::size_t at = base;
  for (const Chunk& c : chunks)
    for (std::size_t k = c.begin; k < c.end; ++k) rows[at++] = tmp_rows[k - base];
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

template <class F>
void JointBhm::for_each_stored_line(const std::int64_t a[3], const std::int64_t b[3], F f) const {
  for_each_tile_part(
      a, b, [&](const std::int64_t t[3], const std::int64_t ca[3], const std::int64_t cb[3]) {
        const std::int64_t id = find_tile(t);
        if (id < 0) return;
        for (std::int64_t k = ca[2]; k <= cb[2]; ++k)
          for (std::int64_t j = ca[1]; j <= cb[1]; ++j) {
            const std::int64_t local =
                ((k - t[2] * tile_) * tile_ + (j - t[1] * tile_)) * tile_ + (ca[0] - t[0] * tile_);
            const std::int64_t g[3] = {ca[0], j, k};
            f(id * tile_cells_ + local, g, cb[0] - ca[0] + 1);
          }
      });
}

double JointBhm::coupling(std::int64_t a, std::int64_t b, const std::int64_t o[3]) const {
  if (b < 0) return 0.0;  // a kernel no sample reached couples to nothing
  std::int64_t slot = 0;
  for (int d = dim_ - 1; d >= 0; --d) slot = slot * box_ + o[d];
  if (slot == 0) return prec_[std::size_t(a) * static_cast<std::size_t>(half_slots_)];
  const std::int64_t first = slot > 0 ? a : b;
  const std::int32_t at =
      half_at_[static_cast<std::size_t>(centre_lin_ + (slot > 0 ? slot : -slot))];
  return at < 0
             ? 0.0
             : prec_[std::size_t(first) * static_cast<std::size_t>(half_slots_) + std::size_t(at)];
}

bool JointBhm::box_rows(const std::vector<std::uint32_t>& rows, Scratch& sc) const {
  // A dense box of cells around the rows: the rows' bounds grown by the stencil's reach twice,
  // so that every kernel whose stencil reaches a row (within pad) has its own stencil inside.
  // The products then stream each kernel's half stencil against x and y in the box (the solve
  // is bound by those reads). False when the box would be much larger than the rows.
  sc.boxed = false;
  if (rows.empty()) return false;
  std::int64_t lo[3], hi[3];
  cell_bounds(rows, lo, hi);
  std::int64_t volume = 1;
  for (int d = 0; d < 3; ++d) {
    const std::int64_t r = d < dim_ ? 2 * pad_ : 0;
    sc.box_lo[d] = lo[d] - r;
    sc.box_n[d] = hi[d] - lo[d] + 1 + 2 * r;
    volume *= sc.box_n[d];
  }
  if (volume > 64 * std::int64_t(rows.size()) + 65536) return false;
  const std::int64_t* n = sc.box_n;
  std::vector<std::int64_t>& at = sc.part_around_at[0];  // scratch here
  at.resize(rows.size());
  for (std::size_t u = 0; u < rows.size(); ++u) {
    std::int64_t c[3];
    cell_of(rows[u], c);
    at[u] = ((c[2] - sc.box_lo[2]) * n[1] + (c[1] - sc.box_lo[1])) * n[0] + (c[0] - sc.box_lo[0]);
  }
  sc.box_off.resize(half_.size());
  sc.box_len.resize(half_.size());
  sc.box_reach = 1;
  for (std::size_t h = 0; h < half_.size(); ++h) {
    sc.box_off[h] = (std::int64_t(half_[h].d[2]) * n[1] + half_[h].d[1]) * n[0] + half_[h].d[0];
    sc.box_len[h] = half_[h].len;
    sc.box_reach = std::max(sc.box_reach, sc.box_off[h] + half_[h].len);
  }
  // The parts: the rows before and after the median row's cell, each in storage order.
  std::vector<std::int64_t>& sorted = sc.part_around_at[1];
  sorted = at;
  std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(sorted.size() / 2),
                   sorted.end());
  sc.box_split = sorted[sorted.size() / 2];
  for (int p = 0; p < 2; ++p) {
    sc.part_rows[p].clear();
    sc.part_at[p].clear();
  }
  for (std::size_t u = 0; u < rows.size(); ++u) {
    const int p = at[u] < sc.box_split ? 0 : 1;
    sc.part_rows[p].push_back(rows[u]);
    sc.part_at[p].push_back(at[u]);
  }
  sc.pbox.assign(std::size_t(volume), 0.0);
  for (int p = 0; p < 2; ++p) sc.ybox[p].assign(std::size_t(volume), 0.0);
  sc.boxed = true;
  return true;
}

namespace {

// ybox += P xbox over the listed kernels' half stencils (`hs` doubles each, from `prec`): each
// gives its own row's products with the kernels after it and, mirrored, theirs with it.
void half_products(const double* prec, std::size_t hs, const std::int32_t* len,
                   const std::int64_t* off, std::size_t nh, const std::uint32_t* kernel,
                   const std::int64_t* at, std::size_t m, const double* xbox, double* ybox) {
  for (std::size_t u = 0; u < m; ++u) {
    const double* v = prec + std::size_t(kernel[u]) * hs;
    const std::int64_t a = at[u];
    const double xa = xbox[a];
    double s0 = v[0] * xa, s1 = 0;
    ++v;
    for (std::size_t h = 0; h < nh; ++h) {
      const double* __restrict px = xbox + a + off[h];
      double* __restrict py = ybox + a + off[h];
      const std::int32_t n = len[h];
      for (std::int32_t j = 0; j < n; ++j) {
        s1 += v[j] * px[j];
        py[j] += v[j] * xa;
      }
      v += n;
    }
    ybox[a] += s0 + s1;
  }
}

// One half run of compile-time length L: the same sums in the same order as half_products()'s
// loop, unrolled.
template <int L>
inline void half_run(const double* __restrict v, const double* __restrict px, double* __restrict py,
                     double xa, double& s1) {
  for (int j = 0; j < L; ++j) {
    s1 += v[j] * px[j];
    py[j] += v[j] * xa;
  }
}

// half_products() for a stencil whose half runs have the lengths L..., known when compiled: the
// same result bit for bit. The runs are a few doubles long (3, 7, 7 and 5 at the 2D defaults), so
// the general loop spends as much on its bounds as on its products.
template <int... L>
void half_products_fixed(const double* prec, std::size_t hs, const std::int64_t* off,
                         const std::uint32_t* kernel, const std::int64_t* at, std::size_t m,
                         const double* xbox, double* ybox) {
  constexpr int lens[] = {L...};
  constexpr int nh = sizeof...(L);
  int first[nh] = {};
  for (int h = 1; h < nh; ++h) first[h] = first[h - 1] + lens[h - 1];
  for (std::size_t u = 0; u < m; ++u) {
    const double* v = prec + std::size_t(kernel[u]) * hs;
    const std::int64_t a = at[u];
    const double xa = xbox[a];
    const double s0 = v[0] * xa;
    double s1 = 0;
    ++v;
    int h = 0;
    ((half_run<L>(v + first[h], xbox + a + off[h], ybox + a + off[h], xa, s1), ++h), ...);
    ybox[a] += s0 + s1;
  }
}

// The products through half_products_fixed() where the stencil is one it was compiled for (the
// 2D default), else half_products().
void half_products_any(const double* prec, std::size_t hs, const std::int32_t* len,
                       const std::int64_t* off, std::size_t nh, const std::uint32_t* kernel,
                       const std::int64_t* at, std::size_t m, const double* xbox, double* ybox) {
  if (nh == 4 && len[0] == 3 && len[1] == 7 && len[2] == 7 && len[3] == 5)
    half_products_fixed<3, 7, 7, 5>(prec, hs, off, kernel, at, m, xbox, ybox);
  else
    half_products(prec, hs, len, off, nh, kernel, at, m, xbox, ybox);
}

}  // namespace

void JointBhm::multiply_box(const std::vector<double>& x, double xb, bool x_outside,
                            const std::vector<std::uint32_t>& rows, std::vector<double>& y,
                            double& yb, Scratch& sc, Context* ctx) const {
  (void)rows;  // the parts hold them
  double* xbx = sc.pbox.data();
  const std::int64_t* n = sc.box_n;
  const std::int64_t* lo = sc.box_lo;
  const std::int64_t volume = n[0] * n[1] * n[2];
  const std::int64_t split = sc.box_split;
  const std::int64_t spill = std::min(volume, split + sc.box_reach);  // part 0's y ends here
  const auto hs = static_cast<std::size_t>(half_slots_);
  if (x_outside) {
    // x over the whole box, and every stored kernel within pad of the rows' bounds: their
    // stencils may reach a row.
    const std::int64_t hi[3] = {lo[0] + n[0] - 1, lo[1] + n[1] - 1, lo[2] + n[2] - 1};
    for_each_stored_line(lo, hi, [&](std::int64_t s, const std::int64_t g[3], std::int64_t l) {
      const std::int64_t at = ((g[2] - lo[2]) * n[1] + (g[1] - lo[1])) * n[0] + (g[0] - lo[0]);
      std::memcpy(xbx + at, x.data() + s, sizeof(double) * std::size_t(l));
    });
    std::int64_t a[3], b[3];
    for (int d = 0; d < 3; ++d) {
      const std::int64_t r = d < dim_ ? pad_ : 0;
      a[d] = lo[d] + r;
      b[d] = lo[d] + n[d] - 1 - r;
    }
    for (int p = 0; p < 2; ++p) {
      sc.part_around[p].clear();
      sc.part_around_at[p].clear();
    }
    for_each_stored_line(a, b, [&](std::int64_t s, const std::int64_t g[3], std::int64_t l) {
      const std::int64_t at = ((g[2] - lo[2]) * n[1] + (g[1] - lo[1])) * n[0] + (g[0] - lo[0]);
      for (std::int64_t i = 0; i < l; ++i) {
        const int p = at + i < split ? 0 : 1;
        sc.part_around[p].push_back(static_cast<std::uint32_t>(s + i));
        sc.part_around_at[p].push_back(at + i);
      }
    });
  } else {
    for (int p = 0; p < 2; ++p)
      for (std::size_t u = 0; u < sc.part_rows[p].size(); ++u)
        xbx[sc.part_at[p][u]] = x[sc.part_rows[p][u]];
  }
  // The parts' products, each into its own box of y (cleared first: part 0 writes cells before
  // `spill`, part 1 cells from `split` on), then each part's rows gathered, part 1's adding
  // part 0's spill. The same two parts with or without a helper: the sums do not depend on
  // the threads.
  double bias_part[2] = {0, 0};
  detail::for_each_item(ctx, 2, [&](std::size_t p) {
    double* ybx = sc.ybox[p].data();
    const std::int64_t first = p == 0 ? 0 : split, last = p == 0 ? spill : volume;
    std::fill(ybx + first, ybx + last, 0.0);
    const std::vector<std::uint32_t>& k = x_outside ? sc.part_around[p] : sc.part_rows[p];
    const std::vector<std::int64_t>& at = x_outside ? sc.part_around_at[p] : sc.part_at[p];
    half_products_any(prec_.data(), hs, sc.box_len.data(), sc.box_off.data(), half_.size(),
                      k.data(), at.data(), k.size(), xbx, ybx);
  });
  detail::for_each_item(ctx, 2, [&](std::size_t p) {
    const double* y0 = sc.ybox[0].data();
    const double* y1 = sc.ybox[1].data();
    const std::uint32_t* k = sc.part_rows[p].data();
    const std::int64_t* at = sc.part_at[p].data();
    const std::size_t m = sc.part_rows[p].size();
    // The bias row summed in a local: through the reference, every term would be a store and
    // a load in one dependent chain.
    double sb = 0;
    for (std::size_t u = 0; u < m; ++u) {
      const std::uint32_t a = k[u];
      const std::int64_t c = at[u];
      double v = p == 0 ? y0[c] : (c < spill ? y0[c] + y1[c] : y1[c]);
      if (o_.bias) {
        v += bcoup_[a] * xb;
        sb += bcoup_[a] * x[a];
      }
      y[a] = v;
    }
    bias_part[p] = sb;
    // Leave x's box zero for the next product.
    if (x_outside) {
      const std::int64_t half = volume / 2;
      std::fill(xbx + (p == 0 ? 0 : half), xbx + (p == 0 ? half : volume), 0.0);
    } else {
      for (std::size_t u = 0; u < m; ++u) xbx[at[u]] = 0;
    }
  });
  yb = (o_.bias ? pbb_ * xb : 0.0) + bias_part[0] + bias_part[1];
}

void JointBhm::multiply_sparse(const std::vector<double>& x, double xb,
                               const std::vector<std::uint32_t>& rows, std::vector<double>& y,
                               double& yb) const {
  double sb = o_.bias ? pbb_ * xb : 0.0;
  const auto hs = static_cast<std::size_t>(half_slots_);
  for (const std::uint32_t a : rows) {
    std::int64_t g[3];
    cell_of(a, g);
    const std::int64_t home = a / tile_cells_;
    const double* row = &prec_[std::size_t(a) * hs];
    double v = row[0] * x[a];
    for (const HalfRun& h : half_)
      for (std::int32_t j = 0; j < h.len; ++j) {
        const std::int64_t o[3] = {h.d[0] + j, h.d[1], h.d[2]};
        const std::int64_t after[3] = {g[0] + o[0], g[1] + o[1], g[2] + o[2]};
        const std::int64_t before[3] = {g[0] - o[0], g[1] - o[1], g[2] - o[2]};
        const std::int64_t b = in_grid(after) ? find_cell(after, home) : -1;
        if (b >= 0) v += row[h.at + j] * x[std::size_t(b)];
        const std::int64_t c = in_grid(before) ? find_cell(before, home) : -1;
        if (c >= 0) v += prec_[std::size_t(c) * hs + std::size_t(h.at + j)] * x[std::size_t(c)];
      }
    if (o_.bias) {
      v += bcoup_[a] * xb;
      sb += bcoup_[a] * x[a];
    }
    y[a] = v;
  }
  yb = sb;
}

double JointBhm::solve(const std::vector<std::uint32_t>& rows, std::vector<double>& x, double& xb,
                       double tol, int max_it, std::size_t* its, Scratch& sc, bool rows_boxed,
                       Context* ctx, const double* bias_outside, bool residual_given) const {
  // Conjugate gradients on the rows `rows` (and the bias), the other means held fixed, from
  // the current x. Jacobi preconditioner. sc.p is zero outside `rows` on entry and on exit.
  const std::size_t st = x.size();
  const auto hs = static_cast<std::size_t>(half_slots_);
  for (std::vector<double>* v : {&sc.r, &sc.z, &sc.p, &sc.q})
    if (v->size() < st) v->resize(st, 0.0);
  std::vector<double>&r = sc.r, &z = sc.z, &p = sc.p, &q = sc.q;
  double rb = 0, zb = 0, pb = 0, qb = 0;
  const bool boxed = rows_boxed ? sc.boxed : box_rows(rows, sc);
  if (residual_given) {
    rb = o_.bias ? sc.rb : 0.0;
  } else {
    double yb = 0;
    if (boxed)
      multiply_box(x, xb, true, rows, q, yb, sc, ctx);
    else
      multiply_sparse(x, xb, rows, q, yb);
    // The bias row reads every mean, not only those of `rows`.
    if (o_.bias) {
      yb = pbb_ * xb;
      if (bias_outside) {
        yb += *bias_outside;
        for (std::uint32_t a : rows) yb += bcoup_[a] * x[a];
      } else {
        for (std::size_t a = 0; a < st; ++a) yb += bcoup_[a] * x[a];
      }
      rb = etab_ - yb;
    }
    for (std::uint32_t a : rows) r[a] = eta_[a] - q[a];
  }
  double rr = rb * rb, ee = etab_ * etab_;
  for (std::uint32_t a : rows) {
    rr += r[a] * r[a];
    ee += eta_[a] * eta_[a];
  }
  const double stop = tol * tol * std::max(ee, 1e-300);
  auto precondition = [&] {
    double rz = 0;
    for (std::uint32_t a : rows) {
      z[a] = r[a] / prec_[std::size_t(a) * hs];
      rz += r[a] * z[a];
    }
    if (o_.bias) {
      zb = rb / pbb_;
      rz += rb * zb;
    }
    return rz;
  };
  double rz = precondition();
  for (std::uint32_t a : rows) p[a] = z[a];
  pb = zb;
  int it = 0;
  for (; it < max_it && rr > stop; ++it) {
    if (boxed)
      multiply_box(p, pb, false, rows, q, qb, sc, ctx);
    else
      multiply_sparse(p, pb, rows, q, qb);
    double pq = pb * qb;
    for (std::uint32_t a : rows) pq += p[a] * q[a];
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    rr = 0;
    for (std::uint32_t a : rows) {
      x[a] += alpha * p[a];
      r[a] -= alpha * q[a];
      rr += r[a] * r[a];
    }
    if (o_.bias) {
      xb += alpha * pb;
      rb -= alpha * qb;
      rr += rb * rb;
    }
    const double rz_new = precondition();
    const double beta = rz_new / rz;
    rz = rz_new;
    for (std::uint32_t a : rows) p[a] = z[a] + beta * p[a];
    pb = zb + beta * pb;
  }
  for (std::uint32_t a : rows) p[a] = 0;
  sc.rb = rb;
  if (its) *its += static_cast<std::size_t>(it);
  return std::sqrt(rr / std::max(ee, 1e-300));
}

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

void JointBhm::update(const LabelledPoints& samples, Context* ctx) {
  check_samples(samples);
  stats_ = {};
  if (samples.empty()) return;
  if (ctx && detail::sums_on_device(o_.sums, ctx->info()))
    update_on_device(samples, *ctx);
  else
    update_on_host(samples, ctx);
}

void JointBhm::list_features(const LabelledPoints& samples, Context* ctx) {
  // The scan's features, flat: each sample's kernels, phi and stencil-linear cells, and its
  // runs of consecutive cells (add_outer()). Computed once for every EM iteration.
  Scratch& sc = scratch_;
  const bool weighted = !samples.weight.empty();
  const std::size_t ns = samples.size();
  auto clear = [](FeatureList& out) {
    out.kernel.clear();
    out.phi.clear();
    out.lin.clear();
    out.runs.clear();
    out.yc.clear();
    out.w.clear();
    out.start.assign(1, 0);
    out.run_start.assign(1, 0);
  };
  // Sample i's features (span a, b; tiles from span_tiles()) appended to `out`.
  auto list = [&](FeatureList& out, std::size_t i, const std::int64_t a[3], const std::int64_t b[3],
                  const std::int32_t tiles[8]) {
    const std::size_t first = out.kernel.size();
    span_features(&samples.position[i * dim_], a, b, tiles,
                  [&](std::uint32_t kernel, const std::int64_t g[3], double phi) {
                    // In raster order: a stencil-linear cell each.
                    std::int64_t l = 0;
                    for (int d = dim_ - 1; d >= 0; --d) l = l * box_ + g[d];
                    const auto at = static_cast<std::uint32_t>(out.kernel.size());
                    if (at > first && l == out.lin.back() + 1)
                      ++out.runs.back();
                    else
                      out.runs.insert(out.runs.end(), {at, 1u});
                    out.kernel.push_back(kernel);
                    out.phi.push_back(phi);
                    out.lin.push_back(l);
                  });
    if (out.kernel.size() == first) return;
    out.start.push_back(static_cast<std::uint32_t>(out.kernel.size()));
    out.run_start.push_back(static_cast<std::uint32_t>(out.runs.size() / 2));
    const double w = weighted ? samples.weight[i] : 1.0;
    out.w.push_back(w);
    out.yc.push_back(samples.label[i] ? 0.5 * w : -0.5 * w);
  };
  auto span = [&](std::size_t i, std::int64_t a[3], std::int64_t b[3]) {
    return sample_span(&samples.position[i * dim_], a, b);
  };
  // Tiles are made in the order of the samples (their storage order), before any change to the
  // posterior: a new tile holds the prior, so a throw (too many kernels) leaves the model as it
  // was.
  if (!ctx) {
    // One pass, each sample's tiles then its features: the lists of the two halves below.
    clear(sc);
    for (std::size_t i = 0; i < ns; ++i) {
      std::int64_t a[3], b[3];
      std::int32_t tiles[8];
      if (!span(i, a, b)) continue;
      span_tiles(&samples.position[i * dim_], a, b, true, tiles);
      list(sc, i, a, b, tiles);
    }
    return;
  }
  // The tiles first, on this thread; then the features of each half of the samples into its
  // own list, the second appended to the first: the lists of one pass over the samples.
  constexpr std::int32_t kNoSpan = -2;
  sc.sample_tiles.resize(ns * 8);
  for (std::size_t i = 0; i < ns; ++i) {
    std::int32_t* tiles = &sc.sample_tiles[i * 8];
    std::int64_t a[3], b[3];
    if (!span(i, a, b))
      tiles[0] = kNoSpan;
    else
      span_tiles(&samples.position[i * dim_], a, b, true, tiles);
  }
  detail::for_each_item(ctx, 2, [&](std::size_t h) {
    FeatureList& out = h == 0 ? static_cast<FeatureList&>(sc) : sc.second;
    clear(out);
    for (std::size_t i = h * ns / 2; i < (h + 1) * ns / 2; ++i) {
      const std::int32_t* tiles = &sc.sample_tiles[i * 8];
      std::int64_t a[3], b[3];
      if (tiles[0] == kNoSpan || !span(i, a, b)) continue;
      list(out, i, a, b, tiles);
    }
  });
  const FeatureList& s2 = sc.second;
  const auto nf = static_cast<std::uint32_t>(sc.kernel.size());
  const auto nr = static_cast<std::uint32_t>(sc.runs.size() / 2);
  sc.kernel.insert(sc.kernel.end(), s2.kernel.begin(), s2.kernel.end());
  sc.phi.insert(sc.phi.end(), s2.phi.begin(), s2.phi.end());
  sc.lin.insert(sc.lin.end(), s2.lin.begin(), s2.lin.end());
  sc.yc.insert(sc.yc.end(), s2.yc.begin(), s2.yc.end());
  sc.w.insert(sc.w.end(), s2.w.begin(), s2.w.end());
  for (std::size_t k = 1; k < s2.start.size(); ++k) sc.start.push_back(s2.start[k] + nf);
  for (std::size_t k = 1; k < s2.run_start.size(); ++k)
    sc.run_start.push_back(s2.run_start[k] + nr);
  for (std::size_t k = 0; k < s2.runs.size(); k += 2)
    sc.runs.insert(sc.runs.end(), {s2.runs[k] + nf, s2.runs[k + 1]});
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
    for (std::size_t a = 0; a < mean_.size(); ++a)
      if (!mark_[a]) bias_outside += bcoup_[a] * mean_[a];
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

void JointBhm::update_by_scan(const LabelledPoints& samples) {
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
    update(s);
  }
}

bool JointBhm::near_data(const std::int64_t g[3], std::int64_t hint) const {
  // Whether a sample or a seed reached a kernel of g's block.
  const std::int64_t hz = dim_ == 3 ? hb_ : 0;
  for (std::int64_t dk = -hz; dk <= hz; ++dk)
    for (std::int64_t dj = -hb_; dj <= hb_; ++dj)
      for (std::int64_t di = -hb_; di <= hb_; ++di) {
        const std::int64_t c[3] = {g[0] + di, g[1] + dj, g[2] + dk};
        const std::int64_t s = find_cell(c, hint);
        if (s >= 0 && (touched_[std::size_t(s)] || seeded_[std::size_t(s)])) return true;
      }
  return false;
}

double JointBhm::predictive_var_at(const std::int64_t g[3], std::int64_t hint,
                                   std::vector<double>& scratch) const {
  // phi(h_k)^T (P_BB)^-1 phi(h_k) on the block B of kernels that reach h_k: the variance with
  // the kernels outside the block held at their means (a slight underestimate). Kernels of the
  // block that are not stored hold their prior.
  std::vector<std::int64_t> block;
  std::vector<std::int64_t> cells;
  std::vector<double> phi;
  const std::int64_t hz = dim_ == 3 ? hb_ : 0;
  for (std::int64_t dk = -hz; dk <= hz; ++dk)
    for (std::int64_t dj = -hb_; dj <= hb_; ++dj)
      for (std::int64_t di = -hb_; di <= hb_; ++di) {
        const std::int64_t c[3] = {g[0] + di, g[1] + dj, g[2] + dk};
        if (!in_grid(c)) continue;
        const double d2 =
            (double(di * di) + double(dj * dj) + double(dk * dk)) * o_.spacing * o_.spacing;
        if (gamma_ * d2 > o_.tau) continue;
        block.push_back(find_cell(c, hint));
        cells.insert(cells.end(), {c[0], c[1], c[2]});
        phi.push_back(std::exp(-gamma_ * d2));
      }
  const std::size_t b = block.size();
  scratch.assign(b * b, 0.0);
  Eigen::Map<Eigen::MatrixXd> A(scratch.data(), Eigen::Index(b), Eigen::Index(b));
  for (std::size_t u = 0; u < b; ++u) {
    if (block[u] < 0) {
      A(Eigen::Index(u), Eigen::Index(u)) = 1.0 / o_.prior_var;
      continue;
    }
    for (std::size_t v = 0; v < b; ++v) {
      const std::int64_t o[3] = {cells[3 * v] - cells[3 * u], cells[3 * v + 1] - cells[3 * u + 1],
                                 cells[3 * v + 2] - cells[3 * u + 2]};
      A(Eigen::Index(u), Eigen::Index(v)) = coupling(block[u], block[v], o);
    }
  }
  Eigen::Map<const Eigen::VectorXd> ph(phi.data(), Eigen::Index(b));
  const Eigen::LLT<Eigen::MatrixXd> llt(A);
  if (llt.info() != Eigen::Success) return o_.prior_var * ph.squaredNorm();
  return ph.dot(llt.solve(ph));
}

double JointBhm::exported_var(const std::int64_t g[3], std::int64_t s,
                              std::vector<double>& scratch) const {
  const std::int64_t hint = s >= 0 ? s / tile_cells_ : -1;
  if (!near_data(g, hint)) return o_.prior_var;
  return std::min(o_.prior_var, predictive_var_at(g, hint, scratch) / sum_phi2_);
}

std::size_t JointBhm::seed_unreached(const KernelMap& field, double min_var, double min_support) {
  if (field.dim != dim_)
    throw ArgumentError("joint BHM: the seed map is " + std::to_string(field.dim) + "D, the map " +
                        std::to_string(dim_) + "D");
  field.validate("joint BHM seed");
  if (field.empty()) return 0;
  const detail::KernelIndex index(field, o_.tau);
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  field.bounds(lo, hi);
  const double reach = index.max_reach();
  std::int64_t a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) {
    double ua = std::floor((lo[d] - reach - lo_[d]) / o_.spacing);
    double ub = std::ceil((hi[d] + reach - lo_[d]) / o_.spacing);
    ua = std::max(ua, bounded_ ? 0.0 : double(1 - kCellLimit));
    ub = std::min(ub, bounded_ ? double(n_[d] - 1) : double(kCellLimit - 1));
    if (!(ua <= ub)) return 0;
    a[d] = static_cast<std::int64_t>(ua);
    b[d] = static_cast<std::int64_t>(ub);
  }
  const double floor_var = std::min(std::max(min_var, 1e-12), o_.prior_var);
  std::vector<std::uint32_t> near;
  std::size_t seeded = 0;
  std::int64_t hint = -1;
  for (std::int64_t k = a[2]; k <= b[2]; ++k)
    for (std::int64_t j = a[1]; j <= b[1]; ++j)
      for (std::int64_t i = a[0]; i <= b[0]; ++i) {
        const std::int64_t g[3] = {i, j, dim_ == 3 ? k : 0};
        std::int64_t s = find_cell(g, hint);
        if (s >= 0) {
          hint = s / tile_cells_;
          if (touched_[std::size_t(s)] || seeded_[std::size_t(s)]) continue;
        }
        const double x[3] = {lo_[0] + double(i) * o_.spacing, lo_[1] + double(j) * o_.spacing,
                             lo_[2] + double(k) * o_.spacing};
        const detail::LocalSums ls = detail::local_sums(field, index, x, near);
        const double mu = ls.mu, s2 = ls.s2, support = ls.sum;
        if (support < min_support) continue;
        if (s < 0) {
          std::int64_t t[3] = {0, 0, 0};
          for (int d = 0; d < dim_; ++d) t[d] = floor_div(g[d], tile_);
          make_tile(t);
          s = find_cell(g, -1);
          hint = s / tile_cells_;
        }
        const auto su = static_cast<std::size_t>(s);
        const double m0 = mu / grid_sum_;
        const double v0 = std::min(o_.prior_var, std::max(floor_var, s2 / grid_sum2_));
        // Replace the prior's part of the natural parameters: precision 1/v0, eta m0/v0.
        prec_[su * static_cast<std::size_t>(half_slots_)] += 1.0 / v0 - 1.0 / o_.prior_var;
        eta_[su] += m0 / v0;
        mean_[su] = m0;
        seeded_[su] = 1;
        mark_dirty(static_cast<std::uint32_t>(s));
        ++seeded;
      }
  return seeded;
}

KernelMap JointBhm::map() const {
  // Polish the means over every kernel a sample or a seed reached, on a copy.
  std::vector<std::uint32_t> rows;
  for (std::size_t a = 0; a < touched_.size(); ++a)
    if (touched_[a] || seeded_[a]) rows.push_back(static_cast<std::uint32_t>(a));
  std::vector<double> mean = mean_;
  double meanb = meanb_;
  if (!rows.empty()) {
    Scratch sc;
    solve(rows, mean, meanb, 1e-8, 4 * o_.cg_max_iterations, nullptr, sc);
  }
  // Variances of the tiles whose precision changed since the last export.
  std::vector<double> scratch;
  for (std::size_t t = 0; t < tiles_.size(); ++t) {
    if (!tile_dirty_[t]) continue;
    for (std::int64_t l = 0; l < tile_cells_; ++l) {
      const auto s = static_cast<std::uint32_t>(std::int64_t(t) * tile_cells_ + l);
      std::int64_t g[3];
      cell_of(s, g);
      var_[s] = in_grid(g) ? exported_var(g, s, scratch) : o_.prior_var;
    }
    tile_dirty_[t] = 0;
  }
  KernelMap m;
  m.dim = dim_;
  m.reserve(size());
  auto position = [&](const std::int64_t g[3], double p[3]) {
    for (int d = 0; d < 3; ++d) p[d] = d < dim_ ? lo_[d] + double(g[d]) * o_.spacing : 0.0;
  };
  if (bounded_) {
    std::int64_t hint = -1;
    for (std::int64_t k = 0; k < (dim_ == 3 ? n_[2] : 1); ++k)
      for (std::int64_t j = 0; j < n_[1]; ++j)
        for (std::int64_t i = 0; i < n_[0]; ++i) {
          const std::int64_t g[3] = {i, j, k};
          double p[3];
          position(g, p);
          const std::int64_t s = find_cell(g, hint);
          if (s >= 0) {
            hint = s / tile_cells_;
            m.push_back(p, gamma_, mean[std::size_t(s)], var_[std::size_t(s)]);
          } else {
            // Not stored: its prior mean, and the variance of its block (which may hold a
            // stored neighbour).
            m.push_back(p, gamma_, 0.0, exported_var(g, -1, scratch));
          }
        }
  } else {
    for (std::uint32_t s = 0; s < mean.size(); ++s) {
      std::int64_t g[3];
      cell_of(s, g);
      double p[3];
      position(g, p);
      m.push_back(p, gamma_, mean[s], var_[s]);
    }
    // Retired tiles, as they were left (retire_far()).
    for (const RetiredTile& r : retired_)
      for (std::int64_t l = 0; l < tile_cells_; ++l) {
        std::int64_t g[3] = {0, 0, 0}, rest = l;
        for (int d = 0; d < dim_; ++d) {
          g[d] = std::int64_t(r.coord[d]) * tile_ + rest % tile_;
          rest /= tile_;
        }
        double p[3];
        position(g, p);
        m.push_back(p, gamma_, r.mean[std::size_t(l)], r.var[std::size_t(l)]);
      }
  }
  m.has_bias = o_.bias;
  if (o_.bias) {
    m.bias_mean = meanb;
    m.bias_var = 1.0 / pbb_;
  }
  return m;
}

void JointBhm::predict_exact(const double* points, std::size_t n, double* mean, double* var) const {
  // P over the stored kernels of the grid (and the bias, last) as a sparse matrix; one
  // factorisation. Kernels not stored are independent at their prior (mean 0, prior_var).
  std::vector<std::int64_t> index(mean_.size(), -1);
  std::vector<std::uint32_t> stored;
  for (std::uint32_t s = 0; s < mean_.size(); ++s) {
    std::int64_t g[3];
    cell_of(s, g);
    if (!in_grid(g)) continue;
    index[s] = std::int64_t(stored.size());
    stored.push_back(s);
  }
  const auto m = Eigen::Index(stored.size());
  const Eigen::Index dimp = m + (o_.bias ? 1 : 0);
  std::vector<Eigen::Triplet<double>> t;
  for (Eigen::Index u = 0; u < m; ++u) {
    const std::uint32_t a = stored[std::size_t(u)];
    std::int64_t g[3];
    cell_of(a, g);
    const double* row = &prec_[std::size_t(a) * static_cast<std::size_t>(half_slots_)];
    const std::int64_t home = a / tile_cells_;
    t.emplace_back(u, u, row[0]);
    for (const HalfRun& h : half_)
      for (std::int32_t j = 0; j < h.len; ++j) {
        const double p = row[h.at + j];
        if (p == 0) continue;
        const std::int64_t c[3] = {g[0] + h.d[0] + j, g[1] + h.d[1], g[2] + h.d[2]};
        const std::int64_t b = in_grid(c) ? find_cell(c, home) : -1;
        if (b < 0 || index[std::size_t(b)] < 0) continue;
        t.emplace_back(u, Eigen::Index(index[std::size_t(b)]), p);
        t.emplace_back(Eigen::Index(index[std::size_t(b)]), u, p);
      }
    if (o_.bias && bcoup_[a] != 0) {
      t.emplace_back(u, m, bcoup_[a]);
      t.emplace_back(m, u, bcoup_[a]);
    }
  }
  if (o_.bias) t.emplace_back(m, m, pbb_);
  Eigen::SparseMatrix<double> P(dimp, dimp);
  P.setFromTriplets(t.begin(), t.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(P);
  if (ldlt.info() != Eigen::Success) throw Error("joint BHM: precision not positive definite");
  Eigen::VectorXd eta(dimp);
  for (Eigen::Index u = 0; u < m; ++u) eta[u] = eta_[stored[std::size_t(u)]];
  if (o_.bias) eta[m] = etab_;
  const Eigen::VectorXd w = ldlt.solve(eta);
  std::vector<Feature> f;
  Eigen::VectorXd phi(dimp);
  for (std::size_t i = 0; i < n; ++i) {
    features(points + i * dim_, f);
    phi.setZero();
    double prior_part = 0;
    for (const Feature& x : f) {
      if (x.kernel == kNone)
        prior_part += o_.prior_var * x.phi * x.phi;
      else
        phi[index[x.kernel]] = x.phi;
    }
    if (o_.bias) phi[m] = 1.0;
    mean[i] = phi.dot(w);
    var[i] = phi.dot(ldlt.solve(phi)) + prior_part;
  }
}

}  // namespace potmap
