#include "drive_mapping.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <iostream>

#include "commands.hpp"
#include "default_dictionary.hpp"
#include "drive_checkpoint.hpp"
#include "drive_outputs.hpp"
#include "drive_ranks.hpp"
#include "interrupt.hpp"
#include "map_checkpoint.hpp"
#include "potmap/data/drive.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/learn/bhm_joint_merge.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/mapping/drive_mapper.hpp"
#include "potmap/mapping/drive_volume.hpp"
#include "potmap/pot/dictionary_io.hpp"
#include "progress.hpp"

namespace fs = std::filesystem;

namespace potmap::cli {

namespace {

std::string default_out(const std::string& drive) {
  fs::path p = fs::path(drive).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  return (fs::path("out") / "mapping" / p.filename()).string();
}

// Progress on stderr: a bar on a terminal, else a line every tenth of the drive, with the ETA.
struct DriveProgress {
  std::function<void(double)> bar;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  std::size_t done = 0, total = 0, next_line = 0;
  bool quiet = false;
  void step(std::size_t keyframe, const KeyframeStats& st) {
    ++done;
    const double f = double(done) / double(total);
    if (bar) return bar(f);
    if (quiet || done < next_line) return;
    next_line = done + std::max<std::size_t>(1, total / 10);
    const double el = seconds_since(start);
    std::fprintf(stderr,
                 "potmap: keyframe %zu (%zu of %zu, %.0f%%): %zu samples as %zu, %.0f ms, "
                 "%.0f MB; elapsed %.0f s, ETA %.0f s\n",
                 keyframe, done, total, 100 * f, st.samples, st.gathered,
                 st.label_ms + st.transfer_ms + st.update_ms, st.memory_bytes / 1e6, el,
                 el * (1 - f) / f);
  }
};

// The process's peak resident memory so far, bytes (Linux; 0 elsewhere).
double peak_rss_bytes() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return 1024.0 * std::strtod(line.c_str() + 6, nullptr);
  return 0;
}

DriveMapperOptions mapper_options(const DriveMappingArgs& a, std::string* dict_file) {
  DriveMapperOptions o;
  o.range_cut = a.range_cut;
  o.labels.seed = a.seed;
  if (a.keep_tiles) o.retire_radius = 0;
  o.bhm.half_life = a.half_life;
  o.bhm.sums = a.sums == "host"     ? JointBhmSums::host
               : a.sums == "device" ? JointBhmSums::device
                                    : JointBhmSums::automatic;
  if (a.method == "repot") {
    o.transfer_every = a.transfer_every;
    *dict_file = a.dict;
    o.dictionary = std::make_shared<const Dictionary>(
        a.dict.empty() ? default_dictionary(dict_file, 3) : read_dictionary(a.dict));
    if (o.dictionary->dim != 3)
      throw ArgumentError("mapping: " + *dict_file + " is a " + std::to_string(o.dictionary->dim) +
                          "D dictionary; a drive needs 3D atoms (potmap dict default --3d)");
  } else if (a.method != "bhm") {
    throw ArgumentError("mapping: a 3D drive is mapped with --method bhm or repot, not '" +
                        a.method +
                        "' (POT's averaged map of a whole drive grows with the drive: RePOT "
                        "keeps the transported kernels where the data does not reach)");
  }
  return o;
}

// scores.json: what was mapped, the scores, time and memory per keyframe.
nlohmann::json summary_json(const DriveMappingArgs& a, const Drive& drive, const DriveRun& run,
                            const DriveMapper& mapper, std::size_t kernels, const Scores& sc) {
  const double n = double(run.keyframes);
  nlohmann::json j;
  j["drive"] = a.drive;
  j["layout"] = drive.layout;
  j["poses"] = drive.poses_file;
  j["method"] = mapper.options().dictionary ? "RePOT" : "BHM";
  j["keyframes"] = run.keyframes;
  double path = 0;
  for (std::size_t i = 3; i + 2 < run.positions.size(); i += 3)
    path += std::hypot(run.positions[i] - run.positions[i - 3],
                       run.positions[i + 1] - run.positions[i - 2],
                       run.positions[i + 2] - run.positions[i - 1]);
  j["path_m"] = path;
  j["first"] = a.first;
  j["range_cut_m"] = a.range_cut;
  j["half_life_s"] = a.half_life;
  j["scores"] = {{"acc", sc.acc}, {"auc", sc.auc}, {"nll", sc.nll}, {"n", sc.n}};
  j["ms_per_keyframe"] = (run.label_ms + run.transfer_ms + run.update_ms) / n;
  j["label_ms_per_keyframe"] = run.label_ms / n;
  j["transfer_ms_per_keyframe"] = run.transfer_ms / n;
  j["update_ms_per_keyframe"] = run.update_ms / n;
  j["max_update_ms"] = run.max_ms;
  j["kernels"] = kernels;
  j["memory_mb"] = mapper.memory_bytes() / 1e6;
  j["peak_memory_mb"] = run.peak_bytes / 1e6;
  j["peak_rss_mb"] = peak_rss_bytes() / 1e6;
  j["keyframe_memory_mb"] = run.memory_mb;
  j["keyframe_ms"] = run.keyframe_ms;
  return j;
}

// How the drive's keyframes and poses were found, for the first line of the run.
std::string layout_text(const Drive& drive) {
  if (drive.layout == "rosbag") return "ROS bag, poses from " + drive.poses_file;
  return drive.layout == "slam" ? "SLAM keyframes" : "KITTI";
}

// What the run's outputs are written from: one process's mapper, or the ranks' maps merged.
struct DriveResult {
  const JointBhm& learner;
  const KernelMap& map;
  const LabelledPoints& held_out;
  const DriveRun& run;
  const nlohmann::json* ranks;  ///< the ranks' record (null: one process)
};

// The outputs' options of the command line.
DriveOutputOptions output_options(const DriveMappingArgs& a) {
  DriveOutputOptions oo;
  oo.band_low = a.band_low;
  oo.band_high = a.band_high;
  oo.picture_res = a.picture_res;
  oo.picture_pixels = a.picture_pixels;
  oo.voxel = a.voxel_out;
  return oo;
}

// --export-every: the map so far, exported where the end's outputs go, replacing the last.
void export_so_far(const DriveMappingArgs& a, const std::string& dir, DriveMapper& mapper,
                   Context& ctx, const DriveRun& run, std::FILE* human) {
  const auto t0 = std::chrono::steady_clock::now();
  DriveOutputOptions oo = output_options(a);
  oo.progress = [](double) { stop_if_interrupted(); };
  const KernelMap map = mapper.map(&ctx);
  const DriveOutputs outs =
      write_drive_outputs(ctx, map, run.positions, (fs::path(dir) / "map").string(), oo);
  std::fprintf(
      human, "exported       after keyframe %zu: %zu kernels, %s voxels occupied, %.1f s\n",
      run.keyframes, map.size(), outs.json["occupied_voxels"].dump().c_str(), seconds_since(t0));
}

// The map, what robotics stacks load from it, the scores and scores.json.
int write_drive_results(const DriveMappingArgs& a, const Drive& drive, const DriveMapper& mapper,
                        Context& ctx, const DriveResult& res, double mapping_s) {
  const std::string dir = a.out.empty() ? default_out(a.drive) : a.out;
  std::FILE* human = a.json == "-" ? stderr : stdout;
  const auto t_out = std::chrono::steady_clock::now();
  const KernelMap& map = res.map;
  const DriveRun& run = res.run;
  if (map.empty()) throw InputError("mapping: " + a.drive + " gave an empty map");
  const std::string map_file = (fs::path(dir) / "map.potmap").string();
  // The information form (for `potmap merge`) only where it is whole: a retired tile's
  // couplings went into its neighbours' information vector.
  const std::size_t retired = res.learner.retired_tiles();
  if (retired > 0)
    std::fprintf(human,
                 "note           %zu tiles were retired: %s holds no information form and "
                 "cannot be merged (--keep-tiles keeps them)\n",
                 retired, map_file.c_str());
  // The map file (hundreds of MB for a city drive: a copy, a CRC and the disk) is written
  // beside the scoring and the volume, which keep the device busy.
  auto map_written = std::async(std::launch::async, [&] {
    const auto t0 = std::chrono::steady_clock::now();
    if (retired == 0)
      write_joint_bhm_map(res.learner, map_file, &map);
    else
      write_map(map, map_file);
    return seconds_since(t0);
  });
  const LabelledPoints& test = res.held_out;
  const std::vector<float> prob = probability_by_columns(ctx, map, test.position);
  const double scored_s = seconds_since(t_out);
  const Scores sc = score(prob, test.label);

  DriveOutputOptions oo = output_options(a);
  oo.progress = [bar = stage_progress("outputs", a.quiet)](double f) {
    stop_if_interrupted();
    if (bar) bar(f);
  };
  const DriveOutputs outs =
      write_drive_outputs(ctx, map, run.positions, (fs::path(dir) / "map").string(), oo);
  const double write_s = map_written.get();
  const double output_s = seconds_since(t_out);

  const std::size_t n = run.keyframes;
  std::fprintf(human,
               "held-out beams ACC %.4f  AUC %.4f  NLL %.4f  (%zu samples: every %zu-th of 20 %% "
               "of every keyframe's beams, never mapped)\n",
               sc.acc, sc.auc, sc.nll, sc.n, mapper.options().test_stride);
  std::fprintf(human,
               "map            %zu kernels, %.1f MB held; %.0f ms a keyframe (%.0f labelling and "
               "gathering, %.0f transfer, %.0f update) -> %s\n",
               map.size(), mapper.memory_bytes() / 1e6,
               (run.label_ms + run.transfer_ms + run.update_ms) / double(n),
               run.label_ms / double(n), run.transfer_ms / double(n), run.update_ms / double(n),
               map_file.c_str());
  std::fprintf(human, "%s", outs.summary.c_str());
  std::vector<std::string> files = {map_file};
  files.insert(files.end(), outs.files.begin(), outs.files.end());

  nlohmann::json j = summary_json(a, drive, run, mapper, map.size(), sc);
  if (res.ranks) {
    j["ranks"] = *res.ranks;
    j["memory_mb"] = res.learner.memory_bytes() / 1e6;  // the merged map's learner
  }
  j["mapping_s"] = mapping_s;
  j["outputs_s"] = output_s;
  j["outputs_phases_s"] = {
      {"map_file_beside", write_s}, {"scores", scored_s}, {"volume_and_band", output_s - scored_s}};
  j["device"] = ctx.info().summary();
  j["sums_on_device"] = mapper.learner().last_stats().sums_on_device;
  j["outputs"] = outs.json;
  write_scores_and_list(dir, j, files, a.json, human);
  std::error_code ec;
  if (!a.keep_checkpoint) fs::remove((fs::path(dir) / "map.ckpt"), ec);
  return 0;
}

// Under mpirun: every tile kept, so that the ranks' maps merge exactly, and no checkpoints
// (each rank's would be its part's).
DriveMappingArgs rank_args(DriveMappingArgs a, const MappingRanks& ranks) {
  if (ranks.size() == 1) return a;
  if (a.resume)
    throw ArgumentError(
        "mapping: --resume continues a run of one process; the ranks of an mpirun job keep no "
        "checkpoints");
  a.keep_tiles = true;
  a.checkpoint_every = 0;
  a.checkpoint_seconds = 0;
  return a;
}

}  // namespace

