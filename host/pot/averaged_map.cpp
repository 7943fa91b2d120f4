// The averaged overall map (include/potmap/pot/averaged_map.hpp).
#include "potmap/pot/averaged_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "cell_key.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

// phi below exp(-kCut) is treated as 0: the sums lose less than 1e-7 of a kernel.
constexpr double kCut = 16.0;
// The weights' solve couples anchors while phi is above exp(-kSolveCut) (0.0001).
constexpr double kSolveCut = 9.0;

}  // namespace

AveragedMap::AveragedMap(int dim, const AveragedMapOptions& o) : dim_(dim), opt_(o) {
  if (dim != 2 && dim != 3)
    throw ArgumentError("AveragedMap: dimension " + std::to_string(dim) + " (must be 2 or 3)");
  if (!(o.spacing > 0) || !std::isfinite(o.spacing))
    throw ArgumentError("AveragedMap: spacing must be a positive number of metres");
  if (!(o.min_support > 0) || !std::isfinite(o.min_support))
    throw ArgumentError("AveragedMap: min_support must be positive");
  if (!(o.ridge >= 0) || !std::isfinite(o.ridge))
    throw ArgumentError("AveragedMap: ridge must be finite and >= 0");
  if (o.sweeps < 0) throw ArgumentError("AveragedMap: sweeps must be >= 0");
  map_.dim = dim;
}

std::int64_t AveragedMap::cell(double x) const {
  return static_cast<std::int64_t>(std::floor(x / opt_.spacing));
}

std::uint64_t AveragedMap::key(const std::int64_t c[3]) const {
  return detail::pack_cell(c);
}

