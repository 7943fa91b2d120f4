// The averaged overall map (include/potmap/pot/averaged_map.hpp).
#include "potmap/pot/averaged_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string>

#include "cell_key.hpp"
#include "potmap/error.hpp"
#include "runtime/wider_vectors.hpp"

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

namespace {

// Blocks of 32 x 32 cells in 2D (8 m at 0.25 m, 4 KB of slots), 16^3 in 3D.
constexpr std::int64_t kBlock2 = 32, kBlock3 = 16;

std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}

}  // namespace

std::int64_t AveragedMap::block_side() const {
  return dim_ == 3 ? kBlock3 : kBlock2;
}

void AveragedMap::slots_along_x(const std::int64_t c[3], std::size_t count,
                                std::int64_t* out) const {
  const std::int64_t b = block_side();
  std::int64_t blk[3] = {0, floor_div(c[1], b), floor_div(c[2], b)};
  const std::int64_t row = (c[1] - blk[1] * b) * b + (c[2] - blk[2] * b) * b * b;
  const std::size_t volume = std::size_t(dim_ == 3 ? b * b * b : b * b);
  std::int64_t x = c[0];
  const std::int64_t end = c[0] + std::int64_t(count);
  while (x < end) {
    blk[0] = floor_div(x, b);
    const std::int64_t x0 = x - blk[0] * b, run = std::min(b - x0, end - x);
    const auto it = blocks_.find(detail::pack_cell(blk));
    if (it == blocks_.end()) {
      std::fill_n(out, run, std::int64_t(-1));
    } else {
      const std::int32_t* s = &block_slots_[it->second * volume + std::size_t(row + x0)];
      for (std::int64_t k = 0; k < run; ++k) out[k] = s[k];
    }
    out += run;
    x += run;
  }
}

bool AveragedMap::set_slot(const std::int64_t c[3], std::uint32_t slot) {
  const std::int64_t b = block_side();
  const std::int64_t blk[3] = {floor_div(c[0], b), floor_div(c[1], b), floor_div(c[2], b)};
  const std::size_t volume = std::size_t(dim_ == 3 ? b * b * b : b * b);
  const auto ins = blocks_.emplace(detail::pack_cell(blk), std::uint32_t(blocks_.size()));
  if (ins.second) block_slots_.resize(block_slots_.size() + volume, -1);
  std::int32_t& s = block_slots_[ins.first->second * volume +
                                 std::size_t((c[0] - blk[0] * b) +
                                             b * ((c[1] - blk[1] * b) + b * (c[2] - blk[2] * b)))];
  if (s >= 0) return false;
  s = std::int32_t(slot);
  return true;
}

