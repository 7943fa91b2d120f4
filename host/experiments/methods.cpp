// The baselines of the experiments: occupancy grid (OctoMap), online BHM, offline ABHM.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>

#include "grid_queries.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/experiments/lookahead.hpp"
#include "potmap/io/known_cells.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/map/evaluate.hpp"

namespace potmap::experiment {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

FittedMap kernel_fitted_map(Context* ctx, std::shared_ptr<const KernelMap> map) {
  FittedMap f;
  f.kernels = map;
  // Made at the first picture only: scoring never asks.
  f.known = [ctx, map, ev = std::shared_ptr<KnownEvaluator>()](const double* pts, std::size_t n,
                                                               std::uint8_t* known) mutable {
    if (!ev) ev = std::make_shared<KnownEvaluator>(ctx, *map);
    const KnownValues v = ev->values(std::vector<double>(pts, pts + n * std::size_t(map->dim)));
    std::copy(v.known.begin(), v.known.end(), known);
  };
  if (ctx) {
    auto ev = std::make_shared<MapEvaluator>(*ctx, *map);
    f.query = [ev](const double* pts, std::size_t n, double* prob, double* var) {
      std::vector<float> p(n), v(n);
      ev->evaluate(pts, n, nullptr, v.data(), p.data());
      for (std::size_t i = 0; i < n; ++i) {
        prob[i] = p[i];
        if (var) var[i] = v[i];
      }
    };
  } else {
    f.query = [map](const double* pts, std::size_t n, double* prob, double* var) {
      const MapValuesExact e = evaluate_exact(*map, pts, n);
      for (std::size_t i = 0; i < n; ++i) {
        prob[i] = e.prob[i];
        if (var) var[i] = e.var[i];
      }
    };
  }
  return f;
}

Method ogm_method(double resolution) {
  char name[64];
  std::snprintf(name, sizeof name, "OGM %g m", resolution);
  Method m;
  m.name = name;
  m.group = "OGM";
  m.fit = [resolution](Context*, const MapTask& task) {
    const auto t0 = std::chrono::steady_clock::now();
    OgmOptions o;
    o.resolution = resolution;
    auto grid = std::make_shared<OccupancyGrid>(task.dim, o);
    LookAheadScorer ahead(task);
    for (std::size_t i = 0; i < task.train_scans.size(); ++i) {
      // Cells no beam has crossed read p = 0.5 (OccupancyGrid::probability).
      ahead.before(
          task.first_index + std::int64_t(i),
          [&](const double* pts, std::size_t n, double* prob) { grid->probability(pts, n, prob); });
      grid->insert(task.train_scans[i]);
    }
    FittedMap f;
    f.fit_seconds = seconds_since(t0) - ahead.seconds();
    if (ahead.active()) f.lookahead = ahead.take();
    f.info["cell_m"] = resolution;
    f.info["leaves"] = double(grid->leaf_count());
    f.info["memory_mb"] = double(grid->memory_bytes()) / 1e6;
    detail::set_grid_queries(f, grid);
    return f;
  };
  return m;
}

JointBhmOptions joint_bhm_options(const BhmSetup& setup) {
  JointBhmOptions o;
  o.spacing = setup.spacing;
  o.gamma = setup.gamma;
  if (setup.prior_var > 0) o.prior_var = setup.prior_var;
  o.bias = setup.bias;
  o.em_iterations = setup.options.em_iterations;
  if (setup.tau > 0) o.tau = setup.tau;
  if (setup.solve_margin >= 0) o.solve_margin = setup.solve_margin;
  if (setup.cg_tolerance > 0) o.cg_tolerance = setup.cg_tolerance;
  return o;
}

namespace {

std::string box_text(int dim, const double lo[3], const double hi[3]) {
  std::string t;
  for (int k = 0; k < dim; ++k) {
    char b[48];
    std::snprintf(b, sizeof b, "%s%.0f m", k ? " x " : "", hi[k] - lo[k]);
    t += b;
  }
  return t;
}

}  // namespace

KernelMap learn_bhm(Context* ctx, const BhmSetup& setup, int dim, const double lo[3],
                    const double hi[3], const LabelledPoints& samples, double* spacing_out,
                    double* gamma_out, std::size_t* learner_bytes_out,
                    const std::function<void(const JointBhm&, std::int64_t scan)>& before_scan) {
  double spacing = setup.spacing;
  if (setup.count > 0) {
    double v = 1;
    for (int k = 0; k < dim; ++k) v *= std::max(hi[k] - lo[k], 1e-3);
    spacing = std::pow(v / double(setup.count), 1.0 / dim);
  }
  if (spacing_out) *spacing_out = spacing;
  if (setup.joint) {
    JointBhmOptions o = joint_bhm_options(setup);
    o.spacing = spacing;
    // The experiments' joint BHM covers the task's whole box: a long 3D drive's box holds
    // more kernels than it may (riverside-a's 2.4 km: billions at 1 m), which `potmap mapping`
    // maps a keyframe at a time with tiles made where samples are and retired behind.
    std::optional<JointBhm> bounded;
    try {
      bounded.emplace(dim, lo, hi, o);
    } catch (const ArgumentError& e) {
      throw ArgumentError(std::string(e.what()) + " over the task's box of " +
                          box_text(dim, lo, hi) +
                          (dim == 3 ? "; map a whole drive with potmap mapping DRIVE, or take "
                                      "fewer keyframes (--scans)"
                                    : "; take fewer scans (--scans) or a wider spacing"));
    }
    JointBhm& learner = *bounded;
    // With the context, as `potmap mapping` runs it: the solves' parts on the host team (the
    // same posterior bit for bit as on this thread alone), the final map's variances on every
    // core.
    std::function<void(std::int64_t)> before;
    if (before_scan) before = [&](std::int64_t t) { before_scan(learner, t); };
    learner.update_by_scan(setup.voxel > 0 ? aggregate_voxels(samples, setup.voxel) : samples, ctx,
                           before);
    if (gamma_out) *gamma_out = learner.gamma();
    if (learner_bytes_out) *learner_bytes_out = learner.memory_bytes();
    return learner.map(ctx);
  }
  const double gamma = setup.gamma > 0 ? setup.gamma : 8.0 / (spacing * spacing);
  if (gamma_out) *gamma_out = gamma;
  KernelMap map = bhm_grid_prior(dim, lo, hi, spacing, gamma, 0.0,
                                 setup.prior_var > 0 ? setup.prior_var : 1e4, setup.bias);
  bhm_update_sequential(ctx, map, samples, setup.options);
  if (learner_bytes_out)
    *learner_bytes_out = sizeof(double) * (map.position.size() + map.gamma.size() +
                                           map.w_mean.size() + map.w_var.size());
  return map;
}

Method bhm_method(const BhmSetup& setup, const std::string& name) {
  Method m;
  m.name = m.group = name;
  m.fit = [setup](Context* ctx, const MapTask& task) {
    const auto t0 = std::chrono::steady_clock::now();
    double spacing = 0, gamma = 0;
    std::size_t bytes = 0;
    LookAheadScorer ahead(task);
    std::function<void(const JointBhm&, std::int64_t)> before;
    if (ahead.active() && setup.joint)
      before = [&](const JointBhm& learner, std::int64_t scan) {
        ahead.before(scan, [&](const double* pts, std::size_t n, double* prob) {
          std::vector<double> var(n);
          learner.predict(pts, n, prob, var.data(), ctx);
          for (std::size_t i = 0; i < n; ++i) prob[i] = probit_probability(prob[i], var[i]);
        });
      };
    auto map = std::make_shared<KernelMap>(learn_bhm(ctx, setup, task.dim, task.lo, task.hi,
                                                     task.train, &spacing, &gamma, &bytes, before));
    const double secs = seconds_since(t0) - ahead.seconds();
    FittedMap f = kernel_fitted_map(ctx, map);
    f.fit_seconds = secs;
    if (before) f.lookahead = ahead.take();
    f.info["kernels"] = double(map->size());
    f.info["spacing_m"] = spacing;
    f.info["gamma"] = gamma;
    f.info["joint"] = setup.joint ? 1.0 : 0.0;
    f.info["memory_mb"] = double(bytes) / 1e6;
    return f;
  };
  return m;
}

Method abhm_method(const AbhmSetup& setup, const std::string& name) {
  Method m;
  m.name = m.group = name;
  m.fit = [setup](Context* ctx, const MapTask& task) {
    const auto t0 = std::chrono::steady_clock::now();
    AbhmParams p = abhm_init_halton(task.dim, task.lo, task.hi, setup.count, setup.gamma0);
    AbhmOptions o;
    o.steps = setup.steps;
    o.batch = setup.batch;
    o.seed = task.seed * 7919 + 1;
    o.report_every = 0;
    o.device = ctx;
    abhm_train(p, task.train, o);
    auto map = std::make_shared<KernelMap>(p.to_map());
    const double secs = seconds_since(t0);
    FittedMap f = kernel_fitted_map(ctx, map);
    f.fit_seconds = secs;
    f.info["kernels"] = double(map->size());
    f.info["steps"] = double(setup.steps);
    f.info["gamma0"] = setup.gamma0;
    return f;
  };
  return m;
}

std::vector<double> query_map(const FittedMap& map, const LabelledPoints& test,
                              double* query_seconds) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<double> prob(test.size());
  if (!test.empty()) map.query(test.position.data(), test.size(), prob.data(), nullptr);
  if (query_seconds) *query_seconds = seconds_since(t0);
  for (double& p : prob) p = std::min(1.0, std::max(0.0, p));  // float rounding past 1
  return prob;
}

Scores score_map(const FittedMap& map, const LabelledPoints& test, double* query_seconds) {
  return score(query_map(map, test, query_seconds), test.label);
}

}  // namespace potmap::experiment
