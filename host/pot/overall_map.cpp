// The overall map: merging rule, hash grid and cap (documented in
// include/potmap/pot/overall_map.hpp).
#include "potmap/pot/overall_map.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "potmap/error.hpp"

namespace potmap {

namespace {

// A query wider than this many cells either side rebuilds the grid with a larger cell, so a few
// very wide kernels cannot make every query walk thousands of empty cells.
constexpr std::int64_t kMaxSpan = 4;

std::uint64_t mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

}  // namespace

OverallMap::OverallMap(int dim, const OverallMapOptions& options) : dim_(dim), opt_(options) {
  if (dim != 2 && dim != 3)
    throw ArgumentError("OverallMap: dimension " + std::to_string(dim) + " (must be 2 or 3)");
  if (!(opt_.merge_radius >= 0) || !std::isfinite(opt_.merge_radius))
    throw ArgumentError("OverallMap: merge_radius must be finite and >= 0");
  if (!(opt_.gamma_ratio >= 1) || !std::isfinite(opt_.gamma_ratio))
    throw ArgumentError("OverallMap: gamma_ratio must be finite and >= 1");
  if (!(opt_.retire_to > 0 && opt_.retire_to <= 1))
    throw ArgumentError("OverallMap: retire_to must be in (0, 1]");
  map_.dim = dim;
}

void OverallMap::cell_of(const double* p, std::int64_t c[3]) const {
  for (int d = 0; d < 3; ++d)
    c[d] = d < dim_ ? static_cast<std::int64_t>(std::floor(p[d] / cell_)) : 0;
}

OverallMap::CellKey OverallMap::key_of(const std::int64_t c[3]) const {
  // Distinct cells may share a key; that only adds candidates, whose distances are checked.
  return mix(mix(mix(static_cast<std::uint64_t>(c[0])) ^ static_cast<std::uint64_t>(c[1])) ^
             static_cast<std::uint64_t>(c[2]));
}

OverallMap::CellKey OverallMap::key_of(const double* p) const {
  std::int64_t c[3];
  cell_of(p, c);
  return key_of(c);
}

void OverallMap::index_insert(std::uint32_t k) {
  grid_[key_of(&map_.position[std::size_t(k) * dim_])].push_back(k);
}

void OverallMap::index_erase(std::uint32_t k) {
  auto it = grid_.find(key_of(&map_.position[std::size_t(k) * dim_]));
  if (it == grid_.end()) return;
  auto& v = it->second;
  v.erase(std::remove(v.begin(), v.end(), k), v.end());
  if (v.empty()) grid_.erase(it);
}

long OverallMap::nearest_mergeable(const double* p, double gamma, long exclude) const {
  // Any partner e has max(gamma_n, gamma_e) >= gamma_n, so d^2 < merge_radius / gamma_n.
  const double reach = std::sqrt(opt_.merge_radius / gamma);
  std::int64_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) {
    lo[d] = static_cast<std::int64_t>(std::floor((p[d] - reach) / cell_));
    hi[d] = static_cast<std::int64_t>(std::floor((p[d] + reach) / cell_));
  }
  long best = -1;
  double best_d2 = HUGE_VAL;
  std::int64_t c[3];
  for (c[2] = lo[2]; c[2] <= hi[2]; ++c[2])
    for (c[1] = lo[1]; c[1] <= hi[1]; ++c[1])
      for (c[0] = lo[0]; c[0] <= hi[0]; ++c[0]) {
        const auto it = grid_.find(key_of(c));
        if (it == grid_.end()) continue;
        for (std::uint32_t e : it->second) {
          if (born_[e] == adds_ || long(e) == exclude) continue;
          const double ge = map_.gamma[e];
          const double gmax = std::max(ge, gamma), gmin = std::min(ge, gamma);
          if (gmax > opt_.gamma_ratio * gmin) continue;
          double d2 = 0;
          for (int d = 0; d < dim_; ++d) {
            const double t = map_.position[std::size_t(e) * dim_ + d] - p[d];
            d2 += t * t;
          }
          if (d2 * gmax < opt_.merge_radius &&
              (d2 < best_d2 || (d2 == best_d2 && long(e) < best))) {
            best = e;
            best_d2 = d2;
          }
        }
      }
  return best;
}

