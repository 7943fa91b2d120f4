#include <iostream>

#include "commands.hpp"
#include "user_cache.hpp"

namespace potmap::cli {

std::shared_ptr<std::string> add_device_option(CLI::App* cmd) {
  auto dev = std::make_shared<std::string>();
  cmd->add_option("--device", *dev,
                  "OpenCL device: substring of the platform's name or vendor or the device's name "
                  "(default: POTMAP_DEVICE, "
                  "else first GPU, else first CPU)");
  return dev;
}

Context make_context(const std::string& device, bool quiet) {
  ContextOptions o;
  o.device = device;
  o.binary_cache_dir = kernel_cache_dir();
  Context ctx(o);
  if (!quiet) std::cerr << "potmap: device: " << ctx.info().summary() << "\n";
  return ctx;
}

void register_devices(CLI::App& app, Runner& runner) {
  CLI::App* cmd = app.add_subcommand("devices", "List the OpenCL devices potmap can use");
  cmd->callback([&runner] {
    runner.action = [] {
      const auto devices = list_devices();
      if (devices.empty()) {
        std::cout << "no OpenCL devices\n";
        return 1;
      }
      for (const DeviceInfo& d : devices)
        std::cout << (d.is_gpu   ? "GPU "
                      : d.is_cpu ? "CPU "
                                 : "ACC ")
                  << d.summary() << ", " << d.compute_units << " compute units, "
                  << (d.global_mem_bytes >> 20) << " MiB" << (d.has_fp64 ? ", fp64" : "") << "\n";
      return 0;
    };
  });
}

}  // namespace potmap::cli
