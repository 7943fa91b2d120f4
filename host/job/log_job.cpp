#include "log_job.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>

#include "job_report.hpp"
#include "job_text.hpp"
#include "mapping_merge.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"
#include "potmap/io/ros_map.hpp"
#include "potmap/job/map_job.hpp"
#include "potmap/job/map_pictures.hpp"
#include "potmap/pot/default_dictionary_file.hpp"

namespace fs = std::filesystem;

namespace potmap::job {

namespace {

// The scans of `log` from options.first, at most max_scans of them, cut at range_cut.
std::vector<Scan> read_scans(const std::string& log, const MappingJobOptions& a) {
  Dataset ds = read_dataset(log, a.bag);
  if (ds.scans.empty()) throw InputError(log + ": no scans");
  if (a.first >= ds.scans.size())
    throw ArgumentError("mapping: --first " + std::to_string(a.first) + " but " + log + " has " +
                        std::to_string(ds.scans.size()) + " scans");
  std::vector<Scan> scans(ds.scans.begin() + static_cast<long>(a.first), ds.scans.end());
  if (a.max_scans > 0 && scans.size() > a.max_scans) scans.resize(a.max_scans);
  if (a.range_cut > 0)
    for (Scan& s : scans) s = limit_range(s, a.range_cut);
  return scans;
}

// The library's defaults are the settings that map the real logs (docs/methods.md); the
// preset "paper" the authors' rules.
MapJob map_job_of(const MappingJobOptions& a, const Report& report) {
  if (a.preset != "default" && a.preset != "paper")
    throw ArgumentError("mapping: --preset must be default or paper, not '" + a.preset + "'");
  if (!a.ranking.empty() && a.ranking != "indexed" && a.ranking != "exhaustive")
    throw ArgumentError("mapping: --ranking must be indexed or exhaustive, not '" + a.ranking +
                        "'");
  if (a.rotations < 1)
    throw ArgumentError("mapping: --rotations must be at least 1, not " +
                        std::to_string(a.rotations));
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
  const auto t0 = std::chrono::steady_clock::now();
  job.after_scan = [&report, t0](std::size_t, std::size_t done, std::size_t total,
                                 const std::string& line) {
    report.progress({"mapping", "scan", done, total, seconds_since(t0), line});
  };
  job.note = [&report](const std::string& line) { report.note(line); };
  return job;
}

// The files a person and a robot read beside the map: pictures and a ROS map.
void write_pictures_and_ros_map(Context& ctx, const KernelMap& map, const MappingJobOptions& a,
                                double z, const Report& report, MappingJobResult& out) {
  const std::string prefix = (fs::path(a.out) / "map").string();
  const double res = picture_resolution(map, 5, a.picture_pixels);
  const MapPictures pics = write_map_pictures(ctx, map, prefix, res, 5, z);
  RosMapOptions ro;
  ro.resolution = a.ros_resolution;
  ro.z = z;
  const RosMapSummary ros = write_ros_map(&ctx, map, prefix + ".yaml", ro);
  report.note(format("pictures       %zu x %zu at %.3f m per pixel", pics.width, pics.height,
                     pics.resolution));
  report.note(format("ROS map        %zu x %zu at %.3f m: %zu occupied, %zu free, %zu unknown",
                     ros.width, ros.height, ro.resolution, ros.occupied, ros.free, ros.unknown));
  out.files.insert(out.files.end(), pics.files.begin(), pics.files.end());
  out.files.push_back(ros.yaml);
  out.files.push_back(ros.pgm);
}

}  // namespace

MappingJobResult run_log_job(Context& ctx, const std::string& log, const MappingJobOptions& a,
                             const MappingJobHooks& hooks, JobRanks& ranks) {
  const Report report{hooks};
  if (a.method != "pot" && a.method != "repot")
    throw ArgumentError("mapping: a 2D log is mapped with --method pot or repot, not '" + a.method +
                        "'");
  if (a.half_life > 0 && a.method != "repot")
    throw ArgumentError(
        "mapping: --half-life fades RePOT's persistent joint BHM; POT's averaged map does not "
        "forget (--method repot)");
  if (a.lookahead && a.method != "repot")
    throw ArgumentError(
        "mapping: --lookahead on a 2D log scores RePOT's persistent map; --method pot has none "
        "(potmap experiment --lookahead scores POT's averaged map)");
  if (a.lookahead && ranks.size() > 1)
    throw ArgumentError(
        "mapping: --lookahead needs the scans in one process (a rank's map lacks the scans "
        "before its part)");
  if (ranks.rank() == 0) fs::create_directories(a.out);

  std::vector<Scan> scans = read_scans(log, a);
  const std::size_t selected = scans.size();
  const RankPart part = ranks.part(0, selected, "scans");  // all of them on one process
  scans.resize(part.end);
  std::string dict_file;
  const Dictionary dict = job_dictionary(a, report, scans.front().dim, &dict_file);
  if (scans.front().dim != dict.dim)
    throw ArgumentError("mapping: " + log + " holds " + std::to_string(scans.front().dim) +
                        "D scans, the dictionary " + dict_file + " is " + std::to_string(dict.dim) +
                        "D");
  MapJob job = map_job_of(a, report);
  job.start_at = part.begin;
  job.lookahead = a.lookahead;
  if (ranks.size() > 1) check_rank_mergeable(job.mapper);
  report.note(format("mapping        %zu scans of %s (cut at %g m), %s, %zu atoms of %s", selected,
                     log.c_str(), a.range_cut, a.method == "repot" ? "RePOT" : "POT", dict.size(),
                     a.dictionary.empty() ? ("the default dictionary " + dict_file).c_str()
                                          : a.dictionary.c_str()));
  if (ranks.size() > 1)
    report.note(format("rank           %d of %d: scans %zu-%zu", ranks.rank(), ranks.size(),
                       part.begin, part.end - 1));
  MapJobResult r = run_map_job(&ctx, dict, scans, job);
  MappingJobResult out;
  if (ranks.size() > 1 &&
      !merge_rank_maps(ranks, &ctx, part, r, [&report](const std::string& l) { report.note(l); })) {
    out.wrote = false;
    return out;
  }
  const KernelMap& map = r.overall_map();
  if (map.empty()) throw InputError("mapping: " + log + " gave an empty map");
  const std::string map_file = (fs::path(a.out) / "map.potmap").string();
  // With what merging needs (RePOT: the joint BHM's information form; POT: the averaged map's
  // anchor sums), so that maps of the same place made apart can be merged (`potmap merge`).
  r.write_overall_map(map_file);
  out.files.push_back(map_file);
  out.scores = r.overall_scores;
  report.note(
      format("held-out beams ACC %.4f  AUC %.4f  NLL %.4f  (%zu samples, 20 %% of every "
             "scan's beams, never mapped)",
             r.overall_scores.acc, r.overall_scores.auc, r.overall_scores.nll, r.overall_scores.n));
  report.note(format("map            %zu kernels, %.1f MB, %.1f ms per scan -> %s",
                     r.overall_kernels(), r.overall_memory_bytes() / 1e6, r.mean_wall_ms,
                     map_file.c_str()));
  const double z = dict.dim == 3 ? scans.front().origin()[2] : 0;
  write_pictures_and_ros_map(ctx, map, a, z, report, out);

  nlohmann::json j = nlohmann::json::parse(r.to_json());
  j["log"] = log;
  j["method"] = a.method == "repot" ? "RePOT" : "POT";
  j["ranking"] = job.mapper.pot.ranking == PotRanking::indexed ? "indexed" : "exhaustive";
  if (a.preset != "default") j["preset"] = a.preset;
  j["seed_rule"] = a.seeds_yield_fully ? "yield-fully" : "keep-start";
  j["dictionary"] = a.dictionary.empty() ? "default: " + default_dictionary_recipe() : a.dictionary;
  j["range_cut"] = a.range_cut;
  j["half_life_s"] = a.half_life;
  j["device"] = ctx.info().summary();
  if (a.lookahead)
    report_lookahead(r.lookahead, r.lookahead_beyond, r.totals.ahead_ms, r.totals.scans, "scan",
                     report, j, out);
  write_scores(a.out, j, out);
  return out;
}

}  // namespace potmap::job
