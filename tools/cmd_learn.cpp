// `potmap learn bhm|abhm`: fit a kernel map to labelled samples over an area.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <vector>

#include "commands.hpp"
#include "dataset_samples.hpp"
#include "potmap/data/labelled_points.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/learn/abhm.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/learn/bhm_joint.hpp"

namespace potmap::cli {

namespace {

constexpr const char* kInputHelp =
    "Labelled samples (CSV t,x,y[,z],occupied or .npz) or any dataset `potmap data info` reads "
    "(CARMEN log, KITTI frame or sequence folder, nuScenes frame), labelled here";

struct AreaArgs {
  std::vector<double> bounds;  // xmin xmax ymin ymax [zmin zmax]; empty: the data's bounds
  double spacing = 1.0;
  std::size_t count = 0;
};

void add_area_options(CLI::App* cmd, AreaArgs& a) {
  cmd->add_option("--bounds", a.bounds,
                  "Area: xmin xmax ymin ymax [zmin zmax], metres (default: the data's bounds)")
      ->expected(4, 6);
  cmd->add_option("--spacing", a.spacing, "Kernel grid spacing, metres (default 1)");
  cmd->add_option("--count", a.count,
                  "Approximate number of kernels; overrides --spacing (default: unset)");
}

// Grid corners and spacing from the options and the data.
void resolve_area(const AreaArgs& a, const LabelledPoints& pts, double lo[3], double hi[3],
                  double& spacing) {
  const int dim = pts.dim;
  for (int d = 0; d < 3; ++d) lo[d] = hi[d] = 0;
  if (!a.bounds.empty()) {
    if (static_cast<int>(a.bounds.size()) != 2 * dim)
      throw ArgumentError("--bounds needs " + std::to_string(2 * dim) + " values for " +
                          std::to_string(dim) + "D data");
    for (int d = 0; d < dim; ++d) {
      lo[d] = a.bounds[2 * d];
      hi[d] = a.bounds[2 * d + 1];
    }
  } else {
    if (pts.empty()) throw InputError("no samples and no --bounds");
    for (int d = 0; d < dim; ++d) lo[d] = hi[d] = pts.position[d];
    for (std::size_t i = 0; i < pts.size(); ++i)
      for (int d = 0; d < dim; ++d) {
        lo[d] = std::min(lo[d], pts.position[i * dim + d]);
        hi[d] = std::max(hi[d], pts.position[i * dim + d]);
      }
  }
  spacing = a.spacing;
  if (a.count > 0) {
    double vol = 1;
    for (int d = 0; d < dim; ++d) vol *= std::max(hi[d] - lo[d], 1e-9);
    spacing = std::pow(vol / double(a.count), 1.0 / dim);
  }
}

struct BhmArgs {
  std::string input, output, prior;
  AreaArgs area;
  LabelArgs labels;
  std::string model = "joint";
  double gamma = 0.0, var0 = 0.0;
  int em = 3;
  bool sequential = false, cpu = false, bias = false, no_bias = false;
};

struct AbhmArgs {
  std::string input, output, checkpoint, params;
  AreaArgs area;
  LabelArgs labels;
  double gamma0 = 1.0;
  bool halton = false, cpu = false;
  std::size_t steps = 2450, batch = 256, report = 100;
  std::uint64_t seed = 1;
};

// The joint-posterior BHM of the samples on a grid (spacing: the model's unless given).
void learn_joint_bhm(const BhmArgs& b, const LabelledPoints& pts, bool spacing_given) {
  if (!b.prior.empty()) throw ArgumentError("--prior needs --model diagonal");
  AreaArgs area = b.area;
  if (!spacing_given) area.spacing = JointBhmOptions{}.spacing;
  double lo[3], hi[3], spacing;
  resolve_area(area, pts, lo, hi, spacing);
  JointBhmOptions o;
  o.spacing = spacing;
  o.gamma = b.gamma;
  if (b.var0 > 0) o.prior_var = b.var0;
  o.bias = !b.no_bias;
  o.em_iterations = b.em;
  JointBhm learner(pts.dim, lo, hi, o);
  std::cerr << "potmap: joint BHM over " << pts.size() << " samples, " << learner.size()
            << " kernels " << spacing << " m apart, gamma " << learner.gamma() << "\n";
  if (b.sequential)
    learner.update_by_scan(pts);
  else
    learner.update(pts);
  write_learned_map(&learner, learner.map(), b.output);
}

// The diagonal BHM of the samples, on a grid or a given prior map, on the device or the CPU.
void learn_diagonal_bhm(const BhmArgs& b, const LabelledPoints& pts, const std::string& device) {
  KernelMap map;
  if (!b.prior.empty()) {
    map = read_map(b.prior);
  } else {
    double lo[3], hi[3], spacing;
    resolve_area(b.area, pts, lo, hi, spacing);
    const double gamma = b.gamma > 0 ? b.gamma : 8.0 / (spacing * spacing);
    map = bhm_grid_prior(pts.dim, lo, hi, spacing, gamma, 0.0, b.var0 > 0 ? b.var0 : 1e4, b.bias);
  }
  std::cerr << "potmap: BHM over " << pts.size() << " samples, " << map.size() << " kernels\n";
  BhmOptions o;
  o.em_iterations = b.em;
  std::unique_ptr<Context> ctx;
  if (!b.cpu) ctx = std::make_unique<Context>(make_context(device));
  if (b.sequential)
    bhm_update_sequential(ctx.get(), map, pts, o);
  else if (ctx)
    bhm_update(*ctx, map, pts, o);
  else
    bhm_update_reference(map, pts, o);
  write_map(map, b.output);
}

// ABHM from a grid or a Halton start, on the device or the CPU.
void learn_abhm(const AbhmArgs& a, const std::string& device) {
  const LabelledPoints pts = read_samples(a.input, a.labels).train;
  double lo[3], hi[3], spacing;
  resolve_area(a.area, pts, lo, hi, spacing);
  AbhmParams p;
  if (a.halton) {
    if (a.area.count == 0) throw ArgumentError("--halton needs --count");
    p = abhm_init_halton(pts.dim, lo, hi, a.area.count, a.gamma0);
  } else {
    p = abhm_init_grid(pts.dim, lo, hi, spacing, a.gamma0);
  }
  std::cerr << "potmap: ABHM over " << pts.size() << " samples, " << p.size() << " kernels, "
            << a.steps << " steps\n";
  std::unique_ptr<Context> ctx;
  if (!a.cpu) ctx = std::make_unique<Context>(make_context(device));
  AbhmOptions o;
  o.steps = a.steps;
  o.batch = a.batch;
  o.seed = a.seed;
  o.report_every = a.report;
  o.checkpoint = a.checkpoint;
  o.device = ctx.get();
  o.progress = [](std::size_t step, double elbo) {
    std::fprintf(stderr, "potmap: step %zu ELBO %.3f\n", step, elbo);
  };
  abhm_train(p, pts, o);
  write_map(p.to_map(), a.output);
  if (!a.params.empty()) write_abhm_params(p, a.params);
}

void add_bhm(CLI::App* learn, Runner& runner) {
  CLI::App* bhm = learn->add_subcommand(
      "bhm", "Bayesian Hilbert map: kernels on a grid, weights by the Jaakkola-Jordan bound");
  auto b = std::make_shared<BhmArgs>();
  b->labels.labels.holdout_fraction = 0;
  bhm->add_option("input", b->input, kInputHelp)->required();
  bhm->add_option("-o,--output", b->output, "Map file to write")->required();
  bhm->add_option("--prior", b->prior,
                  "Map file used as prior instead of a grid (positions and widths kept)");
  add_area_options(bhm, b->area);
  bhm->add_option("--model", b->model,
                  "joint: the whole Jaakkola-Jordan posterior over overlapping kernels (default; "
                  "spacing 0.5 m, gamma -ln(0.19)/spacing^2, prior variance 10, bias weight: a "
                  "continuous, calibrated map); diagonal: one variance per kernel, narrow disjoint "
                  "kernels (spacing 1 m, gamma 8/spacing^2, prior variance 10000, no bias). "
                  "--prior needs diagonal")
      ->check(CLI::IsMember({"joint", "diagonal"}));
  bhm->add_option("--gamma", b->gamma,
                  "Kernel width of the grid, 1/m^2 (default: the model's, from the spacing)");
  bhm->add_option("--prior-var", b->var0,
                  "Prior weight variance (default: joint 10, diagonal 10000)");
  bhm->add_option("--em", b->em, "EM iterations (E-steps) per update (default 3)");
  bhm->add_flag("--bias", b->bias, "Diagonal model: add a bias weight");
  bhm->add_flag("--no-bias", b->no_bias, "Joint model: no bias weight");
  bhm->add_flag("--sequential", b->sequential,
                "Update scan by scan (column t), posterior of one the prior of the next");
  bhm->add_flag("--cpu", b->cpu, "Use the double-precision CPU reference instead of OpenCL");
  add_label_options(bhm, b->labels, "--label-seed");
  auto bdev = add_device_option(bhm);
  bhm->callback([&runner, b, bdev, bhm] {
    const bool spacing_given = bhm->count("--spacing") > 0;
    runner.action = [b, bdev, spacing_given] {
      const LabelledPoints pts = read_samples(b->input, b->labels).train;
      if (b->model == "joint")
        learn_joint_bhm(*b, pts, spacing_given);
      else
        learn_diagonal_bhm(*b, pts, *bdev);
      return 0;
    };
  });
}

void add_abhm(CLI::App* learn, Runner& runner) {
  CLI::App* abhm = learn->add_subcommand(
      "abhm", "Automorphing BHM: per-kernel position, width and weight by variational inference");
  auto a = std::make_shared<AbhmArgs>();
  a->labels.labels.holdout_fraction = 0;
  abhm->add_option("input", a->input, kInputHelp)->required();
  abhm->add_option("-o,--output", a->output, "Map file to write (means of q)")->required();
  add_area_options(abhm, a->area);
  abhm->add_flag("--halton", a->halton,
                 "Start kernels on a Halton sequence (needs --count) instead of a regular grid");
  abhm->add_option("--gamma0", a->gamma0, "Starting kernel width, 1/m^2 (default 1)");
  abhm->add_option("--steps,--iterations", a->steps, "Adam steps (default 2450)");
  abhm->add_option("--batch", a->batch, "Samples per minibatch (default 256)");
  abhm->add_option("--seed", a->seed, "Random seed (default 1)");
  abhm->add_option("--report", a->report, "Print the ELBO every this many steps (default 100)");
  abhm->add_option("--checkpoint", a->checkpoint,
                   "Checkpoint file: resumed from if it exists, written every 500 steps");
  abhm->add_option("--params", a->params,
                   "Also write the variational parameters (read_abhm_params reads them)");
  abhm->add_flag("--cpu", a->cpu, "Use the double-precision CPU reference instead of OpenCL");
  add_label_options(abhm, a->labels, "--label-seed");
  auto adev = add_device_option(abhm);
  abhm->callback([&runner, a, adev] {
    runner.action = [a, adev] {
      learn_abhm(*a, *adev);
      return 0;
    };
  });
}

}  // namespace

void register_learn(CLI::App& app, Runner& runner) {
  CLI::App* learn =
      app.add_subcommand("learn", "Learn a kernel map from labelled samples or scans");
  learn->require_subcommand(1);
  add_bhm(learn, runner);
  add_abhm(learn, runner);
}

}  // namespace potmap::cli
