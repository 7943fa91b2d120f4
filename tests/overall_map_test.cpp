#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "potmap/data/labelling.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/pot/overall_map.hpp"

using namespace potmap;

namespace {

KernelMap one_kernel(double x, double y, double g, double wm, double wv) {
  KernelMap m;
  const double p[2] = {x, y};
  m.push_back(p, g, wm, wv);
  return m;
}

// The documented rule, brute force: every query scans every kernel.
struct ReferenceOverall {
  OverallMapOptions o;
  KernelMap map;
  std::vector<double> count;
  std::vector<int> born;
  int adds = 0;
  explicit ReferenceOverall(int dim, OverallMapOptions opt) : o(opt) { map.dim = dim; }
  long nearest(const double* p, double g, long exclude) const {
    const int D = map.dim;
    long best = -1;
    double bd = HUGE_VAL;
    for (std::size_t e = 0; e < map.size(); ++e) {
      if (born[e] == adds || long(e) == exclude) continue;
      const double gmax = std::max(map.gamma[e], g), gmin = std::min(map.gamma[e], g);
      if (gmax > o.gamma_ratio * gmin) continue;
      double d2 = 0;
      for (int d = 0; d < D; ++d) d2 += std::pow(map.position[e * D + d] - p[d], 2);
      if (d2 * gmax < o.merge_radius && d2 < bd) {
        bd = d2;
        best = static_cast<long>(e);
      }
    }
    return best;
  }
  void merge(std::size_t e, const double* p, double g, double wm, double wv, double c) {
    const int D = map.dim;
    const double om = count[e] / (count[e] + c), on = c / (count[e] + c);
    const double prec = om / map.w_var[e] + on / wv;
    map.w_mean[e] = (om * map.w_mean[e] / map.w_var[e] + on * wm / wv) / prec;
    map.w_var[e] = 1 / prec;
    map.gamma[e] = om * map.gamma[e] + on * g;
    for (int d = 0; d < D; ++d) map.position[e * D + d] = om * map.position[e * D + d] + on * p[d];
    count[e] += c;
  }
  void remove(std::size_t f) {
    const int D = map.dim;
    const std::size_t last = map.size() - 1;
    for (int d = 0; d < D; ++d) map.position[f * D + d] = map.position[last * D + d];
    map.gamma[f] = map.gamma[last];
    map.w_mean[f] = map.w_mean[last];
    map.w_var[f] = map.w_var[last];
    count[f] = count[last];
    born[f] = born[last];
    map.position.resize(last * D);
    map.gamma.pop_back();
    map.w_mean.pop_back();
    map.w_var.pop_back();
    count.pop_back();
    born.pop_back();
  }
  void add(const KernelMap& in) {
    ++adds;
    const int D = map.dim;
    for (std::size_t i = 0; i < in.size(); ++i) {
      const double* p = &in.position[i * D];
      long e = nearest(p, in.gamma[i], -1);
      if (e < 0) {
        map.push_back(p, in.gamma[i], in.w_mean[i], in.w_var[i]);
        count.push_back(1);
        born.push_back(adds);
        continue;
      }
      merge(e, p, in.gamma[i], in.w_mean[i], in.w_var[i], 1);
      for (long f; (f = nearest(&map.position[e * D], map.gamma[e], e)) >= 0;) {
        const double q[3] = {map.position[f * D], map.position[f * D + 1], 0};
        merge(e, q, map.gamma[f], map.w_mean[f], map.w_var[f], count[f]);
        born[e] = std::min(born[e], born[f]);
        const long last = static_cast<long>(map.size()) - 1;
        remove(f);
        if (e == last) e = f;
      }
    }
  }
};

// A patch of kernels around (cx, cy) with widths spread over a factor 8 and positions and
// weights jittered, as successive transported maps of one place look.
KernelMap jittered_patch(std::mt19937_64& rng, double cx, double cy, double jitter, int n = 12) {
  std::normal_distribution<double> g(0, 1);
  KernelMap m;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double p[2] = {cx + i * 0.7 + jitter * g(rng), cy + j * 0.7 + jitter * g(rng)};
      const double gamma = 4.0 * std::pow(2.0, ((i + j) % 4) - 1.5) * std::exp(0.1 * g(rng));
      m.push_back(p, gamma, 3 * g(rng), std::exp(g(rng)));
    }
  return m;
}

}  // namespace

