// `potmap mapping LOG`: the library's mapping job (potmap/job/mapping_job.hpp) from the command
// line: its options, its account and progress printed, the files listed.
#include <nlohmann/json.hpp>

#include <cstdio>

#include "commands.hpp"
#include "default_dictionary.hpp"
#include "interrupt.hpp"
#include "mapping_ranks.hpp"
#include "potmap/job/mapping_job.hpp"
#include "progress.hpp"

namespace potmap::cli {

namespace {

struct MappingArgs {
  std::string log, json;
  bool quiet = false;
  MappingJobOptions job;
};

// Under mpirun (a build with MPI) every rank maps its part and rank 0 merges them.
int run_mapping(const MappingArgs& args, const std::string& device) {
  const InterruptScope interrupts;  // Ctrl-C: stop at the next scan or keyframe, files whole
  MappingRanks ranks;
  return ranks.guard([&] {
    MappingJobOptions o = args.job;
    if (o.out.empty()) o.out = default_mapping_folder(args.log);
    std::FILE* human = args.json == "-" || ranks.rank() > 0 ? stderr : stdout;
    MappingJobHooks hooks = printing_hooks(human, args.quiet);
    hooks.ranks = &ranks;
    // Built when missing, with its notes and a progress bar.
    hooks.default_dictionary = [](int dim, std::string* where) {
      return default_dictionary(where, dim);
    };
    Context ctx = make_context(ranks.device(device));
    const MappingJobResult r = run_mapping_job(ctx, args.log, o, hooks);
    if (r.wrote) list_job_files(r, args.json, human);
    return 0;
  });
}

}  // namespace

void register_mapping(CLI::App& app, Runner& runner) {
  CLI::App* cmd = app.add_subcommand(
      "mapping",
      "From a raw log to a map in one command: the scans mapped by RePOT with the built-in "
      "dictionary (or --dict), written as DIR/map.potmap, pictures DIR/map_{prob,var,kernels}.png, "
      "a ROS map DIR/map.yaml + map.pgm and DIR/scores.json (held-out beams). A 3D drive folder is "
      "mapped by the joint BHM a keyframe at a time into DIR/map.potmap, an OctoMap DIR/map.bt, "
      "the occupied voxels DIR/map_occupied.ply, a height band's pictures DIR/map_band_*.png and "
      "ROS map DIR/map_band.yaml, and DIR/scores.json (docs/drives-3d.md). Under mpirun "
      "(`mpirun -n N potmap mapping LOG`, a build with MPI) each rank maps a contiguous part of "
      "the scans or keyframes (a drive's with every tile kept) and rank 0 merges the ranks' maps "
      "in information form and writes the outputs, scored on every scan's held-out beams "
      "(docs/mapping-ranks.md)");
  auto a = std::make_shared<MappingArgs>();
  auto device = add_device_option(cmd);
  cmd->add_option("LOG", a->log,
                  "Any dataset potmap reads: a 2D log (CARMEN), or a 3D drive folder (SLAM "
                  "keyframes Scans/*.pcd + odom_poses.txt, or a KITTI sequence)")
      ->required();
  cmd->add_option("-o,--out", a->job.out, "Output folder (default out/mapping/<log name>)");
  cmd->add_option("--dict", a->job.dictionary, "Dictionary of atoms (default: the built-in one)");
  cmd->add_option("--method", a->job.method,
                  "2D logs: repot (default: POT's transport refined by a persistent joint BHM) "
                  "or pot; 3D drives: bhm (default: the joint BHM at the drive defaults) or repot "
                  "(that BHM seeded by POT's transport from the built-in 3D dictionary, or "
                  "--dict, where no sample reaches)");
  cmd->add_option("--range-cut", a->job.range_cut,
                  "Returns farther than this (metres, horizontally in 3D) become no-returns "
                  "(default: 20 for 2D logs, the towns' range, which the default dictionary's "
                  "atoms are cut at; 40 for 3D drives, a car's road and the buildings beside it; "
                  "0: none)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--poses", a->job.poses,
                  "3D drives: odom (odom_poses.txt), optimized (optimized_poses.txt) or auto")
      ->check(CLI::IsMember({"odom", "optimized", "auto"}))
      ->capture_default_str();
  cmd->add_option("--band", a->job.band_low,
                  "3D drives: the pictures' and ROS map's height band starts this many metres "
                  "about the sensor's height")
      ->capture_default_str();
  cmd->add_option("--band-top", a->job.band_high, "3D drives: and ends this many metres about it")
      ->capture_default_str();
  cmd->add_option("--voxel", a->job.voxel,
                  "3D drives: voxel edge of the OctoMap, point cloud and band, metres")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--transfer-every", a->job.transfer_every,
                  "3D drives, --method repot: transfer every N keyframes (seeds last until data "
                  "reaches them)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--keep-tiles", a->job.keep_tiles,
                "3D drives: keep every tile of the joint BHM (memory grows with the drive) so "
                "that map.potmap carries its information form for `potmap merge`");
  cmd->add_flag("--lookahead", a->job.lookahead,
                "Score each keyframe's (2D logs: scan's, RePOT only) held-out samples on the map "
                "before it is added, all of them and those beyond every earlier sample's reach "
                "(what transfer is for: a prior where the sensor has not been); in scores.json");
  cmd->add_option("--sums", a->job.sums,
                  "3D drives: where the joint BHM's features and sums run: auto (the device "
                  "when it is a GPU with doubles, else the host), host or device")
      ->check(CLI::IsMember({"auto", "host", "device"}))
      ->capture_default_str();
  cmd->add_option("--checkpoint-every", a->job.checkpoint_every,
                  "3D drives: write DIR/map.ckpt after every N keyframes (default 0: not by "
                  "count)")
      ->capture_default_str();
  cmd->add_option("--checkpoint-seconds", a->job.checkpoint_seconds,
                  "3D drives: and when T seconds have passed since the last one (default 30; 0: "
                  "not by time). With both 0 no checkpoint is written")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--export-every", a->job.export_every,
                  "3D drives: also write DIR/map.bt, map_occupied.ply and the band's files of the "
                  "map so far after every N keyframes, for a planner reading them while the drive "
                  "goes on (each file replaced whole; 0: only at the end)")
      ->capture_default_str();
  cmd->add_flag("--resume", a->job.resume,
                "3D drives: continue from DIR/map.ckpt when it is there");
  cmd->add_flag("--keep-checkpoint", a->job.keep_checkpoint,
                "3D drives: keep DIR/map.ckpt after the run");
  add_bag_options(cmd, a->job.bag);
  cmd->add_option("--first", a->job.first, "Skip this many scans")->capture_default_str();
  cmd->add_option("--max-scans", a->job.max_scans, "Map at most this many scans (0: all)")
      ->capture_default_str();
  cmd->add_option("--preset", a->job.preset,
                  "2D logs: default (the library's defaults, which map real logs best) or paper "
                  "(the authors' rules: exhaustive ranking, barycentric kernels summed with "
                  "merging, no wall clearance; MapperOptions::paper())")
      ->check(CLI::IsMember({"default", "paper"}))
      ->capture_default_str();
  cmd->add_option("--ranking", a->job.ranking,
                  "exhaustive: every atom at every rotation (the paper's); indexed: nearest "
                  "atoms by signature at estimated rotations, coarse to fine (potmap map's "
                  "--ranking; default: the preset's, indexed for default, exhaustive for paper)")
      ->check(CLI::IsMember({"exhaustive", "indexed"}));
  cmd->add_option("--rotations", a->job.rotations, "Rotations tried per atom")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--ros-res", a->job.ros_resolution,
                  "ROS map resolution, metres per pixel (3D drives: the band's map is at --voxel)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--picture-pixels", a->job.picture_pixels, "Pixels along the pictures' long side")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--seed", a->job.seed, "Seed of labelling, hold-out and subsampling")
      ->capture_default_str();
  cmd->add_option("--json", a->json, "'-': also print the summary as JSON on stdout");
  add_seed_rule_flag(cmd, &a->job.seeds_yield_fully);
  add_half_life_option(cmd, &a->job.half_life);
  cmd->add_flag("-q,--quiet", a->quiet, "No line per scan (a progress bar on a terminal)");
  cmd->callback(
      [&runner, a, device] { runner.action = [a, device] { return run_mapping(*a, *device); }; });
}

}  // namespace potmap::cli
