// The potmap command: one subcommand per job, each in its own cmd_*.cpp.
#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>

#include "commands.hpp"
#include "interrupt.hpp"
#include "potmap/error.hpp"
#include "potmap/runtime/context.hpp"
#include "potmap/version.hpp"

int main(int argc, char** argv) {
  // Before anything loads PoCL (potmap/runtime/context.hpp says why).
  potmap::pin_pocl_workers();
  CLI::App app{"potmap: continuous occupancy maps by parameter optimal transport (OpenCL)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("potmap ") + POTMAP_VERSION_STRING);
  potmap::cli::Runner runner;
  potmap::cli::register_eval(app, runner);
  potmap::cli::register_devices(app, runner);
  potmap::cli::register_raster(app, runner);
  potmap::cli::register_demo(app, runner);
  potmap::cli::register_learn(app, runner);
  potmap::cli::register_data(app, runner);
  potmap::cli::register_map(app, runner);
  potmap::cli::register_mapping(app, runner);
  potmap::cli::register_export(app, runner);
  potmap::cli::register_merge(app, runner);
  potmap::cli::register_dict(app, runner);
  potmap::cli::register_experiment(app, runner);
  potmap::cli::register_experiment_frames(app, runner);
  potmap::cli::register_bench(app, runner);
  potmap::cli::register_tune(app, runner);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    return runner.run();
  } catch (const potmap::cli::Interrupted&) {
    std::cerr << "potmap: interrupted; files being written were removed (a checkpoint written "
                 "before stays for --resume)\n";
    return 130;
  } catch (const potmap::Error& e) {
    std::cerr << "potmap: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "potmap: internal error: " << e.what() << "\n";
    return 2;
  }
}