namespace {

// Two doubles at a time (GCC's and Clang's vector extension: SSE2 on x86-64, NEON on arm64,
// without naming an instruction set).
typedef double Pair __attribute__((vector_size(16)));

inline Pair load(const double* p) {
  Pair v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// The weights' Gram matrix on the grid as a stencil over the dense box: on the grid Phi
// depends on the offset and the width only, so one table per width serves every anchor, and
// the stencil is walked over dense copies of the box (contiguous loads, no per-neighbour lists).
//  - Phi is even, so each run of the stencil along x is paired with its mirror image through
//    the centre and the pair summed before one multiply; runs are padded with a zero entry to
//    whole pairs of doubles, so a dot has half the multiplies and no scalar tails.
//  - The centre's own row is summed apart, one double at a time and its nearest cells last:
//    the sweep has just written the cell before, and its weight is the one term that waits
//    for the last update, so it enters after the rest of the sum (a pair load over the fresh
//    store would also wait for the store to reach the cache).
class Stencil {
 public:
  // ws: the stencil's radius in cells; n: the box's cells along each axis.
  Stencil(std::int64_t ws, const std::int64_t n[3], int d, double h) : ws_(ws), h_(h) {
    for (std::int64_t dz = 0; dz <= (d == 3 ? ws : 0); ++dz)
      for (std::int64_t dy = dz == 0 ? 1 : -ws; dy <= ws; ++dy) {
        const std::int64_t q = dy * dy + dz * dz;
        if (q > ws * ws) continue;
        const auto hx = std::int64_t(std::floor(std::sqrt(double(ws * ws - q))));
        runs_.push_back({-hx + n[0] * (dy + n[1] * dz), -hx - n[0] * (dy + n[1] * dz), q2_.size(),
                         std::size_t(2 * hx + 2)});
        for (std::int64_t dx = -hx; dx <= hx; ++dx) q2_.push_back(dx * dx + q);
        q2_.push_back(-1);
      }
    gram.resize(q2_.size());
    gram2.resize(q2_.size());
    row.assign(std::size_t(std::max<std::int64_t>(ws, 1) + 1), 0.0);
    row2 = row;
  }

  // Fills the tables for kernels of this width.
  void set_gamma(double gamma) {
    // An anchor's width is an average of equal widths, equal to the last up to rounding: a
    // table rebuilt for every ulp cost more than the sweeps. 1e-9 relative changes a weight by
    // less than 1e-8 of itself.
    if (std::abs(gamma - gamma_) <= 1e-9 * gamma) return;
    for (std::size_t e = 0; e < q2_.size(); ++e) {
      gram[e] = q2_[e] < 0 ? 0.0 : std::exp(-gamma * h_ * h_ * double(q2_[e]));
      gram2[e] = gram[e] * gram[e];
    }
    for (std::int64_t k = 1; k <= ws_; ++k) {
      row[std::size_t(k)] = std::exp(-gamma * h_ * h_ * double(k * k));
      row2[std::size_t(k)] = row[std::size_t(k)] * row[std::size_t(k)];
    }
    gamma_ = gamma;
  }

  // The sum over the runs of box[i + offset] * wt: two pairs of partial sums, so that the adds
  // do not wait on each other.
  double runs_dot(const double* box, std::size_t i, const std::vector<double>& wt) const {
    Pair s0 = {0, 0}, s1 = {0, 0};
    for (const Run& run : runs_) {
      const double* b = box + std::int64_t(i) + run.offset;
      const double* m = box + std::int64_t(i) + run.mirror;
      const double* w = wt.data() + run.first;
      std::size_t e = 0;
      for (; e + 4 <= run.length; e += 4) {
        s0 += (load(b + e) + load(m + e)) * load(w + e);
        s1 += (load(b + e + 2) + load(m + e + 2)) * load(w + e + 2);
      }
      if (e < run.length) s0 += (load(b + e) + load(m + e)) * load(w + e);
    }
    const Pair s = s0 + s1;
    return s[0] + s[1];
  }

  // The centre row's sum from ws cells out in to 2 (the caller adds the nearest two, last).
  double row_dot(const double* box, std::size_t i, const std::vector<double>& wt) const {
    double r = 0;
    for (std::int64_t k = ws_; k >= 2; --k) r += wt[std::size_t(k)] * (box[i - k] + box[i + k]);
    return r;
  }

  // The sums over the runs of has[i + offset] * gram and * gram2, in one pass.
  void runs_partition(const double* has, std::size_t i, double& p_sum, double& p2_sum) const {
    Pair p = {0, 0}, p2 = {0, 0};
    for (const Run& run : runs_) {
      const double* b = has + std::int64_t(i) + run.offset;
      const double* m = has + std::int64_t(i) + run.mirror;
      for (std::size_t e = 0; e < run.length; e += 2) {
        const Pair both = load(b + e) + load(m + e);
        p += both * load(gram.data() + run.first + e);
        p2 += both * load(gram2.data() + run.first + e);
      }
    }
    p_sum = p[0] + p[1];
    p2_sum = p2[0] + p2[1];
  }

  // Gram entries of the runs and their squares; row[k], row2[k]: the centre row's at k cells
  // (k from 1 to ws; row[1] is 0 when ws is).
  std::vector<double> gram, gram2, row, row2;

 private:
  struct Run {
    std::int64_t offset;  // box offset of the run's first cell from the centre cell
    std::int64_t mirror;  // its mirror image's first cell
    std::size_t first;    // its first entry in the weights
    std::size_t length;   // 2 hx + 1 cells and one entry of padding
  };
  std::int64_t ws_;
  double h_;
  double gamma_ = -1;
  std::vector<Run> runs_;         // the rows off the centre's, one of each mirrored pair
  std::vector<std::int64_t> q2_;  // squared grid distance of each entry, -1 for padding
};

}  // namespace

// A dense box of cells over the scan's footprint (plus the solve's stencil around it): the
// sums and sweeps index it directly instead of hashing every neighbour.
struct AveragedMap::Box {
  double gmin;        // the scan's narrowest kernel's width
  std::int64_t span;  // cells a kernel reaches along an axis
  std::int64_t lo[3] = {0, 0, 0}, n[3] = {1, 1, 1};
  std::size_t cells;
};

AveragedMap::Box AveragedMap::footprint(const KernelMap& inst) const {
  const int d = dim_;
  Box box;
  box.gmin = *std::min_element(inst.gamma.begin(), inst.gamma.end());
  const double reach = std::sqrt(kCut / box.gmin);
  box.span = static_cast<std::int64_t>(std::ceil(reach / opt_.spacing));
  for (int a = 0; a < d; ++a) {
    double mn = HUGE_VAL, mx = -HUGE_VAL;
    for (std::size_t k = 0; k < inst.size(); ++k) {
      mn = std::min(mn, inst.position[k * d + a]);
      mx = std::max(mx, inst.position[k * d + a]);
    }
    box.lo[a] = cell(mn) - 2 * box.span;
    box.n[a] = cell(mx) + 2 * box.span - box.lo[a] + 1;
  }
  box.cells = std::size_t(box.n[0] * box.n[1] * box.n[2]);
  return box;
}

POTMAP_WIDER_VECTORS void AveragedMap::scatter(const KernelMap& inst, const Box& box) {
  const int d = dim_;
  const double h = opt_.spacing;
  const std::int64_t span = box.span;
  const std::int64_t *lo = box.lo, *n = box.n;
  Workspace& work = ws_;
  work.m.assign(box.cells, 0);
  work.v.assign(box.cells, 0);
  work.sup.assign(box.cells, 0);
  work.sg.assign(box.cells, 0);
  std::vector<double>&m = work.m, &v = work.v, &sup = work.sup, &sg = work.sg;
  const std::int64_t zs = d == 3 ? span : 0;
  // On the grid a Gaussian is the product of one factor an axis, and along an axis each factor
  // is the last times a ratio that itself shrinks by exp(-2 g h^2) a cell: 3 d + 1 exponentials
  // a kernel instead of 2 span + 1 an axis (the product drifts by a few ulp over a span). The
  // walk starts at the kernel's own cell, so the factors only fall and underflow only where
  // they are negligible. The cut stays on the whole exponent, as one exp would take it.
  const std::size_t side = std::size_t(2 * span + 1);
  work.t2.assign(3 * side, 0);
  work.f.assign(3 * side, 0);
  std::vector<double>&t2 = work.t2, &f = work.f;
  for (std::size_t k = 0; k < inst.size(); ++k) {
    const double* p = &inst.position[k * d];
    const double g = inst.gamma[k];
    std::int64_t c0[3] = {0, 0, 0};
    const double shrink = std::exp(-2 * g * h * h);
    for (int a = 0; a < d; ++a) {
      c0[a] = cell(p[a]) - lo[a];
      for (std::int64_t o = -span; o <= span; ++o) {
        const double t = (lo[a] + c0[a] + o + 0.5) * h - p[a];
        t2[a * side + std::size_t(o + span)] = t * t;
      }
      const double tc = (lo[a] + c0[a] + 0.5) * h - p[a];  // from the kernel to its cell's centre
      double* fc = &f[a * side + std::size_t(span)];
      fc[0] = std::exp(-g * tc * tc);
      double up = std::exp(-g * (h * h + 2 * tc * h)), down = std::exp(-g * (h * h - 2 * tc * h));
      for (std::int64_t o = 1; o <= span; ++o) {
        fc[o] = fc[o - 1] * up;
        fc[-o] = fc[1 - o] * down;
        up *= shrink;
        down *= shrink;
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
        // The row's cells within the cut: a run, since t2 falls then rises along the row, so
        // every cell between its ends is within the cut too and the pass over it has no test
        // (which kept the compiler from vectorising it).
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
          const double phi = fyz * fx[x];
          pm[x] += wm * phi;
          pv[x] += wv * phi * phi;
          ps[x] += phi;
          pg[x] += g * phi;
        }
      }
    }
  }
}