void OverallMap::merge_into(std::size_t e, const double* p, double g, double wm, double wv,
                            std::uint32_t c_n) {
  const double c = count_[e];
  const double om = c / (c + c_n), on = c_n / (c + c_n);
  const double we = map_.w_mean[e], ve = map_.w_var[e];
  double w, v;
  if (ve == 0 && wv == 0) {
    w = om * we + on * wm;
    v = 0;
  } else if (ve == 0) {
    w = we;
    v = 0;
  } else if (wv == 0) {
    w = wm;
    v = 0;
  } else {
    const double prec = om / ve + on / wv;
    v = 1.0 / prec;
    w = (om * we / ve + on * wm / wv) * v;
  }
  map_.w_mean[e] = w;
  map_.w_var[e] = v;
  map_.gamma[e] = om * map_.gamma[e] + on * g;
  double* h = &map_.position[e * dim_];
  const CellKey before = key_of(h);
  double moved[3];
  for (int d = 0; d < dim_; ++d) moved[d] = om * h[d] + on * p[d];
  if (key_of(moved) != before) {
    index_erase(static_cast<std::uint32_t>(e));
    std::copy(moved, moved + dim_, h);
    index_insert(static_cast<std::uint32_t>(e));
  } else {
    std::copy(moved, moved + dim_, h);
  }
  count_[e] = static_cast<std::uint32_t>(
      std::min<std::uint64_t>(UINT32_MAX, std::uint64_t(count_[e]) + c_n));
  last_seen_[e] = adds_;
}

void OverallMap::remove(std::size_t f) {
  index_erase(static_cast<std::uint32_t>(f));
  const std::size_t last = map_.size() - 1;
  if (f != last) {
    index_erase(static_cast<std::uint32_t>(last));
    for (int d = 0; d < dim_; ++d) map_.position[f * dim_ + d] = map_.position[last * dim_ + d];
    map_.gamma[f] = map_.gamma[last];
    map_.w_mean[f] = map_.w_mean[last];
    map_.w_var[f] = map_.w_var[last];
    count_[f] = count_[last];
    last_seen_[f] = last_seen_[last];
    born_[f] = born_[last];
    index_insert(static_cast<std::uint32_t>(f));
  }
  map_.position.resize(last * dim_);
  map_.gamma.pop_back();
  map_.w_mean.pop_back();
  map_.w_var.pop_back();
  count_.pop_back();
  last_seen_.pop_back();
  born_.pop_back();
}

std::size_t OverallMap::consolidate(std::size_t e) {
  // A merge moves e; if it now lies on another old kernel, the two are one kernel seen twice.
  // Fusing them keeps the merge radius a real spacing, so jittered revisits cannot slowly pile
  // kernels around one place.
  std::size_t fused = 0;
  for (;;) {
    const long f = nearest_mergeable(&map_.position[e * dim_], map_.gamma[e], long(e));
    if (f < 0) return fused;
    const std::size_t ff = static_cast<std::size_t>(f);
    const double p[3] = {map_.position[ff * dim_], map_.position[ff * dim_ + 1],
                         dim_ == 3 ? map_.position[ff * dim_ + 2] : 0.0};
    merge_into(e, p, map_.gamma[ff], map_.w_mean[ff], map_.w_var[ff], count_[ff]);
    born_[e] = std::min(born_[e], born_[ff]);
    const std::size_t last = map_.size() - 1;
    remove(ff);
    if (e == last) e = ff;  // e was moved into f's slot
    ++fused;
  }
}

