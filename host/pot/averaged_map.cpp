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
  Workspace& work = ws_;
  work.m.assign(cells, 0);
  work.v.assign(cells, 0);
  work.sup.assign(cells, 0);
  work.sg.assign(cells, 0);
  std::vector<double>&m = work.m, &v = work.v, &sup = work.sup, &sg = work.sg;
  const std::int64_t zs = d == 3 ? span : 0;
  double x[3] = {0, 0, 0};
  // On the grid a Gaussian is the product of one factor an axis: 3 (2 span + 1) exponentials a
  // kernel instead of one a cell. The cut stays on the whole exponent, as one exp would take it.
  const std::size_t side = std::size_t(2 * span + 1);
  work.t2.assign(3 * side, 0);
  work.f.assign(3 * side, 0);
  std::vector<double>&t2 = work.t2, &f = work.f;
  for (std::size_t k = 0; k < inst.size(); ++k) {
    const double* p = &inst.position[k * d];
    const double g = inst.gamma[k];
    std::int64_t c0[3] = {0, 0, 0};
    for (int a = 0; a < d; ++a) {
      c0[a] = cell(p[a]) - lo[a];
      for (std::int64_t o = -span; o <= span; ++o) {
        const double t = (lo[a] + c0[a] + o + 0.5) * h - p[a];
        t2[a * side + std::size_t(o + span)] = t * t;
        f[a * side + std::size_t(o + span)] = std::exp(-g * t * t);
      }
    }
    const double wm = inst.w_mean[k], wv = inst.w_var[k];
    const double* tx = t2.data();
    const double* fx = f.data();
    for (std::int64_t dz = -zs; dz <= zs; ++dz) {
      const double z2 = d == 3 ? t2[2 * side + std::size_t(dz + span)] : 0.0;
      const double fz = d == 3 ? f[2 * side + std::size_t(dz + span)] : 1.0;
      for (std::int64_t dy = -span; dy <= span; ++dy) {
        const double yz2 = z2 + t2[side + std::size_t(dy + span)];
        const double fyz = fz * f[side + std::size_t(dy + span)];
        // The row's cells within the cut (a run: t2 falls then rises along the row), then one
        // branch-free pass over the run that the compiler vectorises; a cell of the run the cut
        // still excludes adds exact zeros, so the sums are those of the cell-by-cell test.
        std::size_t a = 0, b = side;
        while (a < b && g * (yz2 + tx[a]) > kCut) ++a;
        while (b > a && g * (yz2 + tx[b - 1]) > kCut) --b;
        if (a == b) continue;
        const std::size_t row =
            std::size_t(c0[0] - span + n[0] * (c0[1] + dy + n[1] * (c0[2] + dz)));
        double* __restrict pm = m.data() + row;
        double* __restrict pv = v.data() + row;
        double* __restrict ps = sup.data() + row;
        double* __restrict pg = sg.data() + row;
        for (std::size_t x = a; x < b; ++x) {
          const double phi = g * (yz2 + tx[x]) > kCut ? 0.0 : fyz * fx[x];
          pm[x] += wm * phi;
          pv[x] += wv * phi * phi;
          ps[x] += phi;
          pg[x] += g * phi;
        }
      }
    }
  }
  // Anchor of each cell: -1 none, -2 not looked up yet. Only the footprint and its stencil are
  // looked up; new anchors are the footprint's own cells, so a later lookup of any other cell
  // finds what an earlier one would have.
  work.slot.assign(cells, -2);
  std::vector<std::int64_t>& slot = work.slot;
  auto grid_cell = [&](std::size_t i, std::int64_t g[3]) {
    g[0] = lo[0] + std::int64_t(i % std::size_t(n[0]));
    g[1] = lo[1] + std::int64_t((i / std::size_t(n[0])) % std::size_t(n[1]));
    g[2] = d == 3 ? lo[2] + std::int64_t(i / std::size_t(n[0] * n[1])) : 0;
  };
  auto slot_of = [&](std::size_t i) {
    if (slot[i] == -2) {
      std::int64_t g[3];
      grid_cell(i, g);
      const auto it = index_.find(key(g));
      slot[i] = it != index_.end() ? std::int64_t(it->second) : -1;
    }
    return slot[i];
  };
  std::vector<std::size_t>& active = work.active;  // cells the scan counts at
  std::vector<double>& change = work.change;       // their averages' change (old average first)
  active.clear();
  change.clear();
  for (std::size_t i = 0; i < cells; ++i) {
    if (sup[i] < opt_.min_support) continue;
    if (slot_of(i) < 0) {
      std::int64_t g[3];
      grid_cell(i, g);
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
    // An anchor's width is an average of equal widths, equal to the last up to rounding: a
    // table rebuilt for every ulp cost more than the sweeps. 1e-9 relative changes a weight by
    // less than 1e-8 of itself.
    if (std::abs(gamma - table_gamma) <= 1e-9 * gamma) return;
    for (std::size_t q = 0; q < table.size(); ++q) table[q] = std::exp(-gamma * h * h * double(q));
    table_gamma = gamma;
  };
  // Each footprint row's neighbours that hold anchors and their Gram entries, gathered once:
  // the start, the sweeps and the variances then read a short list instead of the stencil.
  work.nb_start.assign(active.size() + 1, 0);
  work.part.assign(active.size(), 0);
  work.s2.assign(active.size(), 0);
  work.nb.clear();
  work.nw.clear();
  std::vector<std::uint32_t>&nb_start = work.nb_start, &nb = work.nb;
  std::vector<double>&nw = work.nw, &part = work.part, &s2 = work.s2;
  for (std::size_t t = 0; t < active.size(); ++t) {
    const std::size_t i = active[t];
    weights_of(map_.gamma[std::size_t(slot[i])]);
    double p1 = 0, p2 = 0;
    for (const auto& st : stencil) {
      const std::int64_t b = slot_of(std::size_t(std::int64_t(i) + st[0]));
      if (b < 0) continue;
      const double w = table[std::size_t(st[1])];
      p1 += w;
      p2 += w * w;
      if (st[1] == 0) continue;
      nb.push_back(std::uint32_t(b));
      nw.push_back(w);
    }
    part[t] = p1;
    s2[t] = p2;
    nb_start[t + 1] = std::uint32_t(nb.size());
  }
  // Start the sweeps from the weights moved by each average's change over its partition (the
  // Nadaraya-Watson step): Gauss-Seidel alone removes smooth errors slowly, and a scan's change
  // is mostly smooth, so five sweeps from the old weights left broad areas reading short.
  for (std::size_t t = 0; t < active.size(); ++t) {
    const std::size_t a = std::size_t(slot[active[t]]);
    const double delta = change[t] + sum_sm_[a] / sum_s_[a];
    map_.w_mean[a] += delta / part[t];
  }
  for (int sweep = 0; sweep < opt_.sweeps; ++sweep)
    for (std::size_t t = 0; t < active.size(); ++t) {
      const std::size_t a = std::size_t(slot[active[t]]);
      const double va = sum_sm_[a] / sum_s_[a];
      // Four partial sums: one chain of dependent subtractions kept the core waiting on each
      // (the sweeps were 40 % of add before).
      double r4[4] = {0, 0, 0, 0};
      const double* wmean = map_.w_mean.data();
      std::uint32_t e = nb_start[t];
      const std::uint32_t end = nb_start[t + 1];
      for (; e + 4 <= end; e += 4)
        for (int u = 0; u < 4; ++u) r4[u] += wmean[nb[e + u]] * nw[e + u];
      for (; e < end; ++e) r4[0] += wmean[nb[e]] * nw[e];
      const double r = va - ((r4[0] + r4[1]) + (r4[2] + r4[3]));
      // Projected onto the average's sign: a weight of the other sign would only cancel its
      // neighbours' tails, and past the last anchors it rings into space no scan saw.
      const double wa = r / (1.0 + opt_.ridge);
      map_.w_mean[a] = va >= 0 ? std::max(wa, 0.0) : std::min(wa, 0.0);
    }
  // Variances: the anchors' averages spread by the partition sum_b phi_b(x_a)^2.
  for (std::size_t t = 0; t < active.size(); ++t) {
    const std::size_t a = std::size_t(slot[active[t]]);
    map_.w_var[a] = sum_sv_[a] / sum_s_[a] / s2[t];
  }
}

std::size_t AveragedMap::memory_bytes() const {
  std::size_t b = sizeof(*this);
  b += 8 * (map_.position.capacity() + map_.gamma.capacity() + map_.w_mean.capacity() +
            map_.w_var.capacity());
  b += 8 * (sum_sm_.capacity() + sum_s_.capacity() + sum_sv_.capacity() + sum_sg_.capacity());
  for (const auto* x : {&ws_.m, &ws_.v, &ws_.sup, &ws_.sg, &ws_.t2, &ws_.f, &ws_.nw, &ws_.part,
                        &ws_.s2, &ws_.change})
    b += 8 * x->capacity();
  b += 8 * (ws_.slot.capacity() + ws_.active.capacity()) +
       4 * (ws_.nb_start.capacity() + ws_.nb.capacity());
  b += index_.bucket_count() * sizeof(void*) +
       index_.size() * (sizeof(std::uint64_t) + 4 + 2 * sizeof(void*));
  return b;
}

}  // namespace potmap
