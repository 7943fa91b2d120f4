// Device tunings (potmap/runtime/tuning.hpp): defaults per device, the override syntax and its
// errors, and the routines giving the same results under two tunings (up to the order of their
// floating-point sums).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>

#include "potmap/error.hpp"
#include "potmap/learn/abhm.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/ot/sinkhorn.hpp"
#include "potmap/runtime/tuning.hpp"
#include "potmap/runtime/tuning_file.hpp"
#include "test_support.hpp"
#include "tuned_context.hpp"

using namespace potmap;

namespace {

// Every field moved off the CPU defaults, to values the kernels accept.
const char* kOtherTuning =
    "map_eval.vector_width=4, map_eval.work_group=16, map_eval.cells_work_group=64,"
    "map_eval.chunks_per_query=3 raster.rows_per_item=16 raster.tile=32 sinkhorn.work_group=16,"
    "sinkhorn.groups_per_compute_unit=2,sinkhorn.chunk_slots=200,"
    "learn.bhm_work_group=16,learn.abhm_work_group=32";

Context& tuned_context() {
  static Context ctx = [] {
    ContextOptions o;
    o.device = test::context().info().name;
    o.tuning = kOtherTuning;
    return Context(o);
  }();
  return ctx;
}

std::string error_of(const std::string& spec) {
  try {
    parse_tuning(spec, Tuning{});
  } catch (const ArgumentError& e) {
    return e.what();
  }
  return "";
}

KernelMap random_tuning_map(int dim, std::size_t m, double extent, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(0, extent), lg(std::log(0.05), std::log(2.0)),
      w(-10, 10), lv(std::log(1e-4), std::log(10.0));
  KernelMap map;
  map.dim = dim;
  for (std::size_t k = 0; k < m; ++k) {
    const double p[3] = {pos(rng), pos(rng), pos(rng) * 0.3};
    map.push_back(p, std::exp(lg(rng)), w(rng), std::exp(lv(rng)));
  }
  return map;
}

void expect_close(const MapValues& a, const MapValues& b) {
  ASSERT_EQ(a.prob.size(), b.prob.size());
  double dp = 0, dm = 0, dv = 0;
  for (std::size_t i = 0; i < a.prob.size(); ++i) {
    dp = std::max(dp, double(std::abs(a.prob[i] - b.prob[i])));
    dm = std::max(dm, std::abs(a.mean[i] - b.mean[i]) / (1.0 + std::abs(a.mean[i])));
    dv = std::max(dv, std::abs(a.var[i] - b.var[i]) / (1.0 + a.var[i]));
  }
  EXPECT_LT(dp, 2e-6);
  EXPECT_LT(dm, 2e-5);
  EXPECT_LT(dv, 2e-5);
}

}  // namespace

TEST(Tuning, DefaultsPerDevice) {
  DeviceInfo cpu, gpu;  // no platform: the generic values
  cpu.is_cpu = true;
  gpu.is_gpu = true;
  const Tuning c = default_tuning(cpu), g = default_tuning(gpu);
  EXPECT_EQ(c.map_eval.vector_width, 16);
  EXPECT_EQ(c.map_eval.work_group, 8);
  EXPECT_EQ(c.map_eval.cells_work_group, 16);
  EXPECT_EQ(c.sinkhorn.work_group, 4);
  EXPECT_EQ(g.map_eval.vector_width, 4);
  EXPECT_EQ(g.map_eval.work_group, 64);
  EXPECT_EQ(g.map_eval.cells_work_group, 128);
  EXPECT_EQ(g.sinkhorn.work_group, 64);
  EXPECT_EQ(c.sinkhorn.chunk_slots, g.sinkhorn.chunk_slots);
  validate_tuning(c);
  validate_tuning(g);
}

