// `potmap demo`: the main job on a built-in default. With ../shared/data/carla present, the real
// Town 1 map learned by the paper's authors scored on its labelled test points; otherwise the
// built-in synthetic scene. Prints ACC/AUC/NLL and writes the map's pictures.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "demo_pot.hpp"
#include "potmap/data/labelled_points.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/map/synthetic.hpp"
#include "progress.hpp"

namespace fs = std::filesystem;

namespace potmap::cli {

namespace {

struct DemoArgs {
  std::string data = "../shared/data";
  std::string out;
  double res = 0;  // 0: each job's own (0.25 m for the authors' map)
  bool synthetic = false;
  std::string json;
};

int run_demo(const DemoArgs& a, const std::string& device) {
  Context ctx = make_context(device);
  const fs::path carla = fs::path(a.data) / "carla";
  const bool real = !a.synthetic && fs::exists(carla / "town1_test2k.csv") &&
                    (fs::exists(carla / "npz" / "town1_abhm_map.npz") ||
                     fs::exists(carla / "town1_abhm_map.csv"));
  KernelMap map;
  LabelledPoints test;
  double bounds[4];
  std::string name;
  if (real) {
    name = "town1";
    const fs::path npz = carla / "npz" / "town1_abhm_map.npz";
    const fs::path path = fs::exists(npz) ? npz : carla / "town1_abhm_map.csv";
    std::cerr << "potmap demo: real data: " << path.string() << " and "
              << (carla / "town1_test2k.csv").string() << "\n";
    map = read_map(path.string());
    test = read_labelled_csv((carla / "town1_test2k.csv").string());
    double lo[3], hi[3];
    map.bounds(lo, hi);
    bounds[0] = lo[0];
    bounds[1] = hi[0];
    bounds[2] = lo[1];
    bounds[3] = hi[1];
  } else {
    name = "synthetic";
    std::cerr << "potmap demo: no " << carla.string()
              << " found: using the built-in synthetic scene\n";
    SyntheticScene s = make_synthetic_scene();
    map = std::move(s.map);
    test = std::move(s.test);
    std::copy(s.bounds, s.bounds + 4, bounds);
  }
  if (test.dim != map.dim)
    throw InputError("demo: test points are " + std::to_string(test.dim) + "D but the map is " +
                     std::to_string(map.dim) + "D");

  auto t0 = std::chrono::steady_clock::now();
  MapEvaluator ev(ctx, map);
  MapValues v = ev.evaluate(test.position);  // includes building the kernels on first use
  const double t_first = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  v = ev.evaluate(test.position);
  const double t_eval = seconds_since(t0);
  const Scores sc = score(v.prob, test.label);

  // The exact double-precision sum at the same points, to show the device's error.
  const MapValuesExact ex = evaluate_exact(map, test.position.data(), test.size());
  double dp = 0;
  for (std::size_t i = 0; i < test.size(); ++i) dp = std::max(dp, std::abs(v.prob[i] - ex.prob[i]));

  // With --json -, stdout carries the JSON alone; the readable summary goes to stderr.
  std::FILE* human = a.json == "-" ? stderr : stdout;
  std::fprintf(human, "map        %s: %zu kernels, %dD\n", name.c_str(), map.size(), map.dim);
  std::fprintf(human, "test       %zu labelled points\n", test.size());
  std::fprintf(human, "ACC        %.4f\n", sc.acc);
  std::fprintf(human, "AUC        %.4f\n", sc.auc);
  std::fprintf(human, "NLL        %.4f   (p clipped to [1e-6, 1 - 1e-6])\n", sc.nll);
  std::fprintf(human, "max |dp|   %.2g   (device against the exact double sum)\n", dp);
  std::fprintf(human, "eval time  %.2f ms for %zu points (first call with kernel build: %.2f s)\n",
               t_eval * 1e3, test.size(), t_first);

  RasterSpec spec;
  spec.xmin = bounds[0];
  spec.xmax = bounds[1];
  spec.ymin = bounds[2];
  spec.ymax = bounds[3];
  spec.resolution = a.res;
  RasterOptions ro;
  ro.progress = terminal_progress("raster");
  const std::string prefix = a.out.empty() ? "out/demo/" + name : a.out;
  fs::create_directories(fs::path(prefix).parent_path().empty() ? "."
                                                                : fs::path(prefix).parent_path());
  const RasterSummary rs = rasterize(ctx, map, spec, prefix, ro);
  std::fprintf(human, "picture    %zu x %zu cells at %.2f m in %.2f s (%.1f M cells/s):\n",
               rs.width, rs.height, a.res, rs.seconds, rs.cells / rs.seconds / 1e6);
  for (const std::string& f : rs.files) std::fprintf(human, "           %s\n", f.c_str());

  if (!a.json.empty()) {
    nlohmann::json j = {{"map", name},           {"kernels", map.size()},
                        {"points", test.size()}, {"acc", sc.acc},
                        {"auc", sc.auc},         {"nll", sc.nll},
                        {"max_abs_dp", dp},      {"device", ctx.info().summary()},
                        {"files", rs.files}};
    if (a.json == "-") {
      std::cout << j.dump(1) << "\n";
    } else {
      write_text_atomically(a.json, j.dump(1) + "\n");
    }
  }
  return 0;
}

}  // namespace

void register_demo(CLI::App& app, Runner& runner) {
  CLI::App* cmd = app.add_subcommand(
      "demo",
      "The main job: build a dictionary of atoms on one built-in simulated town, map another by "
      "POT and RePOT, print ACC/AUC/NLL on held-out beams and write the map's pictures. With "
      "--authors-map: score the paper's Town 1 map (or a synthetic scene) instead");
  auto args = std::make_shared<DemoArgs>();
  auto pot = std::make_shared<PotDemoArgs>();
  auto authors = std::make_shared<bool>(false);
  auto device = add_device_option(cmd);
  cmd->add_flag("--authors-map", *authors,
                "Score the authors' Town 1 map on its test points (../shared/data/carla), or the "
                "built-in synthetic scene without it");
  cmd->add_option("--source", pot->source, "Town the atoms come from (default town1)");
  cmd->add_option("--target", pot->target, "Town to map (default town2)");
  cmd->add_option("--source-scans", pot->source_scans, "Scans of the source town (default 10)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--scans", pot->target_scans, "Scans of the target town (default 40)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--rotations", pot->rotations, "Rotations tried per atom (default 8)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--method", pot->method, "pot, repot or both (default both)");
  cmd->add_option("--map-defaults", pot->map_defaults,
                  "POT/RePOT with potmap map's settings (indexed ranking, kernels on the "
                  "scans' samples, averaged overall map, wall clearance 0.5 m); false: the "
                  "library's, the paper's rules")
      ->capture_default_str();
  cmd->add_option("--data", args->data,
                  "with --authors-map: folder holding carla/ (default ../shared/data)");
  cmd->add_option("--out", args->out,
                  "output prefix for the pictures (default out/demo/pot, or out/demo/town1 and "
                  "out/demo/synthetic with --authors-map)");
  cmd->add_option("--res", args->res,
                  "picture resolution, metres per cell (default: 1200 pixels along the long side; "
                  "0.25 with --authors-map)")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--synthetic", args->synthetic,
                "with --authors-map: the built-in synthetic scene even if data exists");
  cmd->add_option("--json", args->json, "also write the scores as JSON to this path ('-': stdout)");
  cmd->callback([&runner, args, pot, authors, device] {
    runner.action = [args, pot, authors, device] {
      if (*authors) {
        DemoArgs d = *args;
        if (d.res <= 0) d.res = 0.25;
        return run_demo(d, *device);
      }
      PotDemoArgs p = *pot;
      p.out = args->out;
      p.json = args->json;
      p.res = args->res;
      return run_pot_demo(p, *device);
    };
  });
}

}  // namespace potmap::cli
