// potmap eval: scores a map on labelled test points (accuracy, AUC, NLL; SPEC section 5).
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>

#include "commands.hpp"
#include "potmap/data/labelled_points.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "progress.hpp"

namespace potmap::cli {

namespace {

struct EvalArgs {
  std::string map;
  std::string test;
  std::string json;
  bool reference = false;
};

// NaN (AUC with one class) has no JSON number: it is written as null.
nlohmann::json number_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nullptr;
}

int run_eval(const EvalArgs& a, const std::string& device) {
  const bool json_stdout = a.json == "-";
  std::ostream& human = json_stdout ? std::cerr : std::cout;
  const auto t_load = std::chrono::steady_clock::now();
  const KernelMap map = read_map(a.map);
  const LabelledPoints test = read_labelled_csv(a.test);
  const double load_s = seconds_since(t_load);
  if (map.dim != test.dim)
    throw ArgumentError("the map " + a.map + " is " + std::to_string(map.dim) +
                        "D but the test points " + a.test + " are " + std::to_string(test.dim) +
                        "D");

  std::vector<double> prob;
  std::string device_name;
  const auto t_eval = std::chrono::steady_clock::now();
  if (a.reference) {
    device_name = "reference (exact double-precision sum on the CPU)";
    prob = evaluate_exact(map, test.position.data(), test.size()).prob;
  } else {
    Context ctx = make_context(device, true);
    device_name = ctx.info().summary();
    MapEvaluator ev(ctx, map);
    const MapValues v = ev.evaluate(test.position);
    prob.assign(v.prob.begin(), v.prob.end());
  }
  const double eval_s = seconds_since(t_eval);
  const Scores s = score(prob, test.label);

  std::size_t occupied = 0;
  for (auto l : test.label) occupied += l;
  human << "map     " << a.map << " (" << map.size() << " kernels, " << map.dim << "D"
        << (map.has_bias ? ", bias" : "") << ")\n"
        << "test    " << a.test << " (" << test.size() << " points, " << occupied << " occupied)\n"
        << "device  " << device_name << "\n"
        << std::fixed << std::setprecision(3) << "time    load " << load_s << " s, evaluate "
        << eval_s << " s (includes device set-up)\n"
        << std::setprecision(4) << "acc     " << s.acc << "   (p >= 0.5 counts as occupied)\n"
        << "auc     " << s.auc << "\n"
        << "nll     " << s.nll << "   (p clipped to [1e-6, 1 - 1e-6])\n"
        << "n       " << s.n << "\n";
  human.unsetf(std::ios::floatfield);

  if (!a.json.empty()) {
    nlohmann::json j = {{"acc", number_or_null(s.acc)},
                        {"auc", number_or_null(s.auc)},
                        {"nll", number_or_null(s.nll)},
                        {"n", s.n},
                        {"device", device_name},
                        {"map", a.map},
                        {"test", a.test},
                        {"kernels", map.size()},
                        {"load_seconds", load_s},
                        {"eval_seconds", eval_s}};
    if (json_stdout) {
      std::cout << j.dump(2) << "\n";
    } else {
      write_text_atomically(a.json, j.dump(2) + "\n");
    }
  }
  return 0;
}

}  // namespace

void register_eval(CLI::App& app, Runner& runner) {
  CLI::App* cmd = app.add_subcommand(
      "eval", "Score a map on labelled test points: accuracy, ROC AUC, mean NLL");
  auto args = std::make_shared<EvalArgs>();
  cmd->add_option("--map", args->map, "Map file (.csv, .npz or .potmap)")->required();
  cmd->add_option("--test", args->test, "Labelled test points, CSV t,x,y[,z],occupied")->required();
  cmd->add_option("--json", args->json,
                  "Also write the scores as JSON to this file; '-' for stdout (the readable "
                  "summary then goes to stderr)");
  cmd->add_flag("--reference", args->reference,
                "Use the exact double-precision CPU evaluator instead of the device");
  auto device = add_device_option(cmd);
  cmd->callback([&runner, args, device] {
    runner.action = [args, device] { return run_eval(*args, *device); };
  });
}

}  // namespace potmap::cli