// PoCL's CPU device gets its own values; another platform's CPU device and every GPU (PoCL's
// own included) keep the generic ones.
TEST(Tuning, PoclCpuDeviceGetsItsShippedDefaults) {
  DeviceInfo pocl, other_cpu, pocl_gpu, gpu;
  pocl.platform = kPoclPlatform;
  pocl.is_cpu = true;
  other_cpu.platform = "Intel(R) OpenCL";
  other_cpu.is_cpu = true;
  pocl_gpu.platform = kPoclPlatform;
  pocl_gpu.is_gpu = true;
  gpu.platform = "NVIDIA CUDA";
  gpu.is_gpu = true;
  EXPECT_TRUE(is_pocl_cpu(pocl));
  EXPECT_FALSE(is_pocl_cpu(other_cpu));
  EXPECT_FALSE(is_pocl_cpu(pocl_gpu));
  EXPECT_FALSE(is_pocl_cpu(gpu));

  const Tuning p = default_tuning(pocl), c = default_tuning(other_cpu);
  EXPECT_EQ(p.sinkhorn.work_group, 1);
  EXPECT_EQ(c.sinkhorn.work_group, 4);
  EXPECT_EQ(c.raster.tile, 64);
  EXPECT_EQ(to_string(c), to_string(Tuning{}));  // the generic CPU values
  // Every other field as the generic CPU values.
  Tuning rest = p;
  rest.sinkhorn.work_group = c.sinkhorn.work_group;
  EXPECT_EQ(to_string(rest), to_string(c));
  EXPECT_EQ(to_string(default_tuning(pocl_gpu)), to_string(default_tuning(gpu)));
  EXPECT_EQ(default_tuning(gpu).sinkhorn.work_group, 64);
  validate_tuning(p);
}

// On the test device, whatever it is: the built-in values, then a tuning file, POTMAP_TUNING and
// ContextOptions::tuning over them, the closer to the call the later.
TEST(Tuning, FileEnvironmentAndOptionStillOverrideTheDevicesDefaults) {
  const DeviceInfo& info = test::context().info();
  const char* env = std::getenv("POTMAP_TUNING");
  const std::string saved = env ? env : "";
  unsetenv("POTMAP_TUNING");
  ContextOptions o;
  o.device = info.name;
  o.tuning_file = false;
  {
    Context c(o);
    EXPECT_EQ(to_string(c.tuning()), to_string(default_tuning(info)));
    if (is_pocl_cpu(info)) EXPECT_EQ(c.tuning().sinkhorn.work_group, 1);
  }
  const std::string dir = test::temp_dir("tuning-over-defaults");
  write_tuning_file(tuning_file_path(dir, info), info,
                    parse_tuning("sinkhorn.work_group=8", default_tuning(info)));
  o.tuning_file = true;
  o.tuning_dir = dir;
  EXPECT_EQ(Context(o).tuning().sinkhorn.work_group, 8);
  setenv("POTMAP_TUNING", "sinkhorn.work_group=16", 1);
  EXPECT_EQ(Context(o).tuning().sinkhorn.work_group, 16);
  o.tuning = "sinkhorn.work_group=4";
  EXPECT_EQ(Context(o).tuning().sinkhorn.work_group, 4);
  if (env)
    setenv("POTMAP_TUNING", saved.c_str(), 1);
  else
    unsetenv("POTMAP_TUNING");
}

TEST(Tuning, ParseOverridesOnlyTheNamedFieldsAndRoundTrips) {
  const Tuning base;
  const Tuning t = parse_tuning("sinkhorn.work_group=8, map_eval.vector_width=8", base);
  EXPECT_EQ(t.sinkhorn.work_group, 8);
  EXPECT_EQ(t.map_eval.vector_width, 8);
  EXPECT_EQ(t.map_eval.work_group, base.map_eval.work_group);
  EXPECT_EQ(t.learn.bhm_work_group, base.learn.bhm_work_group);
  const Tuning other = parse_tuning(kOtherTuning, base);
  EXPECT_EQ(to_string(parse_tuning(to_string(other), base)), to_string(other));
  EXPECT_NE(to_string(other), to_string(base));
  EXPECT_EQ(to_string(parse_tuning("", other)), to_string(other));
}

TEST(Tuning, BadPairsAreNamed) {
  EXPECT_NE(error_of("map_eval.vector_width=5").find("map_eval.vector_width=5"), std::string::npos);
  EXPECT_NE(error_of("sinkhorn.work_group=3").find("power of two"), std::string::npos);
  EXPECT_NE(error_of("nosuch.field=1").find("'nosuch.field'"), std::string::npos);
  EXPECT_NE(error_of("sinkhorn.work_group=abc").find("'abc'"), std::string::npos);
  EXPECT_NE(error_of("sinkhorn.work_group").find("routine.field=value"), std::string::npos);
  EXPECT_NE(error_of("raster.rows_per_item=-4").find("'-4'"), std::string::npos);
  EXPECT_EQ(error_of("raster.rows_per_item=4"), "");
  EXPECT_NE(error_of("raster.tile=128").find("raster.tile=128: must be 16, 32 or 64"),
            std::string::npos)
      << error_of("raster.tile=128");
  EXPECT_EQ(error_of("raster.tile=16"), "");
  ContextOptions o;
  o.device = test::context().info().name;
  o.tuning = "learn.bhm_work_group=0";
  EXPECT_THROW(Context{o}, ArgumentError);
  o.tuning = "learn.bhm_work_group=32";
  Context c(o);
  EXPECT_EQ(c.tuning().learn.bhm_work_group, 32);
  EXPECT_EQ(c.tuning().map_eval.vector_width, default_tuning(c.info()).map_eval.vector_width);
  Tuning bad = c.tuning();
  bad.map_eval.work_group = 6;
  EXPECT_THROW(c.set_tuning(bad), ArgumentError);
}