int run_drive_mapping(const DriveMappingArgs& args, const std::string& device,
                      MappingRanks& ranks) {
  const InterruptScope interrupts;  // Ctrl-C: stop at the next keyframe, files whole
  const DriveMappingArgs a = rank_args(args, ranks);
  DriveOptions dopt;
  dopt.poses = a.poses;
  dopt.bag = a.bag;
  const Drive drive = open_drive(a.drive, dopt);
  if (a.first >= drive.size())
    throw ArgumentError("mapping: --first " + std::to_string(a.first) + " but " + a.drive +
                        " has " + std::to_string(drive.size()) + " keyframes");
  const std::size_t end =
      a.max_keyframes ? std::min(drive.size(), a.first + a.max_keyframes) : drive.size();
  const RankPart part = ranks.part(a.first, end, "keyframes");  // all of them on one process
  const std::string dir = a.out.empty() ? default_out(a.drive) : a.out;
  if (ranks.rank() == 0) {
    fs::create_directories(dir);
    // What runs killed outright (SIGKILL, a power cut) left while writing.
    for (const char* f :
         {"map.ckpt", "map.potmap", "map.bt", "map_occupied.ply", "map_band_prob.png",
          "map_band_var.png", "map_band.yaml", "map_band.pgm", "scores.json"})
      remove_stale_temporaries((fs::path(dir) / f).string());
  }
  std::FILE* human = a.json == "-" || ranks.rank() > 0 ? stderr : stdout;
  const auto t_run = std::chrono::steady_clock::now();

  std::string dict_file;
  const DriveMapperOptions mo = mapper_options(a, &dict_file);
  DriveMapper mapper(mo);
  DriveRun run;
  run.record = drive_run_record(a, drive, mo);
  const std::string ckpt = (fs::path(dir) / "map.ckpt").string();
  std::size_t at = part.begin;
  if (a.resume && fs::exists(ckpt)) {
    at = read_drive_checkpoint(ckpt, run, mapper);
    std::fprintf(human, "resumed        at keyframe %zu from %s\n", at, ckpt.c_str());
  }
  Context ctx = make_context(device);
  std::fprintf(human, "mapping        keyframes %zu-%zu of %s (%s, cut at %g m), %s\n", a.first,
               end - 1, a.drive.c_str(), layout_text(drive).c_str(), a.range_cut,
               mo.dictionary ? ("RePOT: the joint BHM seeded from " +
                                std::to_string(mo.dictionary->size()) + " atoms of " + dict_file)
                                   .c_str()
                             : "joint BHM");
  if (ranks.size() > 1)
    std::fprintf(human, "rank           %d of %d: keyframes %zu-%zu, every tile kept\n",
                 ranks.rank(), ranks.size(), part.begin, part.end - 1);
  if (at < part.end) {
    // The device's programs are built at their first launch (seconds on PoCL): a throwaway
    // mapper maps the first keyframe once, so that no keyframe's time counts a build.
    const auto t_build = std::chrono::steady_clock::now();
    const KeyframeStats first =
        DriveMapper(mo).add(read_keyframe(drive, at), std::int64_t(at), &ctx);
    std::fprintf(human,
                 "device         %s; kernels built in %.1f s (counted in no keyframe); the "
                 "learner's sums on the %s\n",
                 ctx.info().summary().c_str(), seconds_since(t_build),
                 first.sums_on_device ? "device" : "host");
  }
  DriveProgress progress;
  progress.total = part.end - at;
  progress.quiet = a.quiet;
  progress.bar = terminal_progress("mapping");
  // The next keyframe is read (a file parsed) on another thread while this one is mapped.
  auto read_ahead = [&drive](std::size_t i) {
    return std::async(std::launch::async, [&drive, i] { return read_keyframe(drive, i); });
  };
  std::future<Scan> next = at < part.end ? read_ahead(at) : std::future<Scan>();
  DriveCheckpoints checkpoints;
  auto last_checkpoint = std::chrono::steady_clock::now();
  for (std::size_t i = at; i < part.end; ++i) {
    const Scan kf = next.get();
    if (i + 1 < part.end) next = read_ahead(i + 1);
    stop_if_interrupted();
    const KeyframeStats st = mapper.add(kf, std::int64_t(i), &ctx);
    run.add(st, drive.poses[i]);
    progress.step(i, st);
    const bool by_count = a.checkpoint_every && (i + 1 - a.first) % a.checkpoint_every == 0;
    const bool by_time =
        a.checkpoint_seconds > 0 && seconds_since(last_checkpoint) >= a.checkpoint_seconds;
    if ((by_count || by_time) && i + 1 < end) {
      checkpoints.write(ckpt, run, mapper, i + 1);
      last_checkpoint = std::chrono::steady_clock::now();
    }
    if (a.export_every && ranks.size() == 1 && (i + 1 - a.first) % a.export_every == 0 &&
        i + 1 < end)
      export_so_far(a, dir, mapper, ctx, run, human);
  }
  checkpoints.wait();  // before the run's end removes the checkpoint
  const double mapping_s = seconds_since(t_run);
  if (ranks.size() == 1) {
    const KernelMap map = mapper.map(&ctx);
    return write_drive_results(a, drive, mapper, ctx,
                               {mapper.learner(), map, mapper.held_out(), run, nullptr}, mapping_s);
  }
  const std::optional<DriveMerged> m = merge_drive_ranks(ranks, part, mapper, run);
  if (!m) return 0;
  return write_drive_results(a, drive, mapper, ctx,
                             {*m->joint, m->map, m->held_out, m->run, &m->record}, mapping_s);
}

}  // namespace potmap::cli
