// `potmap map`: map scans by POT or RePOT with a dictionary of atoms (SPEC section 4).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <set>

#include "commands.hpp"
#include "dataset_samples.hpp"
#include "default_dictionary.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/io/ros_map.hpp"
#include "potmap/job/map_job.hpp"
#include "potmap/job/map_pictures.hpp"
#include "potmap/mapping/map_files.hpp"
#include "potmap/pot/dictionary_io.hpp"
#include "potmap/pot/fingerprint.hpp"
#include "progress.hpp"

namespace potmap::cli {

using job::MapCheckpointing;
using job::MapJob;
using job::MapJobResult;
using job::MapPictures;

namespace {

struct MapArgs {
  std::string dict, scans, out, instantaneous, json, picture, ros_map;
  bool refine = false, per_scan_refine = false, cpu = false, quiet = false, no_pipeline = false,
       hits_only = false, seeds_yield_fully = true, lookahead = false;
  double refine_min_variance = 0;
  double refine_spacing = JointBhmOptions{}.spacing, refine_prior_var = JointBhmOptions{}.prior_var;
  double half_life = 0;  // seconds of the scans' time (0: never forget)
  int sectors = 5, rotations = 8, em = 1;
  double max_range = 0, holdout = 0.2, res = 0.25, range_cut = 0, ros_res = 0.05;
  std::size_t first = 0, max_scans = 0, candidates = 0, max_kernels = 0;
  std::size_t free_points = PotOptions{}.transport_free_points;
  double free_tolerance = PotOptions{}.transport_free_tolerance;
  double merge_radius = OverallMapOptions{}.merge_radius;
  double wall_clearance = 0.5, displacement_var = 0;
  int anchor_sweeps = PotOptions{}.anchor_sweeps;
  double anchor_clearance = PotOptions{}.anchor_clearance;
  double logit_gain = PotOptions{}.logit_gain;
  std::uint64_t seed = 0;
  std::string ranking = "indexed";
  BagOptions bag;
  // default: the library's defaults; paper: MapperOptions::paper() for the options below that
  // the two presets set apart (--ranking, --placement, --wall-clearance, --average), unless
  // given on the command line. `given`: those that were.
  std::string preset = "default";
  std::set<std::string> given;
  // The experiments' settings (docs/pot-measurements.md); on Intel from the default dictionary,
  // 60 scans: overall AUC / NLL 0.971 / 0.177 (0.958 / 0.213 with each class's partition, gain 1
  // and a 0.5 m anchor clearance; 0.943 / 0.285 with the authors' placement and summed kernels at
  // that clearance and 0.880 / 1.302 without a clearance).
  std::string placement = "auto";
  bool average = true;
  // Checkpoints every 30 s of work by default: at most that much is lost whatever a scan costs
  // (a count of scans bounds neither the loss nor the overhead: scans take 1 ms to seconds),
  // and a checkpoint costs a small fraction of it (RePOT's largest, tens of MB, take tenths of
  // a second; docs/commands.md, Checkpoints and resume).
  std::string checkpoint;  // default: OUT + ".ckpt"
  std::size_t checkpoint_every = 0;
  double checkpoint_seconds = 30;
  bool resume = false, keep_checkpoint = false;
};

// What a checkpoint must match to be resumed: the inputs (by content) and every option that
// changes the overall map, under the names the user typed them with.
nlohmann::json run_record(const MapArgs& a, const std::string& dict_file, const Dictionary& dict,
                          const std::vector<Scan>& scans, const MapJob& job,
                          const std::string& device) {
  nlohmann::json r = {{"--dict", dict_file},
                      {"dictionary fingerprint", fingerprint(dict)},
                      {"--scans", a.scans},
                      {"scans fingerprint", fingerprint(scans)},
                      {"scans", scans.size()},
                      {"--first", a.first},
                      {"--max-scans", a.max_scans},
                      {"--range-cut", a.range_cut},
                      {"--refine", a.refine},
                      {"--per-scan-refine", a.per_scan_refine},
                      {"--seeds-yield-fully", a.seeds_yield_fully},
                      {"--refine-spacing", a.refine_spacing},
                      {"--refine-prior-var", a.refine_prior_var},
                      {"--refine-min-variance", a.refine_min_variance},
                      {"--em", a.em},
                      {"--sectors", a.sectors},
                      {"--rotations", a.rotations},
                      {"--ranking", a.ranking},
                      {"--candidates", a.candidates},
                      {"--max-range", a.max_range},
                      {"--free-points", a.free_points},
                      {"--free-tolerance", a.free_tolerance},
                      {"--hits-only", a.hits_only},
                      {"--holdout", a.holdout},
                      {"--seed", a.seed},
                      {"--wall-clearance", a.wall_clearance},
                      {"--displacement-var", a.displacement_var},
                      {"--merge-radius", a.merge_radius},
                      {"--max-kernels", a.max_kernels},
                      {"--placement", a.placement},
                      {"--average", a.average},
                      {"mapper options fingerprint", fingerprint(job.mapper, job.overall)},
                      {"device", a.cpu ? std::string("CPU reference") : device}};
  // Only when set: the checkpoints of runs without it stay resumable.
  if (a.preset != "default") r["--preset"] = a.preset;
  if (a.half_life > 0) r["--half-life"] = a.half_life;
  if (a.lookahead) r["--lookahead"] = true;
  return r;
}

// The scans from --first, at most --max-scans of them, checked against the dictionary.
std::vector<Scan> scans_to_map(const MapArgs& a, const Dictionary& dict,
                               const std::string& dict_file) {
  std::vector<Scan> all = read_scans(a.scans, a.range_cut, a.bag);
  if (a.first >= all.size())
    throw ArgumentError("map: --first " + std::to_string(a.first) + " but " + a.scans + " has " +
                        std::to_string(all.size()) + " scans");
  std::vector<Scan> scans(all.begin() + static_cast<long>(a.first), all.end());
  if (a.max_scans > 0 && scans.size() > a.max_scans) scans.resize(a.max_scans);
  if (scans.front().dim != dict.dim)
    throw ArgumentError("map: " + a.scans + " holds " + std::to_string(scans.front().dim) +
                        "D scans, the dictionary " + dict_file + " is " + std::to_string(dict.dim) +
                        "D");
  return scans;
}

// The mapper's and the overall map's options from the command line (checkpoints apart).
MapJob map_job(const MapArgs& a) {
  MapJob job;
  // Under --preset paper the options the presets set apart keep the paper's values unless given.
  const bool paper = a.preset == "paper";
  auto set = [&](const char* option) { return !paper || a.given.count(option) > 0; };
  if (paper) job.mapper = MapperOptions::paper();
  PotOptions& po = job.mapper.pot;
  po.sectors = a.sectors;
  po.max_range = a.max_range;
  po.rotations = evenly_spaced_rotations(a.rotations);
  po.refine = a.refine;
  job.mapper.persistent_refine = !a.per_scan_refine;
  job.mapper.refine_map.seeds_yield_fully = a.seeds_yield_fully;
  job.mapper.refine_map.spacing = a.refine_spacing;
  job.mapper.refine_map.prior_var = a.refine_prior_var;
  job.mapper.refine_map.half_life = a.half_life;
  if (a.half_life > 0 && (!a.refine || a.per_scan_refine))
    throw ArgumentError(
        "map: --half-life fades RePOT's persistent joint BHM (--refine without "
        "--per-scan-refine); POT's overall maps do not forget");
  po.refine_min_variance = a.refine_min_variance;
  po.refine_bhm.em_iterations = a.em;
  po.candidates = a.candidates;
  if (set("--ranking"))
    po.ranking = a.ranking == "indexed" ? PotRanking::indexed : PotRanking::exhaustive;
  po.transport_free_points = a.free_points;
  po.transport_free_tolerance = a.free_tolerance;
  po.transport_free = !a.hits_only;
  if (set("--wall-clearance")) po.wall_clearance = a.wall_clearance;
  po.anchor_sweeps = a.anchor_sweeps;
  po.anchor_clearance = a.anchor_clearance;
  po.logit_gain = a.logit_gain;
  // One displacement variance for the scans' kernels and RePOT's seeds, whichever are placed.
  po.displacement_variance = a.displacement_var;
  job.mapper.seed_displacement_variance = a.displacement_var;
  if (set("--placement")) {  // auto: the defaults' (on the samples; RePOT's seeds barycentric)
    po.placement =
        a.placement == "barycentric" ? PotPlacement::barycentric : PotPlacement::target_samples;
    job.mapper.seed_placement =
        a.placement == "target_samples" ? PotPlacement::target_samples : PotPlacement::barycentric;
  }
  if (set("--average")) job.mapper.average_overall = a.average;
  po.seed = a.seed;
  job.mapper.labels.holdout_fraction = a.holdout;
  job.mapper.labels.seed = a.seed;
  job.mapper.pipeline = !a.no_pipeline;
  job.overall.merge_radius = a.merge_radius;
  job.overall.max_kernels = a.max_kernels;
  job.instantaneous_dir = a.instantaneous;
  job.lookahead = a.lookahead;
  if (a.lookahead && (!a.refine || a.per_scan_refine))
    throw ArgumentError(
        "map: --lookahead scores RePOT's persistent map (--refine without --per-scan-refine)");
  print_scans(job, !a.quiet, "potmap map");
  return job;
}

void print_summary(std::FILE* human, const MapArgs& a, const MapJobResult& r) {
  std::fprintf(human, "scans          %zu (%s)\n", r.scans, a.refine ? "RePOT" : "POT");
  std::fprintf(human, "overall map    %zu kernels, %.1f MB%s -> %s\n", r.overall_kernels(),
               r.overall_memory_bytes() / 1e6, r.persistent() ? " (persistent joint BHM)" : "",
               a.out.c_str());
  std::fprintf(human, "instantaneous  ACC %.4f  AUC %.4f  NLL %.4f  (%zu held-out samples)\n",
               r.instantaneous.acc, r.instantaneous.auc, r.instantaneous.nll, r.instantaneous.n);
  std::fprintf(human, "overall        ACC %.4f  AUC %.4f  NLL %.4f\n", r.overall_scores.acc,
               r.overall_scores.auc, r.overall_scores.nll);
  if (r.lookahead.n)
    std::fprintf(human,
                 "look-ahead     AUC %.4f  NLL %.4f  (%zu held-out samples scored before their "
                 "scan); beyond every earlier sample's reach AUC %.4f  NLL %.4f  (%zu)\n",
                 r.lookahead.auc, r.lookahead.nll, r.lookahead.n, r.lookahead_beyond.auc,
                 r.lookahead_beyond.nll, r.lookahead_beyond.n);
  std::fprintf(human,
               "time per scan  %.1f ms solve (max %.1f): ranking %.1f, transport %.1f, "
               "placement %.1f, refine %.1f; preparation %.1f (overlapped)\n",
               r.mean_wall_ms, r.max_wall_ms, r.mean_timing.ranking_ms, r.mean_timing.transport_ms,
               r.mean_timing.placement_ms, r.mean_timing.refine_ms, r.mean_timing.prepare_ms);
}

int run_map(const MapArgs& a, const std::string& device) {
  std::string dict_file = a.dict;
  const Dictionary dict = a.dict.empty() ? default_dictionary(&dict_file) : read_dictionary(a.dict);
  if (a.dict.empty())
    std::cerr << "potmap map: the default dictionary (" << default_dictionary_recipe() << ")\n";
  const std::vector<Scan> scans = scans_to_map(a, dict, dict_file);

  MapJob job = map_job(a);

  std::unique_ptr<Context> ctx;
  if (!a.cpu) ctx = std::make_unique<Context>(make_context(device));
  MapCheckpointing& ck = job.checkpoint;
  ck.path = a.checkpoint.empty() ? a.out + ".ckpt" : a.checkpoint;
  ck.every = a.checkpoint_every;
  ck.every_seconds = a.checkpoint_seconds;
  ck.resume = a.resume;
  if (ck.every == 0 && ck.every_seconds == 0 && !ck.resume) ck.path.clear();
  if (!ck.path.empty())
    ck.run = run_record(a, dict_file, dict, scans, job, ctx ? ctx->info().summary() : "").dump();
  std::cerr << "potmap map: " << dict.size() << " atoms, " << scans.size() << " scans, "
            << (a.refine ? "RePOT" : "POT") << ", " << a.sectors << " sectors, " << a.rotations
            << " rotations" << (a.cpu ? ", CPU reference" : "") << "\n";
  const MapJobResult r = potmap::job::run_map_job(ctx.get(), dict, scans, job);
  const KernelMap& overall = r.overall_map();
  // With what `potmap merge` needs (RePOT's information form, POT's anchor sums).
  write_mapper_map(*r.mapper, a.out);

  std::FILE* human = a.json == "-" ? stderr : stdout;
  print_summary(human, a, r);

  nlohmann::json j = nlohmann::json::parse(r.to_json());
  j["dictionary"] = a.dict.empty() ? "default: " + dict_file : a.dict;
  j["scans_file"] = a.scans;
  j["method"] = a.refine ? "RePOT" : "POT";
  j["device"] = ctx ? ctx->info().summary() : "CPU reference (Eigen, double)";
  j["map"] = a.out;
  if (!a.picture.empty() && !overall.empty()) {
    if (!ctx) throw ArgumentError("map: --picture needs the device (drop --cpu)");
    const MapPictures mp = potmap::job::write_map_pictures(
        *ctx, overall, a.picture, a.res, 5, dict.dim == 3 ? scans.front().origin()[2] : 0);
    std::fprintf(human,
                 "pictures       %zu x %zu at %.2f m; kernels coloured by 1/sqrt(gamma) "
                 "from %.2f m (dark) to %.2f m (bright):\n",
                 mp.width, mp.height, a.res, mp.min_length, mp.max_length);
    for (const auto& f : mp.files) std::fprintf(human, "               %s\n", f.c_str());
    j["pictures"] = mp.files;
  }
  if (!a.ros_map.empty()) {
    RosMapOptions ro;
    ro.resolution = a.ros_res;
    ro.z = dict.dim == 3 ? scans.front().origin()[2] : 0;
    const RosMapSummary rs = write_ros_map(ctx.get(), overall, a.ros_map, ro);
    std::fprintf(
        human,
        "ROS map        %zu x %zu at %.3f m: %zu occupied, %zu free, %zu unknown -> %s, %s\n",
        rs.width, rs.height, ro.resolution, rs.occupied, rs.free, rs.unknown, rs.yaml.c_str(),
        rs.pgm.c_str());
    j["ros_map"] = {rs.yaml, rs.pgm};
  }
  if (r.resumed_at > 0) j["resumed_at_scan"] = r.resumed_at;
  if (r.checkpoints > 0)
    j["checkpoints"] = {{"written", r.checkpoints}, {"seconds", r.checkpoint_seconds}};
  if (a.json == "-")
    std::cout << j.dump(1) << "\n";
  else if (!a.json.empty())
    write_text_atomically(a.json, j.dump(1) + "\n");
  // Only now is the run's work safe in its outputs.
  std::error_code ec;
  if (!ck.path.empty() && !a.keep_checkpoint) std::filesystem::remove(ck.path, ec);
  return 0;
}

}  // namespace

void add_half_life_option(CLI::App* cmd, double* half_life) {
  cmd->add_option("--half-life", *half_life,
                  "Forgetting: the persistent joint BHM's evidence halves every this many "
                  "seconds of the scans' time (their stamps; the scan index where a log has "
                  "none), so a place seen free after it was seen occupied (a car that left) reads "
                  "free within a few scans and a place no longer seen drifts back to uncertain "
                  "(default 0: never; docs/forgetting.md)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
}

void add_seed_rule_flag(CLI::App* cmd, bool* yield_fully) {
  cmd->add_flag("--seeds-yield-fully,!--seeds-keep-start", *yield_fully,
                "RePOT (default): a seed yields when its kernel comes within the solve's margin "
                "of a scan's samples, its mean too, so that the map there is BHM's (up to the "
                "solve's tolerance). "
                "--seeds-keep-start: a seed yields when a sample reaches its kernel and its mean "
                "starts that scan's bound (higher F1, at times lower AUC than BHM)");
}

// --checkpoint and the options of when to write one and whether to resume it.
void add_checkpoint_options(CLI::App* cmd, MapArgs& a) {
  cmd->add_option("--checkpoint", a.checkpoint,
                  "Checkpoint file: the overall map and everything needed to continue the run, "
                  "replaced atomically (default: OUT.ckpt; removed when the run ends well)");
  cmd->add_option("--checkpoint-every", a.checkpoint_every,
                  "Write the checkpoint after every N scans (default 0: not by count)");
  cmd->add_option("--checkpoint-seconds", a.checkpoint_seconds,
                  "Write it when T seconds have passed since the last one (default 30; 0: not by "
                  "time). With both 0 no checkpoint is written")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--resume", a.resume,
                "Continue from the checkpoint (if there is one) and end with the same overall "
                "map as a run that was never stopped; the same input and options are required");
  cmd->add_flag("--keep-checkpoint", a.keep_checkpoint,
                "Keep the checkpoint after the run ends (default: removed)");
}

void register_map(CLI::App& app, Runner& runner) {
  CLI::App* cmd = app.add_subcommand(
      "map",
      "Map scans by parameter optimal transport: every scan's sectors matched with the "
      "dictionary's atoms, their kernels transported and accumulated into an overall map");
  auto a = std::make_shared<MapArgs>();
  auto device = add_device_option(cmd);
  cmd->add_option("--dict", a->dict,
                  "Dictionary of atoms (potmap dict build; default: the built-in dictionary of "
                  "the simulated towns, built once and cached, `potmap dict default`)");
  cmd->add_option("--scans", a->scans, "Scans to map: any dataset potmap reads")->required();
  cmd->add_option("-o,--out", a->out, "Overall map to write (.potmap, .csv or .npz)")->required();
  cmd->add_flag("--refine", a->refine,
                "RePOT: one persistent joint BHM that every scan updates with its training "
                "samples, seeded by the transported kernels where no sample reached yet");
  cmd->add_flag("--per-scan-refine", a->per_scan_refine,
                "RePOT the old way: refine each scan's transported weights on their own and "
                "merge the refined maps (--refine-min-variance and --em apply to it)");
  add_seed_rule_flag(cmd, &a->seeds_yield_fully);
  add_half_life_option(cmd, &a->half_life);
  cmd->add_flag("--lookahead", a->lookahead,
                "With --refine: score each scan's held-out samples on the persistent map before "
                "the scan joins it, all of them and those beyond every earlier sample's reach "
                "(the JSON's lookahead; docs/transfer.md)");
  cmd->add_option("--refine-spacing", a->refine_spacing,
                  "RePOT's persistent map: metres between its kernels (default 0.5, about a "
                  "wall's thickness; a sample's cost grows as (1 / spacing)^dim)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--refine-prior-var", a->refine_prior_var,
                  "RePOT's persistent map: prior variance of its weights (default 10)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--refine-min-variance", a->refine_min_variance,
                  "RePOT per scan: floor on the transported weight variances (default 0)");
  cmd->add_option("--em", a->em, "RePOT per scan: BHM E-steps per scan (default 1)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--sectors", a->sectors, "Sectors per scan (default 5)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--rotations", a->rotations, "Rotations tried, evenly spaced (default 8)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--preset", a->preset,
                  "default (the library's defaults, which map real logs best) or paper (the "
                  "authors' rules, MapperOptions::paper(): exhaustive ranking, barycentric "
                  "placement, no wall clearance, summed overall map, for the options among "
                  "--ranking, --placement, --wall-clearance and --average not given)")
      ->check(CLI::IsMember({"default", "paper"}))
      ->capture_default_str();
  cmd->add_option("--ranking", a->ranking,
                  "exhaustive: every atom at every rotation (the paper's); indexed: nearest "
                  "atoms by signature at estimated rotations, coarse to fine (the default: the "
                  "exhaustive ranking's held-out scores in 3.5 to 9 times less time, "
                  "docs/pot-scale.md)")
      ->check(CLI::IsMember({"exhaustive", "indexed"}))
      ->capture_default_str();
  cmd->add_option("--candidates", a->candidates,
                  "Atoms ranked per sector after descriptor pre-selection (default 0: all)");
  cmd->add_option("--max-range", a->max_range,
                  "Sector radius, metres (default 0: the dictionary's)");
  cmd->add_option("--free-points", a->free_points,
                  "Free samples a side in the transport, thinned evenly (default 200)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--free-tolerance", a->free_tolerance,
                  "The free samples' transport stops at this marginal error (default 1e-2: "
                  "their plan is read as plan-weighted means of free-space logits)")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--hits-only", a->hits_only,
                "Transport hits only (SPEC step 4); kernels follow the nearest hit");
  cmd->add_option("--first", a->first, "Skip this many scans (default 0)");
  cmd->add_option("--max-scans", a->max_scans, "Map at most this many scans (default 0: all)");
  cmd->add_option("--holdout", a->holdout,
                  "Fraction of each scan's beams held out for scoring (default 0.2)")
      ->check(CLI::Range(0.0, 0.9));
  cmd->add_option("--seed", a->seed, "Seed of labelling, split and subsampling (default 0)");
  cmd->add_option("--wall-clearance", a->wall_clearance,
                  "Drop transported free-space kernels landing this close to the scan's hits and "
                  "wall kernels landing farther, metres (default 0.5, about the atoms' kernel "
                  "spacing; 0: off), barycentric kernels; kernels on the scan's samples take "
                  "--anchor-clearance");
  cmd->add_option("--anchor-clearance", a->anchor_clearance,
                  "Kernels on the scan's samples: drop free-sample kernels this close to the "
                  "scan's hits, metres (default 0.25, half the atoms' kernel spacing; 0: off)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--anchor-sweeps", a->anchor_sweeps,
                  "Kernels on the scan's samples: sweeps solving their weights together, walls "
                  "and free space (default 10; 0: each class's own partition)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--logit-gain", a->logit_gain,
                  "Kernels on the scan's samples: factor on the transported logits (default 1.5, "
                  "fitted on the Intel log; 1: the atoms' own)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--displacement-var", a->displacement_var,
                  "Weight variance added per m^2 the transport moved a kernel (default 0; the "
                  "experiments give RePOT's seeds 0.25)");
  cmd->add_option("--merge-radius", a->merge_radius,
                  "Overall map: merge kernels closer than this in gamma*d^2 (default 0.25)");
  cmd->add_option("--max-kernels", a->max_kernels, "Overall map: hard cap (default 0: none)");
  cmd->add_option("--placement", a->placement,
                  "Where transported kernels go: target_samples (on the scan's own samples "
                  "thinned to 0.5 m, carrying the atom's logit pulled back through the plan), "
                  "barycentric (the atoms' kernels' barycentric images, the authors' rule) or "
                  "auto (default: target_samples for POT, barycentric seeds for --refine)")
      ->check(CLI::IsMember({"auto", "barycentric", "target_samples"}));
  cmd->add_option("--average", a->average,
                  "Overall map: the support-weighted average of the scans' maps on a 0.25 m "
                  "grid (true, default) or their kernels summed with merging (false; "
                  "--merge-radius and --max-kernels apply to that one)")
      ->capture_default_str();
  cmd->add_option("--instantaneous", a->instantaneous,
                  "Folder for every scan's instantaneous map (scan_NNNNNN.potmap)");
  cmd->add_option(
      "--picture", a->picture,
      "Write PREFIX_prob.png, PREFIX_var.png and PREFIX_kernels.png of the overall map");
  cmd->add_option("--ros-map", a->ros_map,
                  "Also write the overall map for ROS map_server / nav2: this YAML and a PGM "
                  "beside it (unknown where no kernel reaches or the variance is the prior's)");
  cmd->add_option("--ros-res", a->ros_res, "ROS map resolution, metres per pixel (default 0.05)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--range-cut", a->range_cut,
                  "Returns farther than this (metres) become no-returns (default 0: none; the "
                  "experiments cut real logs at 20, the towns' range)")
      ->check(CLI::NonNegativeNumber);
  add_bag_options(cmd, a->bag);
  cmd->add_option("--res", a->res, "Picture resolution, metres per pixel (default 0.25)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--json", a->json, "Write the summary as JSON to this path ('-': stdout)");
  cmd->add_flag("--cpu", a->cpu, "Use the CPU reference, one problem at a time (slow)");
  cmd->add_flag("--no-pipeline", a->no_pipeline,
                "One scan at a time: no preparing the next scan, and no merging or RePOT update of "
                "the last one, beside the current scan's transfer (same maps)");
  cmd->add_flag("-q,--quiet", a->quiet, "No line per scan (a progress bar on a terminal)");
  add_checkpoint_options(cmd, *a);
  cmd->callback([&runner, a, device, cmd] {
    for (const char* o : {"--ranking", "--placement", "--wall-clearance", "--average"})
      if (cmd->count(o) > 0) a->given.insert(o);
    runner.action = [a, device] { return run_map(*a, *device); };
  });
}

}  // namespace potmap::cli