TEST(Tuning, MapEvaluatorAgreesUnderTwoTunings) {
  const KernelMap map = random_tuning_map(2, 2000, 60, 7);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-5, 65);
  std::vector<double> pts(2 * 6000);
  for (double& x : pts) x = u(rng);
  MapEvaluator a(test::context(), map), b(tuned_context(), map);
  expect_close(a.evaluate(pts), b.evaluate(pts));
  // Pairs are counted per chunk of vector_width x work_group queries: a different count shows
  // that the other tuning reached the evaluator.
  EXPECT_NE(a.last_pairs(), b.last_pairs());
  GridSpec grid;
  grid.dim = 2;
  grid.origin[0] = -3;
  grid.origin[1] = -2;
  grid.resolution = 0.35;
  grid.count[0] = 190;
  grid.count[1] = 150;
  expect_close(a.evaluate_grid(grid), b.evaluate_grid(grid));

  // A 3D grid: tiles of 8 y rows by tile / 8 z rows (raster.tile=32 in the other tuning).
  const KernelMap map3 = random_tuning_map(3, 1500, 40, 9);
  GridSpec g3;
  g3.dim = 3;
  g3.origin[0] = -1;
  g3.origin[1] = -1;
  g3.origin[2] = -1;
  g3.resolution = 0.5;
  g3.count[0] = 90;
  g3.count[1] = 70;
  g3.count[2] = 30;
  MapEvaluator a3(test::context(), map3), b3(tuned_context(), map3);
  expect_close(a3.evaluate_grid(g3), b3.evaluate_grid(g3));

  // The device-buffer path (map_eval.cells_work_group): the same points, already on the device.
  const std::size_t n = pts.size() / 2;
  const double origin[2] = {30, 30};
  std::vector<float> rel(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) rel[i] = static_cast<float>(pts[i] - origin[i % 2]);
  const auto on_device = [&](Context& ctx, MapEvaluator& ev) {
    namespace bc = boost::compute;
    bc::buffer d_pts(ctx.context(), rel.size() * 4), d_m(ctx.context(), n * 4),
        d_v(ctx.context(), n * 4), d_p(ctx.context(), n * 4);
    ctx.queue().enqueue_write_buffer(d_pts, 0, rel.size() * 4, rel.data());
    ev.evaluate_device(d_pts, n, origin, &d_m, &d_v, &d_p).wait();
    MapValues v;
    v.mean.resize(n);
    v.var.resize(n);
    v.prob.resize(n);
    ctx.queue().enqueue_read_buffer(d_m, 0, n * 4, v.mean.data());
    ctx.queue().enqueue_read_buffer(d_v, 0, n * 4, v.var.data());
    ctx.queue().enqueue_read_buffer(d_p, 0, n * 4, v.prob.data());
    return v;
  };
  ASSERT_NE(test::context().tuning().map_eval.cells_work_group,
            tuned_context().tuning().map_eval.cells_work_group);
  expect_close(on_device(test::context(), a), on_device(tuned_context(), b));
}

