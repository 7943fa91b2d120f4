#include "drive_job.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <iostream>

#include "drive_checkpoint.hpp"
#include "drive_outputs.hpp"
#include "drive_ranks.hpp"
#include "job_report.hpp"
#include "job_text.hpp"
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

namespace fs = std::filesystem;

namespace potmap::job {

namespace {

// Progress a keyframe at a time, with a line on the keyframe just mapped.
struct DriveProgress {
  const Report& report;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  std::size_t done = 0, total = 0;
  void step(std::size_t keyframe, const KeyframeStats& st) {
    ++done;
    report.progress(
        {"mapping", "keyframe", done, total, seconds_since(start),
         format("keyframe %zu: %zu samples as %zu, %.0f ms, %.0f MB", keyframe, st.samples,
                st.gathered, st.label_ms + st.transfer_ms + st.update_ms, st.memory_bytes / 1e6)});
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

DriveMapperOptions mapper_options(const MappingJobOptions& a, const Report& report,
                                  std::string* dict_file) {
  DriveMapperOptions o;
  o.range_cut = a.range_cut;
  o.labels.seed = a.seed;
  if (a.keep_tiles) o.retire_radius = 0;
  o.lookahead = a.lookahead;
  o.bhm.half_life = a.half_life;
  o.bhm.sums = a.sums == "host"     ? JointBhmSums::host
               : a.sums == "device" ? JointBhmSums::device
                                    : JointBhmSums::automatic;
  if (a.method == "repot") {
    o.transfer_every = a.transfer_every;
    o.dictionary = std::make_shared<const Dictionary>(job_dictionary(a, report, 3, dict_file));
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
nlohmann::json summary_json(const std::string& recording, const MappingJobOptions& a,
                            const Drive& drive, const DriveRun& run, const DriveMapper& mapper,
                            std::size_t kernels, const Scores& sc) {
  const double n = double(run.keyframes);
  nlohmann::json j;
  j["drive"] = recording;
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
DriveOutputOptions output_options(const MappingJobOptions& a) {
  DriveOutputOptions oo;
  oo.band_low = a.band_low;
  oo.band_high = a.band_high;
  oo.picture_res = a.picture_res;
  oo.picture_pixels = a.picture_pixels;
  oo.voxel = a.voxel;
  return oo;
}

// --export-every: the map so far, exported where the end's outputs go, replacing the last.
void export_so_far(const MappingJobOptions& a, DriveMapper& mapper, Context& ctx,
                   const DriveRun& run, const Report& report) {
  const auto t0 = std::chrono::steady_clock::now();
  DriveOutputOptions oo = output_options(a);
  // Checked between batches of blocks (an interrupt stops the export, files whole), but not
  // shown: a progress bar of its own at every export would hide the keyframes'.
  oo.progress = [&report, t0](double f) {
    report.progress({"export", "share", std::size_t(f * 1000), 1000, seconds_since(t0), {}});
  };
  const KernelMap map = mapper.map(&ctx);
  const DriveOutputs outs =
      write_drive_outputs(ctx, map, run.positions, (fs::path(a.out) / "map").string(), oo);
  report.note(format("exported       after keyframe %zu: %zu kernels, %s voxels occupied, %.1f s",
                     run.keyframes, map.size(), outs.json["occupied_voxels"].dump().c_str(),
                     seconds_since(t0)));
}

// The map, what robotics stacks load from it, the scores and scores.json.
MappingJobResult write_drive_results(const std::string& recording, const MappingJobOptions& a,
                                     const Drive& drive, const DriveMapper& mapper, Context& ctx,
                                     const DriveResult& res, double mapping_s,
                                     const Report& report) {
  const std::string& dir = a.out;
  const auto t_out = std::chrono::steady_clock::now();
  const KernelMap& map = res.map;
  const DriveRun& run = res.run;
  if (map.empty()) throw InputError("mapping: " + recording + " gave an empty map");
  const std::string map_file = (fs::path(dir) / "map.potmap").string();
  // The information form (for `potmap merge`) only where it is whole: a retired tile's
  // couplings went into its neighbours' information vector.
  const std::size_t retired = res.learner.retired_tiles();
  if (retired > 0)
    report.note(
        format("note           %zu tiles were retired: %s holds no information form and "
               "cannot be merged (keep_tiles, --keep-tiles, keeps them)",
               retired, map_file.c_str()));
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
  oo.progress = [&report, t_out](double f) {
    report.progress({"outputs", "share", std::size_t(f * 1000), 1000, seconds_since(t_out), {}});
  };
  const DriveOutputs outs =
      write_drive_outputs(ctx, map, run.positions, (fs::path(dir) / "map").string(), oo);
  const double write_s = map_written.get();
  const double output_s = seconds_since(t_out);

  const double n = double(run.keyframes);
  report.note(
      format("held-out beams ACC %.4f  AUC %.4f  NLL %.4f  (%zu samples: every %zu-th of "
             "20 %% of every keyframe's beams, never mapped)",
             sc.acc, sc.auc, sc.nll, sc.n, mapper.options().test_stride));
  report.note(format(
      "map            %zu kernels, %.1f MB held; %.0f ms a keyframe (%.0f "
      "labelling and gathering, %.0f transfer, %.0f update) -> %s",
      map.size(), mapper.memory_bytes() / 1e6, (run.label_ms + run.transfer_ms + run.update_ms) / n,
      run.label_ms / n, run.transfer_ms / n, run.update_ms / n, map_file.c_str()));
  std::string lines = outs.summary;
  while (!lines.empty() && lines.back() == '\n') lines.pop_back();
  for (std::size_t at = 0, nl; at < lines.size(); at = nl + 1) {
    nl = lines.find('\n', at);
    if (nl == std::string::npos) nl = lines.size();
    report.note(lines.substr(at, nl - at));
  }
  MappingJobResult out;
  out.drive = true;
  out.scores = sc;
  out.files = {map_file};
  out.files.insert(out.files.end(), outs.files.begin(), outs.files.end());

  nlohmann::json j = summary_json(recording, a, drive, run, mapper, map.size(), sc);
  if (res.ranks) {
    j["ranks"] = *res.ranks;
    j["memory_mb"] = res.learner.memory_bytes() / 1e6;  // the merged map's learner
  }
  if (mapper.options().lookahead && !res.ranks) {
    Scores all, beyond;
    lookahead_scores(mapper.lookahead(), all, beyond);
    report_lookahead(all, beyond, run.lookahead_ms, run.keyframes, "keyframe", report, j, out);
  }
  j["mapping_s"] = mapping_s;
  j["outputs_s"] = output_s;
  j["outputs_phases_s"] = {
      {"map_file_beside", write_s}, {"scores", scored_s}, {"volume_and_band", output_s - scored_s}};
  j["device"] = ctx.info().summary();
  j["sums_on_device"] = mapper.learner().last_stats().sums_on_device;
  j["outputs"] = outs.json;
  write_scores(dir, j, out);
  std::error_code ec;
  if (!a.keep_checkpoint) fs::remove((fs::path(dir) / "map.ckpt"), ec);
  return out;
}

// Under several ranks: every tile kept, so that the ranks' maps merge exactly, and no
// checkpoints (each rank's would be its part's).
MappingJobOptions rank_options(MappingJobOptions a, const JobRanks& ranks) {
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

// The first lines of the run: what is mapped, how, and where.
void note_start(const Report& report, const std::string& recording, const MappingJobOptions& a,
                const Drive& drive, const DriveMapperOptions& mo, const std::string& dict_file,
                std::size_t end, const JobRanks& ranks, const RankPart& part) {
  report.note(format("mapping        keyframes %zu-%zu of %s (%s, cut at %g m), %s", a.first,
                     end - 1, recording.c_str(), layout_text(drive).c_str(), a.range_cut,
                     mo.dictionary
                         ? ("RePOT: the joint BHM seeded from " +
                            std::to_string(mo.dictionary->size()) + " atoms of " + dict_file)
                               .c_str()
                         : "joint BHM"));
  if (ranks.size() > 1)
    report.note(format("rank           %d of %d: keyframes %zu-%zu, every tile kept", ranks.rank(),
                       ranks.size(), part.begin, part.end - 1));
}

// The keyframes [at, part.end) into `mapper`, with checkpoints and exports on the way.
void map_keyframes(const MappingJobOptions& a, const Drive& drive, std::size_t at,
                   const RankPart& part, std::size_t end, bool one_process, DriveMapper& mapper,
                   DriveRun& run, Context& ctx, const Report& report) {
  DriveProgress progress{report};
  progress.total = part.end - at;
  const std::string ckpt = (fs::path(a.out) / "map.ckpt").string();
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
    if (a.export_every && one_process && (i + 1 - a.first) % a.export_every == 0 && i + 1 < end)
      export_so_far(a, mapper, ctx, run, report);
  }
  checkpoints.wait();  // before the run's end removes the checkpoint
}

}  // namespace

MappingJobResult run_drive_job(Context& ctx, const std::string& recording,
                               const MappingJobOptions& options, const MappingJobHooks& hooks,
                               JobRanks& ranks) {
  const Report report{hooks};
  const MappingJobOptions a = rank_options(options, ranks);
  DriveOptions dopt;
  dopt.poses = a.poses;
  dopt.bag = a.bag;
  const Drive drive = open_drive(recording, dopt);
  if (a.first >= drive.size())
    throw ArgumentError("mapping: --first " + std::to_string(a.first) + " but " + recording +
                        " has " + std::to_string(drive.size()) + " keyframes");
  const std::size_t end =
      a.max_scans ? std::min(drive.size(), a.first + a.max_scans) : drive.size();
  const RankPart part = ranks.part(a.first, end, "keyframes");  // all of them on one process
  if (ranks.rank() == 0) {
    fs::create_directories(a.out);
    // What runs killed outright (SIGKILL, a power cut) left while writing.
    for (const char* f :
         {"map.ckpt", "map.potmap", "map.bt", "map_occupied.ply", "map_band_prob.png",
          "map_band_var.png", "map_band.yaml", "map_band.pgm", "scores.json"})
      remove_stale_temporaries((fs::path(a.out) / f).string());
  }
  const auto t_run = std::chrono::steady_clock::now();

  std::string dict_file;
  const DriveMapperOptions mo = mapper_options(a, report, &dict_file);
  DriveMapper mapper(mo);
  DriveRun run;
  run.record = drive_run_record(recording, a, drive, mo);
  const std::string ckpt = (fs::path(a.out) / "map.ckpt").string();
  std::size_t at = part.begin;
  if (a.resume && fs::exists(ckpt)) {
    at = read_drive_checkpoint(ckpt, run, mapper);
    report.note(format("resumed        at keyframe %zu from %s", at, ckpt.c_str()));
  }
  note_start(report, recording, a, drive, mo, dict_file, end, ranks, part);
  if (at < part.end) {
    // The device's programs are built at their first launch (seconds on PoCL): a throwaway
    // mapper maps the first keyframe once, so that no keyframe's time counts a build.
    const auto t_build = std::chrono::steady_clock::now();
    const KeyframeStats first =
        DriveMapper(mo).add(read_keyframe(drive, at), std::int64_t(at), &ctx);
    report.note(
        format("device         %s; kernels built in %.1f s (counted in no keyframe); the "
               "learner's sums on the %s",
               ctx.info().summary().c_str(), seconds_since(t_build),
               first.sums_on_device ? "device" : "host"));
  }
  map_keyframes(a, drive, at, part, end, ranks.size() == 1, mapper, run, ctx, report);
  const double mapping_s = seconds_since(t_run);
  if (ranks.size() == 1) {
    const KernelMap map = mapper.map(&ctx);
    return write_drive_results(recording, a, drive, mapper, ctx,
                               {mapper.learner(), map, mapper.held_out(), run, nullptr}, mapping_s,
                               report);
  }
  const std::optional<DriveMerged> m = merge_drive_ranks(
      ranks, part, mapper, run, [&report](const std::string& l) { report.note(l); });
  if (!m) {
    MappingJobResult r;
    r.wrote = false;
    r.drive = true;
    return r;
  }
  return write_drive_results(recording, a, drive, mapper, ctx,
                             {*m->joint, m->map, m->held_out, m->run, &m->record}, mapping_s,
                             report);
}

}  // namespace potmap::job
