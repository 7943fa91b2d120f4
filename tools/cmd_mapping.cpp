// `potmap mapping LOG`: from a raw log to the map, its pictures, a ROS map and the scores, with
// the library's defaults (MapperOptions{}: the settings that map the real logs, as the
// experiments' PotSetup) and the default dictionary.
#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>

#include "commands.hpp"
#include "dataset_samples.hpp"
#include "default_dictionary.hpp"
#include "drive_mapping.hpp"
#include "map_pictures.hpp"
#include "map_pipeline.hpp"
#include "mapping_merge.hpp"
#include "mapping_ranks.hpp"
#include "potmap/data/drive.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/io/ros_map.hpp"
#include "potmap/learn/bhm_joint_merge.hpp"
#include "potmap/pot/dictionary_io.hpp"
#include "progress.hpp"

namespace fs = std::filesystem;

namespace potmap::cli {

namespace {

struct MappingArgs {
  // method "": by the input; ranking "": the preset's; preset: 2D logs' MapperOptions
  std::string log, out, dict, method, json, ranking, preset = "default";
  double range_cut = -1, ros_res = 0.05;  // range_cut -1: 20 m in 2D, 40 m for a 3D drive
  std::size_t first = 0, max_scans = 0, picture_pixels = 1200;
  int rotations = 8;
  std::uint64_t seed = 0;
  double half_life = 0;  // seconds of the scans' time (0: never forget)
  bool quiet = false, seeds_yield_fully = true;
  DriveMappingArgs drive;  // 3D drives: what differs
};

std::string default_out(const std::string& log) {
  std::string stem = fs::path(log).filename().string();
  for (const char* ext : {".gz", ".log", ".txt", ".bag", ".db3"})
    if (stem.size() > std::strlen(ext) && stem.substr(stem.size() - std::strlen(ext)) == ext)
      stem.resize(stem.size() - std::strlen(ext));
  if (stem.empty() || stem == "poses" || stem == "metadata.yaml")
    stem = fs::path(log).parent_path().filename().string();
  return (fs::path("out") / "mapping" / stem).string();
}

// A 3D drive goes to the joint BHM's drive job with the options it shares.
int run_drive(const MappingArgs& a, const std::string& device, MappingRanks& ranks) {
  DriveMappingArgs d = a.drive;
  d.drive = a.log;
  d.out = a.out;
  d.json = a.json;
  d.range_cut = a.range_cut > 0 ? a.range_cut : 40;
  d.first = a.first;
  d.max_keyframes = a.max_scans;
  d.seed = a.seed;
  d.quiet = a.quiet;
  d.picture_pixels = a.picture_pixels;
  d.method = a.method.empty() ? "bhm" : a.method;
  d.dict = a.dict;
  d.half_life = a.half_life;
  return run_drive_mapping(d, device, ranks);
}

int map_log(const MappingArgs& args, const std::string& device, MappingRanks& ranks) {
  DriveOptions probe;
  probe.bag = args.drive.bag;
  if (is_drive(args.log, probe)) {
    if (args.preset != "default") throw ArgumentError("mapping: --preset is for 2D logs");
    return run_drive(args, device, ranks);
  }
  MappingArgs a = args;
  if (a.method.empty()) a.method = "repot";
  if (a.method != "pot" && a.method != "repot")
    throw ArgumentError("mapping: --method must be pot or repot, not '" + a.method + "'");
  if (a.half_life > 0 && a.method != "repot")
    throw ArgumentError(
        "mapping: --half-life fades RePOT's persistent joint BHM; POT's averaged "
        "map does not forget (--method repot)");
  const std::string dir = a.out.empty() ? default_out(a.log) : a.out;
  if (ranks.rank() == 0) fs::create_directories(dir);
  std::FILE* human = a.json == "-" || ranks.rank() > 0 ? stderr : stdout;

  const double range_cut = a.range_cut < 0 ? 20 : a.range_cut;
  std::vector<Scan> all = read_scans(a.log, range_cut, a.drive.bag);
  if (a.first >= all.size())
    throw ArgumentError("mapping: --first " + std::to_string(a.first) + " but " + a.log + " has " +
                        std::to_string(all.size()) + " scans");
  std::vector<Scan> scans(all.begin() + static_cast<long>(a.first), all.end());
  if (a.max_scans > 0 && scans.size() > a.max_scans) scans.resize(a.max_scans);
  const std::size_t selected = scans.size();
  const RankPart part = ranks.part(0, selected, "scans");  // all of them on one process
  scans.resize(part.end);
  std::string dict_file = a.dict;
  const Dictionary dict = a.dict.empty() ? default_dictionary(&dict_file) : read_dictionary(a.dict);
  if (scans.front().dim != dict.dim)
    throw ArgumentError("mapping: " + a.log + " holds " + std::to_string(scans.front().dim) +
                        "D scans, the dictionary " + dict_file + " is " + std::to_string(dict.dim) +
                        "D");

  // The library's defaults are the settings that map the real logs (docs/methods.md);
  // --preset paper the authors' rules.
  MapJob job;
  job.mapper = a.preset == "paper" ? MapperOptions::paper() : MapperOptions{};
  job.mapper.pot.refine = a.method == "repot";
  job.mapper.pot.seed = a.seed;
  if (!a.ranking.empty())
    job.mapper.pot.ranking = a.ranking == "indexed" ? PotRanking::indexed : PotRanking::exhaustive;
  job.mapper.pot.rotations = evenly_spaced_rotations(a.rotations);
  job.mapper.refine_map.seeds_yield_fully = a.seeds_yield_fully;
  job.mapper.refine_map.half_life = a.half_life;
  job.mapper.labels.seed = a.seed;
  job.verbose = !a.quiet;
  job.start_at = part.begin;
  if (ranks.size() > 1) check_rank_mergeable(job.mapper);

  Context ctx = make_context(device);
  std::fprintf(human, "mapping        %zu scans of %s (cut at %g m), %s, %zu atoms of %s\n",
               selected, a.log.c_str(), range_cut, a.method == "repot" ? "RePOT" : "POT",
               dict.size(),
               a.dict.empty() ? ("the default dictionary " + dict_file).c_str() : a.dict.c_str());
  if (ranks.size() > 1)
    std::fprintf(human, "rank           %d of %d: scans %zu-%zu\n", ranks.rank(), ranks.size(),
                 part.begin, part.end - 1);
  MapJobResult r = run_map_job(&ctx, dict, scans, job);
  if (ranks.size() > 1 && !merge_rank_maps(ranks, &ctx, part, r)) return 0;
  const KernelMap& map = r.overall_map();
  if (map.empty()) throw InputError("mapping: " + a.log + " gave an empty map");
  const std::string map_file = (fs::path(dir) / "map.potmap").string();
  // With what merging needs (RePOT: the joint BHM's information form; POT: the averaged map's
  // anchor sums), so that maps of the same place made apart can be merged (`potmap merge`).
  r.write_overall_map(map_file);
  const std::string prefix = (fs::path(dir) / "map").string();
  const double z = dict.dim == 3 ? scans.front().origin()[2] : 0;
  const double res = picture_resolution(map, 5, a.picture_pixels);
  const MapPictures pics = write_map_pictures(ctx, map, prefix, res, 5, z);
  RosMapOptions ro;
  ro.resolution = a.ros_res;
  ro.z = z;
  const RosMapSummary ros = write_ros_map(&ctx, map, prefix + ".yaml", ro);

  std::fprintf(human,
               "held-out beams ACC %.4f  AUC %.4f  NLL %.4f  (%zu samples, 20 %% of every "
               "scan's beams, never mapped)\n",
               r.overall_scores.acc, r.overall_scores.auc, r.overall_scores.nll,
               r.overall_scores.n);
  std::fprintf(human, "map            %zu kernels, %.1f MB, %.1f ms per scan -> %s\n",
               r.overall_kernels(), r.overall_memory_bytes() / 1e6, r.mean_wall_ms,
               map_file.c_str());
  std::fprintf(human, "pictures       %zu x %zu at %.3f m per pixel\n", pics.width, pics.height,
               pics.resolution);
  std::fprintf(human, "ROS map        %zu x %zu at %.3f m: %zu occupied, %zu free, %zu unknown\n",
               ros.width, ros.height, ro.resolution, ros.occupied, ros.free, ros.unknown);
  std::vector<std::string> files = {map_file};
  files.insert(files.end(), pics.files.begin(), pics.files.end());
  files.push_back(ros.yaml);
  files.push_back(ros.pgm);

  nlohmann::json j = r.to_json();
  j["log"] = a.log;
  j["method"] = a.method == "repot" ? "RePOT" : "POT";
  j["ranking"] = job.mapper.pot.ranking == PotRanking::indexed ? "indexed" : "exhaustive";
  if (a.preset != "default") j["preset"] = a.preset;
  j["seed_rule"] = a.seeds_yield_fully ? "yield-fully" : "keep-start";
  j["dictionary"] = a.dict.empty() ? "default: " + default_dictionary_recipe() : a.dict;
  j["range_cut"] = range_cut;
  j["half_life_s"] = a.half_life;
  j["device"] = ctx.info().summary();
  write_scores_and_list(dir, j, files, a.json, human);
  return 0;
}

// Under mpirun (a build with MPI) every rank maps its part and rank 0 merges them.
int run_mapping(const MappingArgs& args, const std::string& device) {
  MappingRanks ranks;
  return ranks.guard([&] { return map_log(args, ranks.device(device), ranks); });
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
  cmd->add_option("-o,--out", a->out, "Output folder (default out/mapping/<log name>)");
  cmd->add_option("--dict", a->dict, "Dictionary of atoms (default: the built-in one)");
  cmd->add_option("--method", a->method,
                  "2D logs: repot (default: POT's transport refined by a persistent joint BHM) "
                  "or pot; 3D drives: bhm (default: the joint BHM at the drive defaults) or repot "
                  "(that BHM seeded by POT's transport from the built-in 3D dictionary, or "
                  "--dict, where no sample reaches)");
  cmd->add_option("--range-cut", a->range_cut,
                  "Returns farther than this (metres, horizontally in 3D) become no-returns "
                  "(default: 20 for 2D logs, the towns' range, which the default dictionary's "
                  "atoms are cut at; 40 for 3D drives, a car's road and the buildings beside it; "
                  "0: none)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--poses", a->drive.poses,
                  "3D drives: odom (odom_poses.txt), optimized (optimized_poses.txt) or auto")
      ->check(CLI::IsMember({"odom", "optimized", "auto"}))
      ->capture_default_str();
  cmd->add_option("--band", a->drive.band_low,
                  "3D drives: the pictures' and ROS map's height band starts this many metres "
                  "about the sensor's height")
      ->capture_default_str();
  cmd->add_option("--band-top", a->drive.band_high, "3D drives: and ends this many metres about it")
      ->capture_default_str();
  cmd->add_option("--voxel", a->drive.voxel_out,
                  "3D drives: voxel edge of the OctoMap, point cloud and band, metres")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--transfer-every", a->drive.transfer_every,
                  "3D drives, --method repot: transfer every N keyframes (seeds last until data "
                  "reaches them)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--keep-tiles", a->drive.keep_tiles,
                "3D drives: keep every tile of the joint BHM (memory grows with the drive) so "
                "that map.potmap carries its information form for `potmap merge`");
  cmd->add_option("--sums", a->drive.sums,
                  "3D drives: where the joint BHM's features and sums run: auto (the device "
                  "when it is a GPU with doubles, else the host), host or device")
      ->check(CLI::IsMember({"auto", "host", "device"}))
      ->capture_default_str();
  cmd->add_option("--checkpoint-every", a->drive.checkpoint_every,
                  "3D drives: write DIR/map.ckpt after every N keyframes (default 0: not by "
                  "count)")
      ->capture_default_str();
  cmd->add_option("--checkpoint-seconds", a->drive.checkpoint_seconds,
                  "3D drives: and when T seconds have passed since the last one (default 30; 0: "
                  "not by time). With both 0 no checkpoint is written")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--export-every", a->drive.export_every,
                  "3D drives: also write DIR/map.bt, map_occupied.ply and the band's files of the "
                  "map so far after every N keyframes, for a planner reading them while the drive "
                  "goes on (each file replaced whole; 0: only at the end)")
      ->capture_default_str();
  cmd->add_flag("--resume", a->drive.resume,
                "3D drives: continue from DIR/map.ckpt when it is there");
  cmd->add_flag("--keep-checkpoint", a->drive.keep_checkpoint,
                "3D drives: keep DIR/map.ckpt after the run");
  add_bag_options(cmd, a->drive.bag);
  cmd->add_option("--first", a->first, "Skip this many scans")->capture_default_str();
  cmd->add_option("--max-scans", a->max_scans, "Map at most this many scans (0: all)")
      ->capture_default_str();
  cmd->add_option("--preset", a->preset,
                  "2D logs: default (the library's defaults, which map real logs best) or paper "
                  "(the authors' rules: exhaustive ranking, barycentric kernels summed with "
                  "merging, no wall clearance; MapperOptions::paper())")
      ->check(CLI::IsMember({"default", "paper"}))
      ->capture_default_str();
  cmd->add_option("--ranking", a->ranking,
                  "exhaustive: every atom at every rotation (the paper's); indexed: nearest "
                  "atoms by signature at estimated rotations, coarse to fine (potmap map's "
                  "--ranking; default: the preset's, indexed for default, exhaustive for paper)")
      ->check(CLI::IsMember({"exhaustive", "indexed"}));
  cmd->add_option("--rotations", a->rotations, "Rotations tried per atom")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--ros-res", a->ros_res,
                  "ROS map resolution, metres per pixel (3D drives: the band's map is at --voxel)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--picture-pixels", a->picture_pixels, "Pixels along the pictures' long side")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--seed", a->seed, "Seed of labelling, hold-out and subsampling")
      ->capture_default_str();
  cmd->add_option("--json", a->json, "'-': also print the summary as JSON on stdout");
  add_seed_rule_flag(cmd, &a->seeds_yield_fully);
  add_half_life_option(cmd, &a->half_life);
  cmd->add_flag("-q,--quiet", a->quiet, "No line per scan (a progress bar on a terminal)");
  cmd->callback(
      [&runner, a, device] { runner.action = [a, device] { return run_mapping(*a, *device); }; });
}

}  // namespace potmap::cli