// The learners' kernels give each work-item one kernel or one sample, summing its own pairs in
// a fixed order: their work-groups (learn.bhm_work_group, learn.abhm_work_group) change nothing,
// bit for bit.
TEST(Tuning, LearnersAgreeBitForBitUnderTwoTunings) {
  ASSERT_NE(test::context().tuning().learn.bhm_work_group,
            tuned_context().tuning().learn.bhm_work_group);
  ASSERT_NE(test::context().tuning().learn.abhm_work_group,
            tuned_context().tuning().learn.abhm_work_group);
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(0, 20);
  LabelledPoints s;
  for (int i = 0; i < 3000; ++i) {
    const double x = u(rng), y = u(rng);
    s.position.insert(s.position.end(), {x, y});
    s.label.push_back(std::hypot(x - 10, y - 10) < 4 ? 1 : 0);
    s.scan.push_back(0);
  }
  const double lo[3] = {0, 0, 0}, hi[3] = {20, 20, 0};
  const KernelMap prior = bhm_grid_prior(2, lo, hi, 1.0, 4.0);
  KernelMap a = prior, b = prior;
  bhm_update(test::context(), a, s);
  bhm_update(tuned_context(), b, s);
  EXPECT_EQ(a.w_mean, b.w_mean);
  EXPECT_EQ(a.w_var, b.w_var);
  EXPECT_NE(a.w_mean, prior.w_mean);  // the update did something

  const AbhmParams p = abhm_init_grid(2, lo, hi, 1.0, 4.0);
  AbhmNoise noise;
  std::normal_distribution<double> z;
  noise.w.resize(p.size());
  noise.g.resize(p.size());
  noise.h.resize(p.h_loc.size());
  for (auto* v : {&noise.w, &noise.g, &noise.h})
    for (double& x : *v) x = z(rng);
  std::vector<double> ga, gb;
  const double la = abhm_loss_device(test::context(), p, AbhmPrior{}, s, 1.0, noise, &ga);
  const double lb = abhm_loss_device(tuned_context(), p, AbhmPrior{}, s, 1.0, noise, &gb);
  EXPECT_EQ(la, lb);
  EXPECT_EQ(ga, gb);
  ASSERT_FALSE(ga.empty());
}

namespace {

// A problem between uniform points in [-1, 1]^2 (source drawn first), epsilon 0.05, tolerance 1e-5.
SinkhornProblem random_problem(std::mt19937& rng, int n_source, int n_target) {
  std::uniform_real_distribution<double> u(-1, 1);
  SinkhornProblem q;
  q.source = Eigen::MatrixXd::NullaryExpr(n_source, 2, [&] { return u(rng); });
  q.target = Eigen::MatrixXd::NullaryExpr(n_target, 2, [&] { return u(rng); });
  q.epsilon = 0.05;
  q.tolerance = 1e-5;
  return q;
}

}  // namespace

TEST(Tuning, SinkhornAgreesUnderTwoTunings) {
  std::mt19937 rng(11);
  SinkhornBatch batch;
  for (int p = 0; p < 12; ++p) {
    SinkhornProblem q = random_problem(rng, 24 + p % 9, 20 + p % 5);
    q.max_iterations = 2000;
    batch.add(q);
  }
  SinkhornOptions o;
  o.want_barycentric = true;
  const auto a = batch.run(test::context(), o);
  const auto b = batch.run(tuned_context(), o);  // 200 slots: several launches
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t p = 0; p < a.size(); ++p) {
    EXPECT_TRUE(a[p].converged && b[p].converged) << p;
    EXPECT_NEAR(a[p].cost, b[p].cost, 1e-4 * a[p].cost) << p;
    EXPECT_LT((a[p].barycentric - b[p].barycentric).cwiseAbs().maxCoeff(), 1e-3) << p;
  }
}

// Both schemes run under a tuned work-group of 1 or 2 (PoCL's CPU device ships 2): on PoCL the
// log-domain scheme, whose kernel PoCL 3.1 cannot build with so few work-items, takes 4 (the
// quirk in host/ot/sinkhorn.cpp) and gives the result it gives under 4.
TEST(Tuning, BothSinkhornSchemesRunUnderSmallTunedWorkGroups) {
  std::mt19937 rng(12);
  SinkhornBatch batch;
  for (int p = 0; p < 3; ++p) batch.add(random_problem(rng, 20 + p, 17 + p));
  const auto four = test::tuned_context("sinkhorn.work_group=4");
  for (const bool stabilised : {true, false})
    for (const int wg : {1, 2}) {
      SCOPED_TRACE(std::string(stabilised ? "stabilised" : "log-domain") +
                   ", sinkhorn.work_group=" + std::to_string(wg));
      const auto tuned = test::tuned_context("sinkhorn.work_group=" + std::to_string(wg));
      SinkhornOptions o;
      o.stabilised = stabilised;
      const auto a = batch.run(*tuned, o), b = batch.run(*four, o);
      ASSERT_EQ(a.size(), b.size());
      for (std::size_t p = 0; p < a.size(); ++p) {
        EXPECT_TRUE(a[p].converged) << p;
        EXPECT_NEAR(a[p].cost, b[p].cost, 1e-4 * std::abs(b[p].cost)) << p;
        if (!stabilised && is_pocl_cpu(tuned->info())) EXPECT_EQ(a[p].cost, b[p].cost) << p;
      }
    }
}