void AveragedMap::add(const KernelMap& inst) {
  if (inst.dim != dim_)
    throw ArgumentError("AveragedMap::add: a " + std::to_string(inst.dim) + "D map added to a " +
                        std::to_string(dim_) + "D map");
  inst.validate("AveragedMap::add");
  if (inst.empty()) return;
  const int d = dim_;
  const double h = opt_.spacing;
  const double gmin = *std::min_element(inst.gamma.begin(), inst.gamma.end());
  const double reach = std::sqrt(kCut / gmin);
  const std::int64_t span = static_cast<std::int64_t>(std::ceil(reach / h));

  // A dense box of cells over the scan's footprint (plus the solve's stencil around it): the
  // sums and sweeps below index it directly instead of hashing every neighbour.
  std::int64_t lo[3] = {0, 0, 0}, n[3] = {1, 1, 1};
  for (int a = 0; a < d; ++a) {
    double mn = HUGE_VAL, mx = -HUGE_VAL;
    for (std::size_t k = 0; k < inst.size(); ++k) {
      mn = std::min(mn, inst.position[k * d + a]);
      mx = std::max(mx, inst.position[k * d + a]);
    }
    lo[a] = cell(mn) - 2 * span;
    n[a] = cell(mx) + 2 * span - lo[a] + 1;
  }
  const std::size_t cells = std::size_t(n[0] * n[1] * n[2]);

  // The scan's logit, variance and support at every cell centre within reach of its kernels,
  // scattered kernel by kernel (each touches only its own neighbourhood of cells).
  std::vector<double> m(cells, 0), v(cells, 0), sup(cells, 0), sg(cells, 0);
  const std::int64_t zs = d == 3 ? span : 0;
  double x[3] = {0, 0, 0};
  for (std::size_t k = 0; k < inst.size(); ++k) {
    const double* p = &inst.position[k * d];
    std::int64_t c0[3] = {0, 0, 0};
    for (int a = 0; a < d; ++a) c0[a] = cell(p[a]) - lo[a];
    for (std::int64_t dz = -zs; dz <= zs; ++dz)
      for (std::int64_t dy = -span; dy <= span; ++dy)
        for (std::int64_t dx = -span; dx <= span; ++dx) {
          const std::int64_t c[3] = {c0[0] + dx, c0[1] + dy, c0[2] + dz};
          const std::size_t i = std::size_t(c[0] + n[0] * (c[1] + n[1] * c[2]));
          double d2 = 0;
          for (int a = 0; a < d; ++a) {
            const double t = (lo[a] + c[a] + 0.5) * h - p[a];
            d2 += t * t;
          }
          const double e = inst.gamma[k] * d2;
          if (e > kCut) continue;
          const double phi = std::exp(-e);
          m[i] += inst.w_mean[k] * phi;
          v[i] += inst.w_var[k] * phi * phi;
          sup[i] += phi;
          sg[i] += inst.gamma[k] * phi;
        }
  }
  std::vector<std::int64_t> slot(cells, -1);  // anchor of each cell, -1: none
  std::vector<std::size_t> active;            // cells the scan counts at
  std::vector<double> change;                 // their averages' change (old average first)
  for (std::size_t i = 0; i < cells; ++i) {
    const std::int64_t c[3] = {std::int64_t(i % n[0]), std::int64_t((i / n[0]) % n[1]),
                               std::int64_t(i / (n[0] * n[1]))};
    const std::int64_t g[3] = {lo[0] + c[0], lo[1] + c[1], d == 3 ? lo[2] + c[2] : 0};
    const auto it = index_.find(key(g));
    if (it != index_.end()) slot[i] = it->second;
    if (sup[i] < opt_.min_support) continue;
    if (slot[i] < 0) {
      for (int a = 0; a < d; ++a) x[a] = (g[a] + 0.5) * h;
      slot[i] = std::int64_t(map_.size());
      index_.emplace(key(g), std::uint32_t(map_.size()));
      map_.push_back(x, sg[i] / sup[i], 0.0, 0.0);
      sum_sm_.push_back(0);
      sum_s_.push_back(0);
      sum_sv_.push_back(0);
      sum_sg_.push_back(0);
    }
    const std::size_t a = std::size_t(slot[i]);
    change.push_back(-(sum_s_[a] > 0 ? sum_sm_[a] / sum_s_[a] : 0.0));
    sum_sm_[a] += sup[i] * m[i];
    sum_s_[a] += sup[i];
    sum_sv_[a] += sup[i] * v[i];
    sum_sg_[a] += sg[i];
    map_.gamma[a] = sum_sg_[a] / sum_s_[a];
    active.push_back(i);
  }

  // Weights: Gauss-Seidel on (Phi + ridge I) w = v over the footprint, neighbours outside it
  // held. On the grid Phi depends on the offset and the width only; the row's own width stands
  // for its neighbours' (equal wherever the atoms share one width, as BHM atoms do).
  const std::int64_t ws =
      std::min<std::int64_t>(span, std::int64_t(std::floor(std::sqrt(kSolveCut / (gmin * h * h)))));
  std::vector<std::array<std::int64_t, 2>> stencil;  // (cell offset, squared grid distance)
  for (std::int64_t dz = -(d == 3 ? ws : 0); dz <= (d == 3 ? ws : 0); ++dz)
    for (std::int64_t dy = -ws; dy <= ws; ++dy)
      for (std::int64_t dx = -ws; dx <= ws; ++dx) {
        const std::int64_t q2 = dx * dx + dy * dy + dz * dz;
        if (q2 <= ws * ws) stencil.push_back({dx + n[0] * (dy + n[1] * dz), q2});
      }
  std::vector<double> table(std::size_t(ws * ws * (d == 3 ? 3 : 2)) + 1);
  double table_gamma = -1;
  auto weights_of = [&](double gamma) {
    if (gamma == table_gamma) return;
    for (std::size_t q = 0; q < table.size(); ++q) table[q] = std::exp(-gamma * h * h * double(q));
    table_gamma = gamma;
  };
  // Start the sweeps from the weights moved by each average's change over its partition (the
  // Nadaraya-Watson step): Gauss-Seidel alone removes smooth errors slowly, and a scan's change
  // is mostly smooth, so five sweeps from the old weights left broad areas reading short.
  for (std::size_t t = 0; t < active.size(); ++t) {
    const std::size_t i = active[t], a = std::size_t(slot[i]);
    weights_of(map_.gamma[a]);
    double part = 0;
    for (const auto& st : stencil)
      if (slot[std::size_t(std::int64_t(i) + st[0])] >= 0) part += table[std::size_t(st[1])];
    const double delta = change[t] + sum_sm_[a] / sum_s_[a];
    map_.w_mean[a] += delta / part;
  }
  for (int sweep = 0; sweep < opt_.sweeps; ++sweep)
    for (std::size_t i : active) {
      const std::size_t a = std::size_t(slot[i]);
      weights_of(map_.gamma[a]);
      double r = sum_sm_[a] / sum_s_[a];
      for (const auto& st : stencil) {
        if (st[1] == 0) continue;
        const std::int64_t b = slot[std::size_t(std::int64_t(i) + st[0])];
        if (b >= 0) r -= map_.w_mean[std::size_t(b)] * table[std::size_t(st[1])];
      }
      // Projected onto the average's sign: a weight of the other sign would only cancel its
      // neighbours' tails, and past the last anchors it rings into space no scan saw.
      const double va = sum_sm_[a] / sum_s_[a];
      const double wa = r / (1.0 + opt_.ridge);
      map_.w_mean[a] = va >= 0 ? std::max(wa, 0.0) : std::min(wa, 0.0);
    }
  // Variances: the anchors' averages spread by the partition sum_b phi_b(x_a)^2.
  for (std::size_t i : active) {
    const std::size_t a = std::size_t(slot[i]);
    weights_of(map_.gamma[a]);
    double s2 = 0;
    for (const auto& st : stencil)
      if (slot[std::size_t(std::int64_t(i) + st[0])] >= 0)
        s2 += table[std::size_t(st[1])] * table[std::size_t(st[1])];
    map_.w_var[a] = sum_sv_[a] / sum_s_[a] / s2;
  }
}

std::size_t AveragedMap::memory_bytes() const {
  std::size_t b = sizeof(*this);
  b += 8 * (map_.position.capacity() + map_.gamma.capacity() + map_.w_mean.capacity() +
            map_.w_var.capacity());
  b += 8 * (sum_sm_.capacity() + sum_s_.capacity() + sum_sv_.capacity() + sum_sg_.capacity());
  b += index_.bucket_count() * sizeof(void*) +
       index_.size() * (sizeof(std::uint64_t) + 4 + 2 * sizeof(void*));
  return b;
}

}  // namespace potmap