TEST(OverallMap, MergeRuleOnHandMadeKernels) {
  OverallMap om(2);
  om.add(one_kernel(0, 0, 4.0, 2.0, 1.0));
  // d^2 gamma = 0.04 * 4 = 0.16 < 0.25: merges. Count 1 on each side: omega = 1/2.
  auto st = om.add(one_kernel(0.2, 0, 4.4, -1.0, 3.0));
  EXPECT_EQ(st.merged, 1u);
  ASSERT_EQ(om.size(), 1u);
  const double prec = 0.5 / 1.0 + 0.5 / 3.0;
  EXPECT_DOUBLE_EQ(om.map().w_var[0], 1 / prec);
  EXPECT_DOUBLE_EQ(om.map().w_mean[0], (0.5 * 2.0 / 1.0 + 0.5 * -1.0 / 3.0) / prec);
  EXPECT_DOUBLE_EQ(om.map().position[0], 0.1);
  EXPECT_DOUBLE_EQ(om.map().gamma[0], 4.2);
  EXPECT_EQ(om.counts()[0], 2u);
  // The variance never drops below the smaller of the two (no overconfidence from revisits).
  EXPECT_GE(om.map().w_var[0], 1.0);
  // A third visit weighs 1/3.
  om.add(one_kernel(0.1, 0, 4.2, 5.0, om.map().w_var[0]));
  EXPECT_NEAR(om.map().w_mean[0], (2 * (0.5 * 2.0 - 0.5 / 3.0) / prec + 5.0) / 3.0, 1e-12);

  // Too far (d^2 gamma = 0.36), too different in width (ratio 2.5): both appended.
  OverallMap far(2);
  far.add(one_kernel(0, 0, 4.0, 1, 1));
  EXPECT_EQ(far.add(one_kernel(0.3, 0, 4.0, 1, 1)).added, 1u);
  EXPECT_EQ(far.add(one_kernel(0, 0, 10.0, 1, 1)).added, 1u);
  EXPECT_EQ(far.size(), 3u);

  // An exact weight (variance 0) wins over an uncertain one; two exact ones average.
  OverallMap exact(2);
  exact.add(one_kernel(0, 0, 1, 7.0, 0.0));
  exact.add(one_kernel(0, 0, 1, -3.0, 2.0));
  EXPECT_EQ(exact.map().w_mean[0], 7.0);
  EXPECT_EQ(exact.map().w_var[0], 0.0);
  exact.add(one_kernel(0, 0, 1, 1.0, 0.0));
  EXPECT_NEAR(exact.map().w_mean[0], (2 * 7.0 + 1.0) / 3, 1e-12);

  // New kernels of one map never merge with each other.
  OverallMap self(2);
  KernelMap two = one_kernel(0, 0, 1, 1, 1);
  const double p[2] = {0, 0};
  two.push_back(p, 1, 1, 1);
  EXPECT_EQ(self.add(two).added, 2u);
}

TEST(OverallMap, AddingTheSameMapTwiceChangesNothing) {
  std::mt19937_64 rng(3);
  KernelMap m = jittered_patch(rng, 10, -5, 0.0);
  const KernelMap m2 = jittered_patch(rng, 30, 40, 0.0);
  for (std::size_t i = 0; i < m2.size(); ++i)
    m.push_back(&m2.position[2 * i], m2.gamma[i], m2.w_mean[i], m2.w_var[i]);
  OverallMap om(2);
  om.add(m);
  const KernelMap once = om.map();
  const auto st = om.add(m);
  EXPECT_EQ(st.merged, m.size());
  EXPECT_EQ(om.size(), once.size());
  for (std::size_t i = 0; i < once.size(); ++i) {
    EXPECT_DOUBLE_EQ(om.map().w_mean[i], once.w_mean[i]);
    EXPECT_DOUBLE_EQ(om.map().w_var[i], once.w_var[i]);
    EXPECT_DOUBLE_EQ(om.map().gamma[i], once.gamma[i]);
    EXPECT_DOUBLE_EQ(om.map().position[2 * i], once.position[2 * i]);
  }
}

TEST(OverallMap, HashGridGivesTheBruteForceResult) {
  for (int trial = 0; trial < 3; ++trial) {
    std::mt19937_64 rng(100 + trial);
    std::uniform_real_distribution<double> u(-20, 20);
    OverallMapOptions o;
    o.merge_radius = trial == 2 ? 2.0 : 0.25;  // wide merges cross many cells too
    OverallMap om(2, o);
    ReferenceOverall ref(2, o);
    std::size_t fused = 0;
    for (int a = 0; a < 40; ++a) {
      // Mostly one neighbourhood revisited, sometimes a wide kernel far away.
      KernelMap m = jittered_patch(rng, u(rng) / 8, u(rng) / 8, 0.15, 6);
      if (a % 7 == 0) {
        const double p[2] = {u(rng) * 50, u(rng)};
        m.push_back(p, 0.01, 1.0, 2.0);
      }
      fused += om.add(m).fused;
      ref.add(m);
    }
    if (trial == 2) EXPECT_GT(fused, 0u);  // consolidation took part
    ASSERT_EQ(om.size(), ref.map.size()) << trial;
    for (std::size_t i = 0; i < ref.map.size(); ++i) {
      EXPECT_NEAR(om.map().position[2 * i], ref.map.position[2 * i], 1e-12);
      EXPECT_NEAR(om.map().position[2 * i + 1], ref.map.position[2 * i + 1], 1e-12);
      EXPECT_NEAR(om.map().gamma[i], ref.map.gamma[i], 1e-12 * ref.map.gamma[i]);
      EXPECT_NEAR(om.map().w_mean[i], ref.map.w_mean[i], 1e-9 * (1 + std::abs(ref.map.w_mean[i])));
      EXPECT_NEAR(om.map().w_var[i], ref.map.w_var[i], 1e-9 * ref.map.w_var[i]);
      EXPECT_EQ(om.counts()[i], static_cast<std::uint32_t>(ref.count[i]));
    }
  }
}