POTMAP_WIDER_VECTORS void AveragedMap::place_anchors(const Box& box) {
  const int d = dim_;
  const double h = opt_.spacing;
  const std::int64_t *lo = box.lo, *n = box.n;
  const std::size_t cells = box.cells;
  Workspace& work = ws_;
  const std::vector<double>&m = work.m, &v = work.v, &sup = work.sup, &sg = work.sg;
  double x[3] = {0, 0, 0};
  // Every cell's anchor over the box (-1: none), read a block row at a time.
  work.slot.resize(cells);
  std::vector<std::int64_t>& slot = work.slot;
  for (std::int64_t z = 0; z < n[2]; ++z)
    for (std::int64_t y = 0; y < n[1]; ++y) {
      const std::int64_t c[3] = {lo[0], lo[1] + y, lo[2] + z};
      slots_along_x(c, std::size_t(n[0]), &slot[std::size_t(n[0] * (y + n[1] * z))]);
    }
  auto grid_cell = [&](std::size_t i, std::int64_t g[3]) {
    g[0] = lo[0] + std::int64_t(i % std::size_t(n[0]));
    g[1] = lo[1] + std::int64_t((i / std::size_t(n[0])) % std::size_t(n[1]));
    g[2] = d == 3 ? lo[2] + std::int64_t(i / std::size_t(n[0] * n[1])) : 0;
  };
  std::vector<std::size_t>& active = work.active;  // cells the scan counts at
  std::vector<double>& change = work.change;       // their averages' change (old average first)
  active.clear();
  change.clear();
  for (std::size_t i = 0; i < cells; ++i) {
    if (sup[i] < opt_.min_support) continue;
    if (slot[i] < 0) {
      std::int64_t g[3];
      grid_cell(i, g);
      for (int a = 0; a < d; ++a) x[a] = (g[a] + 0.5) * h;
      slot[i] = std::int64_t(map_.size());
      set_slot(g, std::uint32_t(map_.size()));
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
}

// Weights: Gauss-Seidel on (Phi + ridge I) w = v over the footprint, neighbours outside it
// held. The row's own width stands for its neighbours' in Phi (equal wherever the atoms share
// one width, as BHM atoms do).
POTMAP_WIDER_VECTORS void AveragedMap::solve_weights(const Box& box) {
  const double h = opt_.spacing;
  const std::size_t cells = box.cells;
  Workspace& work = ws_;
  const std::vector<std::int64_t>& slot = work.slot;
  const std::vector<std::size_t>& active = work.active;
  std::vector<double>& change = work.change;
  const std::int64_t ws = std::min<std::int64_t>(
      box.span, std::int64_t(std::floor(std::sqrt(kSolveCut / (box.gmin * h * h)))));
  Stencil stencil(ws, box.n, dim_, h);
  const std::vector<double>&row = stencil.row, &row2 = stencil.row2;
  // The box arrays end in two zeros: a run's padding may read one cell past the last.
  work.has.resize(cells + 2);
  work.w.resize(cells + 2);
  std::vector<double>&has = work.has, &wbox = work.w;
  for (std::size_t i = 0; i < cells; ++i) has[i] = slot[i] >= 0 ? 1.0 : 0.0;
  has[cells] = has[cells + 1] = wbox[cells] = wbox[cells + 1] = 0.0;
  // Each anchor's partition (sum of the Gram row over cells with anchors) and its squares, in
  // one pass over the runs.
  work.part.resize(active.size());
  work.s2.resize(active.size());
  std::vector<double>&part = work.part, &s2 = work.s2;
  for (std::size_t t = 0; t < active.size(); ++t) {
    const std::size_t i = active[t];
    stencil.set_gamma(map_.gamma[std::size_t(slot[i])]);
    double p, p2;
    stencil.runs_partition(has.data(), i, p, p2);
    const double near = has[i - 1] + has[i + 1];
    part[t] = 1.0 + p + stencil.row_dot(has.data(), i, row) + row[1] * near;
    s2[t] = 1.0 + p2 + stencil.row_dot(has.data(), i, row2) + row2[1] * near;
  }
  // Start the sweeps from the weights moved by each average's change over its partition (the
  // Nadaraya-Watson step): Gauss-Seidel alone removes smooth errors slowly, and a scan's change
  // is mostly smooth, so five sweeps from the old weights left broad areas reading short.
  std::vector<double>& target = change;  // from here on each anchor's average
  for (std::size_t t = 0; t < active.size(); ++t) {
    const std::size_t a = std::size_t(slot[active[t]]);
    const double average = sum_sm_[a] / sum_s_[a];
    map_.w_mean[a] += (change[t] + average) / part[t];
    target[t] = average;
  }
  for (std::size_t i = 0; i < cells; ++i)
    wbox[i] = slot[i] >= 0 ? map_.w_mean[std::size_t(slot[i])] : 0.0;
  const double shrink_ridge = 1.0 / (1.0 + opt_.ridge);
  for (int sweep = 0; sweep < opt_.sweeps; ++sweep)
    for (std::size_t t = 0; t < active.size(); ++t) {
      const std::size_t i = active[t];
      stencil.set_gamma(map_.gamma[std::size_t(slot[i])]);
      const double va = target[t];
      const double rest = va - (stencil.runs_dot(wbox.data(), i, stencil.gram) +
                                stencil.row_dot(wbox.data(), i, row));
      const double r = rest - row[1] * (wbox[i - 1] + wbox[i + 1]);
      // Projected onto the average's sign: a weight of the other sign would only cancel its
      // neighbours' tails, and past the last anchors it rings into space no scan saw.
      const double wa = r * shrink_ridge;
      wbox[i] = va >= 0 ? std::max(wa, 0.0) : std::min(wa, 0.0);
    }
  for (std::size_t i : active) map_.w_mean[std::size_t(slot[i])] = wbox[i];
  // Variances: the anchors' averages spread by the partition sum_b phi_b(x_a)^2.
  for (std::size_t t = 0; t < active.size(); ++t) {
    const std::size_t a = std::size_t(slot[active[t]]);
    map_.w_var[a] = sum_sv_[a] / sum_s_[a] / s2[t];
  }
}

void AveragedMap::add(const KernelMap& inst) {
  if (inst.dim != dim_)
    throw ArgumentError("AveragedMap::add: a " + std::to_string(inst.dim) + "D map added to a " +
                        std::to_string(dim_) + "D map");
  inst.validate("AveragedMap::add");
  if (inst.empty()) return;
  const Box box = footprint(inst);
  scatter(inst, box);
  place_anchors(box);
  solve_weights(box);
}

void AveragedMap::add_map(const AveragedMap& o) {
  if (o.dim_ != dim_ || o.opt_.spacing != opt_.spacing || o.opt_.min_support != opt_.min_support ||
      o.opt_.ridge != opt_.ridge)
    throw ArgumentError("AveragedMap::add_map: the maps' dimension or anchor grid differ (" +
                        std::to_string(dim_) + "D at " + std::to_string(opt_.spacing) + " m, " +
                        std::to_string(o.dim_) + "D at " + std::to_string(o.opt_.spacing) + " m)");
  if (o.map_.empty()) return;
  if (&o == this) {  // its arrays grow below: add a copy
    const AveragedMap copy = o;
    add_map(copy);
    return;
  }
  // One box over both maps' anchors (footprint() of a map holding every anchor of both).
  KernelMap all = o.map_;
  for (std::size_t k = 0; k < map_.size(); ++k)
    all.push_back(&map_.position[k * std::size_t(dim_)], map_.gamma[k], 0.0, 0.0);
  const Box box = footprint(all);
  const std::int64_t *lo = box.lo, *n = box.n;
  Workspace& work = ws_;
  work.slot.resize(box.cells);
  std::vector<std::int64_t>& slot = work.slot;
  auto cell_index = [&](const std::int64_t g[3]) {
    return std::size_t((g[0] - lo[0]) + n[0] * ((g[1] - lo[1]) + n[1] * (g[2] - lo[2])));
  };
  // Every anchor of the merged map is solved: this map's with the change of their averages,
  // the other's new ones from zero.
  std::vector<double> before(map_.size());
  for (std::size_t a = 0; a < map_.size(); ++a) before[a] = sum_sm_[a] / sum_s_[a];
  for (std::size_t k = 0; k < o.map_.size(); ++k) {
    std::int64_t g[3] = {0, 0, 0};
    for (int d = 0; d < dim_; ++d)
      g[d] = cell(o.map_.position[k * std::size_t(dim_) + std::size_t(d)]);
    std::int64_t a = -1;
    slots_along_x(g, 1, &a);
    if (a < 0) {
      a = std::int64_t(map_.size());
      set_slot(g, std::uint32_t(a));
      map_.push_back(&o.map_.position[k * std::size_t(dim_)], o.map_.gamma[k], 0.0, 0.0);
      for (std::vector<double>* v : {&sum_sm_, &sum_s_, &sum_sv_, &sum_sg_}) v->push_back(0);
    }
    const auto u = std::size_t(a);
    sum_sm_[u] += o.sum_sm_[k];
    sum_s_[u] += o.sum_s_[k];
    sum_sv_[u] += o.sum_sv_[k];
    sum_sg_[u] += o.sum_sg_[k];
    map_.gamma[u] = sum_sg_[u] / sum_s_[u];
  }
  for (std::int64_t z = 0; z < n[2]; ++z)
    for (std::int64_t y = 0; y < n[1]; ++y) {
      const std::int64_t c[3] = {lo[0], lo[1] + y, lo[2] + z};
      slots_along_x(c, std::size_t(n[0]), &slot[std::size_t(n[0] * (y + n[1] * z))]);
    }
  work.active.clear();
  work.change.clear();
  for (std::size_t a = 0; a < map_.size(); ++a) {
    std::int64_t g[3] = {0, 0, 0};
    for (int d = 0; d < dim_; ++d)
      g[d] = cell(map_.position[a * std::size_t(dim_) + std::size_t(d)]);
    work.active.push_back(cell_index(g));
    work.change.push_back(a < before.size() ? -before[a] : 0.0);
  }
  // Raster order, as place_anchors() lists them: the sweeps' order.
  std::vector<std::size_t> order(work.active.size());
  for (std::size_t t = 0; t < order.size(); ++t) order[t] = t;
  std::sort(order.begin(), order.end(),
            [&](std::size_t x, std::size_t y) { return work.active[x] < work.active[y]; });
  std::vector<std::size_t> active(order.size());
  std::vector<double> change(order.size());
  for (std::size_t t = 0; t < order.size(); ++t) {
    active[t] = work.active[order[t]];
    change[t] = work.change[order[t]];
  }
  work.active = std::move(active);
  work.change = std::move(change);
  const int sweeps = opt_.sweeps;
  opt_.sweeps = std::max(sweeps, 30);
  solve_weights(box);
  opt_.sweeps = sweeps;
}

std::size_t AveragedMap::memory_bytes() const {
  std::size_t b = sizeof(*this);
  b += 8 * (map_.position.capacity() + map_.gamma.capacity() + map_.w_mean.capacity() +
            map_.w_var.capacity());
  b += 8 * (sum_sm_.capacity() + sum_s_.capacity() + sum_sv_.capacity() + sum_sg_.capacity());
  for (const auto* x : {&ws_.m, &ws_.v, &ws_.sup, &ws_.sg, &ws_.t2, &ws_.f, &ws_.part, &ws_.s2,
                        &ws_.change, &ws_.w, &ws_.has})
    b += 8 * x->capacity();
  b += 8 * (ws_.slot.capacity() + ws_.active.capacity());
  b += blocks_.bucket_count() * sizeof(void*) +
       blocks_.size() * (sizeof(std::uint64_t) + 4 + 2 * sizeof(void*)) +
       4 * block_slots_.capacity();
  return b;
}

}  // namespace potmap
