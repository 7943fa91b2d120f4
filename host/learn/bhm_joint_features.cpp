// The joint BHM's features: a sample's span of cells within the cut-off, the tiles it reaches
// and its kernels with their phi, and a scan's features listed flat for update().
#include "potmap/learn/bhm_joint.hpp"

#include <algorithm>
#include <cmath>

#include "bhm_joint_grid.hpp"
#include "runtime/host_team.hpp"

namespace potmap {

using namespace joint_grid;

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

}  // namespace potmap