TEST(OverallMap, MemoryStaysBoundedWhenRevisiting) {
  std::mt19937_64 rng(7);
  OverallMap om(2);
  std::size_t after10 = 0, bytes10 = 0;
  for (int visit = 0; visit < 300; ++visit) {
    om.add(jittered_patch(rng, 0, 0, 0.05));
    if (visit == 9) {
      after10 = om.size();
      bytes10 = om.memory_bytes();
    }
  }
  // 144 kernels a visit, 300 visits: without merging 43,200. Jittered copies mostly land on
  // their earlier selves; the few that do not fill the gaps once and then merge too.
  EXPECT_LT(om.size(), 2 * after10);
  EXPECT_LT(om.size(), 600u);
  EXPECT_LT(om.memory_bytes(), 3 * bytes10);
}

TEST(OverallMap, HardCapRetiresTheLeastSupported) {
  std::mt19937_64 rng(9);
  OverallMapOptions o;
  o.max_kernels = 300;
  OverallMap om(2, o);
  const KernelMap home = jittered_patch(rng, 0, 0, 0.0);  // 144, revisited every time
  std::size_t retired = 0;
  for (int a = 0; a < 30; ++a) {
    om.add(home);
    retired += om.add(jittered_patch(rng, 100.0 + 20 * a, 0, 0.0)).retired;
    ASSERT_LE(om.size(), o.max_kernels);
  }
  EXPECT_GT(retired, 0u);
  // The home patch, seen 30 times, is still there in full.
  std::size_t home_kept = 0;
  for (std::size_t i = 0; i < om.size(); ++i) home_kept += om.map().position[2 * i] < 50;
  EXPECT_EQ(home_kept, home.size());
}

TEST(OverallMap, RejectsBadInput) {
  EXPECT_THROW(OverallMap(4), ArgumentError);
  OverallMapOptions o;
  o.gamma_ratio = 0.5;
  EXPECT_THROW(OverallMap(2, o), ArgumentError);
  OverallMap om(3);
  EXPECT_THROW(om.add(one_kernel(0, 0, 1, 1, 1)), ArgumentError);
  OverallMap om2(2);
  EXPECT_THROW(om2.add(one_kernel(0, 0, -1, 1, 1)), ArgumentError);
}