OverallMapAddStats OverallMap::add(const KernelMap& inst) {
  if (inst.dim != dim_)
    throw ArgumentError("OverallMap::add: a " + std::to_string(inst.dim) + "D map added to a " +
                        std::to_string(dim_) + "D overall map");
  inst.validate("OverallMap::add");
  ++adds_;
  OverallMapAddStats stats;
  if (inst.empty()) return stats;
  const bool merging = opt_.merge_radius > 0;
  // The widest merge distance of this map decides the cell edge (first time), or forces a
  // rebuild when it is far wider than the cells.
  const double gmin = *std::min_element(inst.gamma.begin(), inst.gamma.end());
  const double reach = merging ? std::sqrt(opt_.merge_radius / gmin) : 1.0;
  if (cell_ == 0 || reach > kMaxSpan * cell_) {
    cell_ = std::max(reach, cell_);
    grid_.clear();
    for (std::size_t k = 0; k < map_.size(); ++k) index_insert(static_cast<std::uint32_t>(k));
  }
  for (std::size_t i = 0; i < inst.size(); ++i) {
    const double* p = &inst.position[i * dim_];
    const long e = merging && !map_.empty() ? nearest_mergeable(p, inst.gamma[i], -1) : -1;
    if (e >= 0) {
      merge_into(static_cast<std::size_t>(e), p, inst.gamma[i], inst.w_mean[i], inst.w_var[i], 1);
      stats.fused += consolidate(static_cast<std::size_t>(e));
      ++stats.merged;
    } else {
      map_.push_back(p, inst.gamma[i], inst.w_mean[i], inst.w_var[i]);
      count_.push_back(1);
      last_seen_.push_back(adds_);
      born_.push_back(adds_);
      index_insert(static_cast<std::uint32_t>(map_.size() - 1));
      ++stats.added;
    }
  }
  if (opt_.max_kernels > 0 && map_.size() > opt_.max_kernels) stats.retired = retire();
  return stats;
}

std::size_t OverallMap::retire() {
  const std::size_t keep = std::max<std::size_t>(
      1, static_cast<std::size_t>(std::floor(opt_.retire_to * double(opt_.max_kernels))));
  const std::size_t n = map_.size(), drop = n - keep;
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  auto weaker = [&](std::uint32_t a, std::uint32_t b) {
    if (count_[a] != count_[b]) return count_[a] < count_[b];
    if (last_seen_[a] != last_seen_[b]) return last_seen_[a] < last_seen_[b];
    return a < b;
  };
  std::nth_element(order.begin(), order.begin() + drop, order.end(), weaker);
  std::vector<char> gone(n, 0);
  for (std::size_t i = 0; i < drop; ++i) gone[order[i]] = 1;
  // Compact in place, keeping the survivors' order.
  std::size_t out = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (gone[k]) continue;
    for (int d = 0; d < dim_; ++d) map_.position[out * dim_ + d] = map_.position[k * dim_ + d];
    map_.gamma[out] = map_.gamma[k];
    map_.w_mean[out] = map_.w_mean[k];
    map_.w_var[out] = map_.w_var[k];
    count_[out] = count_[k];
    last_seen_[out] = last_seen_[k];
    born_[out] = born_[k];
    ++out;
  }
  map_.position.resize(out * dim_);
  map_.gamma.resize(out);
  map_.w_mean.resize(out);
  map_.w_var.resize(out);
  count_.resize(out);
  last_seen_.resize(out);
  born_.resize(out);
  grid_.clear();
  for (std::size_t k = 0; k < out; ++k) index_insert(static_cast<std::uint32_t>(k));
  return drop;
}

std::size_t OverallMap::memory_bytes() const {
  std::size_t b = sizeof(*this);
  b += 8 * (map_.position.capacity() + map_.gamma.capacity() + map_.w_mean.capacity() +
            map_.w_var.capacity());
  b += 4 * count_.capacity() + 8 * (last_seen_.capacity() + born_.capacity());
  // Hash table: a bucket pointer each, and per cell a node (key, vector header, next pointer)
  // plus the vector's storage.
  b += grid_.bucket_count() * sizeof(void*);
  for (const auto& kv : grid_) b += sizeof(kv) + sizeof(void*) + 4 * kv.second.capacity();
  return b;
}

}  // namespace potmap
