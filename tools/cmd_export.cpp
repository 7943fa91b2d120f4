// `potmap export ros|octomap MAP -o FILE`: a kernel map as other stacks load it.
#include <iostream>

#include "commands.hpp"
#include "octomap_export.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/io/ros_map.hpp"

namespace potmap::cli {

namespace {

// What both exports share: the unknown rule (io/known_cells.hpp) and the exact-sum switch.
void add_known_options(CLI::App* cmd, KnownRule& known, bool& cpu) {
  cmd->add_option("--min-support", known.min_support,
                  "Unknown where sum of phi^2 over the kernels is below this")
      ->capture_default_str();
  cmd->add_option("--unknown-variance", known.unknown_variance,
                  "Unknown where the phi^2-weighted mean weight variance is at least this")
      ->capture_default_str();
  cmd->add_flag("--cpu", cpu, "Exact CPU sum instead of the device");
}

}  // namespace

void register_export(CLI::App& app, Runner& runner) {
  CLI::App* exp = app.add_subcommand("export", "Write a map in another stack's format");
  exp->require_subcommand(1);

  CLI::App* ros = exp->add_subcommand(
      "ros",
      "ROS map_server / nav2 occupancy map: YAML + PGM (unknown where no kernel reaches or the "
      "kernels' weight variance is still the prior's; include/potmap/io/ros_map.hpp)");
  struct RosArgs {
    std::string map, out, mode = "trinary";
    std::vector<double> bounds;
    RosMapOptions o;
    bool cpu = false;
  };
  auto r = std::make_shared<RosArgs>();
  ros->add_option("MAP", r->map, "Kernel map (.potmap, .csv, .npz)")->required();
  ros->add_option("-o,--out", r->out, "YAML to write; the PGM goes beside it")->required();
  ros->add_option("--res", r->o.resolution, "Metres per pixel")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  ros->add_option("--bounds", r->bounds,
                  "Window xmin xmax ymin ymax, metres (default: the "
                  "kernels' bounds and a margin of 1 m)")
      ->expected(4);
  ros->add_option("--z", r->o.z, "Height of the slice of a 3D map, metres")->capture_default_str();
  ros->add_option("--mode", r->mode, "trinary or scale")
      ->capture_default_str()
      ->check(CLI::IsMember({"trinary", "scale"}));
  ros->add_option("--occupied-thresh", r->o.occupied_thresh, "Occupied above this probability")
      ->capture_default_str();
  ros->add_option("--free-thresh", r->o.free_thresh, "Free below this probability")
      ->capture_default_str();
  add_known_options(ros, r->o.known, r->cpu);
  auto device = add_device_option(ros);
  ros->callback([&runner, r, device] {
    runner.action = [r, device] {
      if (r->bounds.size() == 4) {
        r->o.xmin = r->bounds[0];
        r->o.xmax = r->bounds[1];
        r->o.ymin = r->bounds[2];
        r->o.ymax = r->bounds[3];
      }
      r->o.mode = r->mode == "scale" ? RosMapMode::scale : RosMapMode::trinary;
      const KernelMap map = read_map(r->map);
      std::unique_ptr<Context> ctx;
      if (!r->cpu) ctx = std::make_unique<Context>(make_context(*device));
      const RosMapSummary s = write_ros_map(ctx.get(), map, r->out, r->o);
      std::cout << "ROS map " << s.width << " x " << s.height << " at " << r->o.resolution
                << " m, origin [" << s.origin[0] << ", " << s.origin[1] << "]: " << s.occupied
                << " occupied, " << s.free << " free, " << s.unknown << " unknown\nwrote " << s.pgm
                << "\nwrote " << s.yaml << "\n";
      return 0;
    };
  });

  CLI::App* oct = exp->add_subcommand(
      "octomap",
      "OctoMap file: .bt (occupied and free voxels, as liboctomap writes them) or .ot (log-odds "
      "of every known voxel, through liboctomap); unknown voxels are left out "
      "(io/known_cells.hpp); a 2D map is one layer");
  struct OctArgs {
    std::string map, out;
    OctomapExportOptions o;
    bool cpu = false;
  };
  auto t = std::make_shared<OctArgs>();
  oct->add_option("MAP", t->map, "Kernel map (.potmap, .csv, .npz)")->required();
  oct->add_option("-o,--out", t->out, "OctoMap file to write (.bt or .ot)")->required();
  oct->add_option("--res", t->o.resolution, "Voxel edge, metres")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  oct->add_option("--z", t->o.z, "2D maps: height of the voxel layer, metres")
      ->capture_default_str();
  add_known_options(oct, t->o.known, t->cpu);
  auto odev = add_device_option(oct);
  oct->callback([&runner, t, odev] {
    runner.action = [t, odev] {
      const KernelMap map = read_map(t->map);
      std::unique_ptr<Context> ctx;
      if (!t->cpu) ctx = std::make_unique<Context>(make_context(*odev));
      const OctomapExportSummary s = write_octomap(ctx.get(), map, t->out, t->o);
      std::cout << "OctoMap at " << t->o.resolution << " m: " << s.occupied << " occupied, "
                << s.free << " free, " << s.unknown << " unknown voxels, " << s.leaves
                << " leaves\nwrote " << t->out << "\n";
      return 0;
    };
  });
}

}  // namespace potmap::cli