// A BHM map of a simulated street learned in two overlapping pieces and merged back scores
// like the map learned in one piece on held-out beams (the plain sum of the pieces is printed
// for comparison: it double-counts the overlap).
TEST(OverallMap, MergedPiecesScoreLikeTheWholeMap) {
  SimOptions so;
  so.scans = 24;
  so.spacing = 2.0;
  so.step_deg = 3;
  so.seed = 4;
  const Simulation sim = simulate(Town::builtin("town1", 4), so);
  LabelOptions lo;
  lo.free_per_metre = 0.3;
  const LabelledSplit split = label_scans(sim.scans, lo);
  double lo_[3] = {HUGE_VAL, HUGE_VAL, 0}, hi[3] = {-HUGE_VAL, -HUGE_VAL, 0};
  for (std::size_t i = 0; i < split.train.size(); ++i)
    for (int d = 0; d < 2; ++d) {
      lo_[d] = std::min(lo_[d], split.train.position[2 * i + d]);
      hi[d] = std::max(hi[d], split.train.position[2 * i + d]);
    }
  const KernelMap prior = bhm_grid_prior(2, lo_, hi, 1.0, 8.0);
  BhmOptions bo;
  bo.em_iterations = 2;
  KernelMap whole = prior;
  bhm_update_reference(whole, split.train, bo);

  // Two pieces along the longer axis, overlapping by 12 m; each learns from its own samples.
  const int ax = (hi[0] - lo_[0]) >= (hi[1] - lo_[1]) ? 0 : 1;
  const double mid = 0.5 * (lo_[ax] + hi[ax]);
  auto piece = [&](double a, double b) {
    KernelMap m;
    for (std::size_t k = 0; k < prior.size(); ++k) {
      const double v = prior.position[2 * k + ax];
      if (v >= a && v <= b) m.push_back(&prior.position[2 * k], prior.gamma[k], 0, prior.w_var[k]);
    }
    LabelledPoints s;
    for (std::size_t i = 0; i < split.train.size(); ++i) {
      const double v = split.train.position[2 * i + ax];
      if (v < a - 1 || v > b + 1) continue;  // a metre past the kernels: their edge still learns
      s.position.insert(s.position.end(), &split.train.position[2 * i],
                        &split.train.position[2 * i + 2]);
      s.label.push_back(split.train.label[i]);
      s.scan.push_back(split.train.scan[i]);
    }
    bhm_update_reference(m, s, bo);
    return m;
  };
  const KernelMap p1 = piece(-HUGE_VAL, mid + 6), p2 = piece(mid - 6, HUGE_VAL);
  OverallMap om(2);
  om.add(p1);
  const auto st = om.add(p2);
  EXPECT_GT(st.merged, 0u);
  EXPECT_EQ(om.size(), whole.size());
  KernelMap summed = p1;
  for (std::size_t k = 0; k < p2.size(); ++k)
    summed.push_back(&p2.position[2 * k], p2.gamma[k], p2.w_mean[k], p2.w_var[k]);

  auto scores = [&](const KernelMap& m) {
    const MapValuesExact v = evaluate_exact(m, split.test.position.data(), split.test.size());
    return score(v.prob, split.test.label);
  };
  const Scores sw = scores(whole), sm = scores(om.map()), ss = scores(summed);
  std::printf(
      "whole  ACC %.4f AUC %.4f NLL %.4f\nmerged ACC %.4f AUC %.4f NLL %.4f\n"
      "summed ACC %.4f AUC %.4f NLL %.4f  (%zu test points, %zu merged)\n",
      sw.acc, sw.auc, sw.nll, sm.acc, sm.auc, sm.nll, ss.acc, ss.auc, ss.nll, sw.n, st.merged);
  EXPECT_GT(sm.auc, sw.auc - 0.01);
  EXPECT_LT(sm.nll, sw.nll + 0.02);
}

// A short simulated drive (2,000 scans, 1 m apart) through a town whose map has a kernel per
// square metre: each scan adds the kernels within 20 m, jittered. The overall map ends near the
// number of distinct kernels driven past: revisits do not add kernels.
TEST(OverallMap, ShortDriveStaysBounded) {
  const Town town = Town::builtin("town1", 2);
  SimOptions so;
  so.scans = 2000;
  so.step_deg = 90;  // only the poses are used
  so.seed = 5;
  const Simulation sim = simulate(town, so);
  const int gx = static_cast<int>(town.width()), gy = static_cast<int>(town.height());
  std::mt19937_64 rng(6);
  std::normal_distribution<double> g(0, 1);
  std::vector<char> seen(std::size_t(gx) * gy, 0);
  std::size_t distinct = 0, size_at_1000 = 0, distinct_at_1000 = 0;
  OverallMap om(2);
  for (std::size_t i = 0; i < sim.scans.size(); ++i) {
    const double x = sim.route[2 * i], y = sim.route[2 * i + 1];
    KernelMap inst;
    for (int cy = std::max(0, int(y) - 20); cy <= std::min(gy - 1, int(y) + 20); ++cy)
      for (int cx = std::max(0, int(x) - 20); cx <= std::min(gx - 1, int(x) + 20); ++cx) {
        if ((cx - x) * (cx - x) + (cy - y) * (cy - y) > 400) continue;
        const double p[2] = {cx + 0.05 * g(rng), cy + 0.05 * g(rng)};
        inst.push_back(p, 8.0 * std::exp(0.1 * g(rng)), std::sin(cx * 0.3 + cy), 0.5);
        char& s = seen[std::size_t(cy) * gx + cx];
        distinct += !s;
        s = 1;
      }
    om.add(inst);
    if (i + 1 == 1000) {
      size_at_1000 = om.size();
      distinct_at_1000 = distinct;
    }
  }
  const double r1000 = double(size_at_1000) / distinct_at_1000,
               r2000 = double(om.size()) / distinct;
  std::printf(
      "after 1000 scans: %zu kernels for %zu distinct places (%.3f); after 2000: %zu for "
      "%zu (%.3f), %.2f MB\n",
      size_at_1000, distinct_at_1000, r1000, om.size(), distinct, r2000, om.memory_bytes() / 1e6);
  // Jittered copies that miss their kernel's merge radius are fused back once a merge brings
  // them together; the ratio to the places seen stays put instead of growing with the visits.
  EXPECT_LT(r2000, 1.2);  // measured 1.053
  EXPECT_LT(r2000, r1000 * 1.15);
  EXPECT_LT(om.memory_bytes(), om.size() * 200);
}
