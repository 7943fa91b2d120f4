// potmap data info FILE | data label DATA -o CSV | data simulate --town NAME --seed S --out DIR
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <sstream>

#include "commands.hpp"
#include "dataset_samples.hpp"
#include "potmap/data/bag.hpp"
#include "potmap/data/drive.hpp"
#include "potmap/data/labelled_points.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "town_picture.hpp"

namespace potmap::cli {

namespace {

// A drive is summarised from its index and its keyframes read one at a time (a long drive
// does not fit in memory as one Dataset).
int drive_info(const std::string& dir) {
  const Drive d = open_drive(dir);
  const DriveSummary s = summarise_drive(d);
  auto fixed = [](double v, int p) {
    std::ostringstream o;
    o.setf(std::ios::fixed);
    o.precision(p);
    o << v;
    return o.str();
  };
  std::cout << "drive: " << dir << " ("
            << (d.layout == "slam" ? "SLAM keyframes" : "KITTI sequence") << ")\n";
  std::cout << "poses: " << d.poses_file << "\n";
  std::cout << "dimension: 3\n";
  std::cout << "scans: " << s.keyframes << "\n";  // the key 2D datasets print too
  std::cout << "points: " << s.points << " (" << s.min_points << " to " << s.max_points
            << " a keyframe)\n";
  std::cout << "path: " << fixed(s.path_length, 1) << " m (median step " << fixed(s.median_step, 2)
            << " m, largest " << fixed(s.largest_step, 2) << " m)\n";
  if (d.has_times)
    std::cout << "duration: " << fixed(s.duration, 1) << " s\n";
  else
    std::cout << "duration: unknown (no times.txt; keyframe indices stand for time)\n";
  std::cout << "field of view: " << fixed(s.azimuth_span, 0) << " deg azimuth, "
            << fixed(s.elevation_min, 1) << " to " << fixed(s.elevation_max, 1)
            << " deg elevation\n";
  std::cout << "return ranges (m): median " << fixed(s.range_median, 1) << ", 99 % below "
            << fixed(s.range_p99, 1) << "\n";
  std::cout << "sensor positions (m): x [" << fixed(s.lo[0], 1) << ", " << fixed(s.hi[0], 1)
            << "] y [" << fixed(s.lo[1], 1) << ", " << fixed(s.hi[1], 1) << "] z ["
            << fixed(s.lo[2], 1) << ", " << fixed(s.hi[2], 1) << "]\n";
  return 0;
}

int scans_info(const std::string& file, const Dataset& ds);

std::string seconds_text(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", s);
  return b;
}

// A bag: what its storage holds, what would be mapped and from which poses, then (for laser
// scans) the scans' summary; a cloud topic's keyframes are summarised as a drive's.
int bag_info(const std::string& file, const BagOptions& o) {
  const BagSummary s = summarise_bag(file, o);
  std::cout << "bag: " << file << " (" << s.format << ", compression " << s.compression << ")\n";
  std::cout << "time span: " << seconds_text(s.duration) << " s from " << seconds_text(s.start)
            << "\n";
  std::cout << "topics:\n";
  for (const BagTopicSummary& t : s.topics)
    std::cout << "  " << t.name << "  " << t.type << "  " << t.count << " messages"
              << (t.frame_id.empty() ? "" : "  frame " + t.frame_id) << "\n";
  std::cout << "mapped topic: " << s.topic << " (" << s.type << ", " << s.dim << "D)\n";
  std::cout << "pose source: " << s.pose_source
            << (o.fixed_frame.empty() ? "" : " (fixed frame " + o.fixed_frame + ")") << "\n";
  if (s.dim == 3) {
    DriveOptions d;
    d.bag = o;
    const Drive drive = open_drive(file, d);
    std::cout << "keyframes: " << drive.size() << " (every " << o.keyframe_distance << " m or "
              << o.keyframe_angle << " rad), poses from " << drive.poses_file << "\n";
    return 0;
  }
  return scans_info(file, read_dataset(file, o));
}

int data_info(const std::string& file, const BagOptions& bag) {
  if (is_bag(file)) return bag_info(file, bag);
  if (is_drive(file)) return drive_info(file);
  return scans_info(file, read_dataset(file));
}

int scans_info(const std::string& file, const Dataset& ds) {
  std::size_t bmin = std::numeric_limits<std::size_t>::max(), bmax = 0, hits = 0, none = 0;
  double rmin = HUGE_VAL, rmax = 0, maxr_lo = HUGE_VAL, maxr_hi = 0;
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  int dim = ds.scans.empty() ? 0 : ds.scans[0].dim;
  for (const Scan& s : ds.scans) {
    bmin = std::min(bmin, s.num_beams());
    bmax = std::max(bmax, s.num_beams());
    hits += s.num_hits();
    none += s.num_no_return();
    maxr_lo = std::min(maxr_lo, s.max_range);
    maxr_hi = std::max(maxr_hi, s.max_range);
    const auto o = s.origin();
    for (std::size_t i = 0; i < s.num_hits(); ++i) {
      double r2 = 0;
      for (int k = 0; k < s.dim; ++k) {
        const double v = s.hits[i * s.dim + k];
        lo[k] = std::min(lo[k], v);
        hi[k] = std::max(hi[k], v);
        r2 += (v - o[k]) * (v - o[k]);
      }
      rmin = std::min(rmin, std::sqrt(r2));
      rmax = std::max(rmax, std::sqrt(r2));
    }
  }
  std::cout << "file: " << file << "\n";
  std::cout << "scans: " << ds.scans.size() << "\n";
  if (ds.scans.empty()) return 0;
  std::cout << "dimension: " << dim << "\n";
  std::cout << "beams per scan: " << bmin;
  if (bmax != bmin) std::cout << " to " << bmax;
  std::cout << "\nhits: " << hits << "\nno-return beams: " << none << "\n";
  std::cout << "hit ranges (m): " << rmin << " to " << rmax << "\n";
  std::cout << "max range (m): " << maxr_lo;
  if (maxr_hi != maxr_lo) std::cout << " to " << maxr_hi;
  std::cout << "\nbounds (m):";
  for (int k = 0; k < dim; ++k)
    std::cout << " "
              << "xyz"[k] << " [" << lo[k] << ", " << hi[k] << "]";
  std::cout << "\nlines skipped: " << ds.stats.lines_skipped << "\n";
  std::cout << "points dropped (NaN/Inf): " << ds.stats.points_dropped << "\n";
  if (ds.stats.stamps_replaced)
    std::cout << "timestamps: the log's do not advance from most scans to the next; the "
              << ds.stats.stamps_replaced << " scans are timed by their index\n";
  return 0;
}

}  // namespace

void register_data(CLI::App& app, Runner& runner) {
  CLI::App* data = app.add_subcommand("data", "Inspect LIDAR datasets and simulate towns");
  data->require_subcommand(1);

  CLI::App* info = data->add_subcommand(
      "info",
      "Summarise a dataset (CARMEN .log[.gz], KITTI/nuScenes .bin, a 3D drive folder: SLAM "
      "keyframes Scans/*.pcd + odom_poses.txt or a KITTI sequence; .pcd/.ply, .npz, labelled "
      ".csv; a ROS 1 .bag or ROS 2 bag folder: its topics and what would be mapped)");
  auto file = std::make_shared<std::string>();
  auto bag = std::make_shared<BagOptions>();
  info->add_option("FILE", *file, "dataset file")->required();
  add_bag_options(info, *bag);
  info->callback(
      [&runner, file, bag] { runner.action = [file, bag] { return data_info(*file, *bag); }; });

  CLI::App* label = data->add_subcommand(
      "label",
      "Write the labelled samples of a dataset (t,x,y[,z],occupied CSV, as `learn` reads): "
      "hits occupied, free samples along every beam, a fraction of the beams held out");
  struct LabelCmd {
    std::string input, output, test;
    LabelArgs args;
  };
  auto lc = std::make_shared<LabelCmd>();
  lc->args.labels.holdout_fraction = 0;
  label->add_option("DATA", lc->input, "any dataset `potmap data info` reads")->required();
  label->add_option("-o,--out", lc->output, "samples to learn from (CSV)")->required();
  label->add_option("--test", lc->test, "also write the held-out samples here (CSV)");
  add_label_options(label, lc->args, "--seed");
  label->callback([&runner, lc] {
    runner.action = [lc] {
      if (lc->args.labels.holdout_fraction > 0 && lc->test.empty())
        throw ArgumentError("data label: --holdout " +
                            std::to_string(lc->args.labels.holdout_fraction) +
                            " needs --test FILE for the held-out samples");
      const LabelledSplit split = read_samples(lc->input, lc->args);
      write_labelled_csv(split.train, lc->output);
      std::cout << "wrote " << lc->output << " (" << split.train.size() << " samples)\n";
      if (!lc->test.empty()) {
        write_labelled_csv(split.test, lc->test);
        std::cout << "wrote " << lc->test << " (" << split.test.size() << " held-out samples)\n";
      }
      if (split.points_dropped)
        std::cout << "points dropped (NaN/Inf): " << split.points_dropped << "\n";
      return 0;
    };
  });

  CLI::App* sim = data->add_subcommand(
      "simulate",
      "Simulate a drive through a built-in town. Writes DIR/scans.log (2D, CARMEN ROBOTLASER1) "
      "or DIR/velodyne/*.bin + poses.txt + calib.txt (3D, KITTI layout), DIR/town.png, and "
      "labelled "
      "samples DIR/train.csv and DIR/test.csv (20 % of beams held out)");
  auto town = std::make_shared<std::string>("town1");
  auto out = std::make_shared<std::string>();
  auto seed = std::make_shared<std::uint64_t>(0);
  auto opt = std::make_shared<SimOptions>();
  sim->add_option("--town", *town, "town1, town2 or town3")->capture_default_str();
  sim->add_option("--seed", *seed, "seed of the town, route and traffic")->capture_default_str();
  sim->add_option("--out", *out, "output folder")->required();
  sim->add_option("--scans", opt->scans, "number of scans")->capture_default_str();
  sim->add_option("--spacing", opt->spacing, "metres between scans")->capture_default_str();
  sim->add_option("--range", opt->max_range, "sensor range, metres")->capture_default_str();
  sim->add_option("--moving", opt->moving_vehicles, "moving vehicles")->capture_default_str();
  sim->add_flag("--3d", opt->three_d, "16-channel 3D sensor instead of a 2D ring");
  sim->callback([&runner, town, out, seed, opt] {
    runner.action = [town, out, seed, opt] {
      const Town t = Town::builtin(*town, *seed);
      opt->seed = *seed;
      const Simulation s = simulate(t, *opt);
      const std::string main_file = write_simulation(s, *opt, *out);
      const std::string png = (std::filesystem::path(*out) / "town.png").string();
      write_true_town(t, *town, s.route, png);
      // Labelled samples (SPEC section 1) beside the scans: train.csv for learning, test.csv
      // with the held-out 20 % of beams, in the `t,x,y[,z],occupied` format every reader takes.
      LabelOptions lo;
      lo.seed = *seed;
      const LabelledSplit split = label_scans(s.scans, lo);
      const std::string train = (std::filesystem::path(*out) / "train.csv").string();
      const std::string test = (std::filesystem::path(*out) / "test.csv").string();
      write_labelled_csv(split.train, train);
      write_labelled_csv(split.test, test);
      std::cout << "scans: " << s.scans.size() << "\n"
                << "wrote " << main_file << "\nwrote " << png << "\nwrote " << train << " ("
                << split.train.size() << " samples)\nwrote " << test << " (" << split.test.size()
                << " held-out samples)\n";
      return 0;
    };
  });
}

}  // namespace potmap::cli
