// `potmap map`: map scans by POT or RePOT with a dictionary of atoms (SPEC section 4).
#include <cmath>
#include <cstdio>
#include <iostream>

#include "commands.hpp"
#include "map_pipeline.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/pot/dictionary_io.hpp"
#include "potmap/render/kernel_picture.hpp"
#include "progress.hpp"

namespace potmap::cli {

namespace {

constexpr double kPi = 3.14159265358979323846;

struct MapArgs {
  std::string dict, scans, out, instantaneous, json, picture;
  bool refine = false, per_scan_refine = false, cpu = false, quiet = false, no_pipeline = false,
       hits_only = false;
  double refine_min_variance = 0;
  int sectors = 5, rotations = 8, em = 1;
  double max_range = 0, holdout = 0.2, res = 0.25;
  std::size_t first = 0, max_scans = 0, candidates = 0, max_kernels = 0;
  std::size_t free_points = PotOptions{}.transport_free_points;
  double merge_radius = OverallMapOptions{}.merge_radius;
  double wall_clearance = 0, displacement_var = 0;
  std::uint64_t seed = 0;
  std::string ranking = "exhaustive";
};

int run_map(const MapArgs& a, const std::string& device) {
  const Dictionary dict = read_dictionary(a.dict);
  Dataset data = read_dataset(a.scans);
  if (a.first >= data.scans.size())
    throw ArgumentError("map: --first " + std::to_string(a.first) + " but " + a.scans + " has " +
                        std::to_string(data.scans.size()) + " scans");
  std::vector<Scan> scans(data.scans.begin() + static_cast<long>(a.first), data.scans.end());
  if (a.max_scans > 0 && scans.size() > a.max_scans) scans.resize(a.max_scans);
  if (scans.front().dim != dict.dim)
    throw ArgumentError("map: " + a.scans + " holds " + std::to_string(scans.front().dim) +
                        "D scans, the dictionary " + a.dict + " is " + std::to_string(dict.dim) +
                        "D");

  MapJob job;
  PotOptions& po = job.mapper.pot;
  po.sectors = a.sectors;
  po.max_range = a.max_range;
  po.rotations.clear();
  for (int i = 0; i < a.rotations; ++i) po.rotations.push_back(2 * kPi * i / a.rotations);
  po.refine = a.refine;
  job.mapper.persistent_refine = !a.per_scan_refine;
  po.refine_min_variance = a.refine_min_variance;
  po.refine_bhm.em_iterations = a.em;
  po.candidates = a.candidates;
  po.ranking = a.ranking == "indexed" ? PotRanking::indexed : PotRanking::exhaustive;
  po.transport_free_points = a.free_points;
  po.transport_free = !a.hits_only;
  po.wall_clearance = a.wall_clearance;
  po.displacement_variance = a.displacement_var;
  po.seed = a.seed;
  job.mapper.labels.holdout_fraction = a.holdout;
  job.mapper.labels.seed = a.seed;
  job.mapper.pipeline = !a.no_pipeline;
  job.overall.merge_radius = a.merge_radius;
  job.overall.max_kernels = a.max_kernels;
  job.instantaneous_dir = a.instantaneous;
  job.verbose = !a.quiet;

  std::unique_ptr<Context> ctx;
  if (!a.cpu) ctx = std::make_unique<Context>(make_context(device));
  std::cerr << "potmap map: " << dict.size() << " atoms, " << scans.size() << " scans, "
            << (a.refine ? "RePOT" : "POT") << ", " << a.sectors << " sectors, " << a.rotations
            << " rotations" << (a.cpu ? ", CPU reference" : "") << "\n";
  const MapJobResult r = run_map_job(ctx.get(), dict, scans, job);
  const KernelMap& overall = r.overall_map();
  write_map(overall, a.out);

  std::FILE* human = a.json == "-" ? stderr : stdout;
  std::fprintf(human, "scans          %zu (%s)\n", r.scans, a.refine ? "RePOT" : "POT");
  std::fprintf(human, "overall map    %zu kernels, %.1f MB%s -> %s\n", r.overall_kernels(),
               r.overall_memory_bytes() / 1e6, r.repot ? " (persistent joint BHM)" : "",
               a.out.c_str());
  std::fprintf(human, "instantaneous  ACC %.4f  AUC %.4f  NLL %.4f  (%zu held-out samples)\n",
               r.instantaneous.acc, r.instantaneous.auc, r.instantaneous.nll, r.instantaneous.n);
  std::fprintf(human, "overall        ACC %.4f  AUC %.4f  NLL %.4f\n", r.overall_scores.acc,
               r.overall_scores.auc, r.overall_scores.nll);
  std::fprintf(human,
               "time per scan  %.1f ms solve (max %.1f): ranking %.1f, transport %.1f, "
               "placement %.1f, refine %.1f; preparation %.1f (overlapped)\n",
               r.mean_wall_ms, r.max_wall_ms, r.mean_timing.ranking_ms, r.mean_timing.transport_ms,
               r.mean_timing.placement_ms, r.mean_timing.refine_ms, r.mean_timing.prepare_ms);

  nlohmann::json j = r.to_json();
  j["dictionary"] = a.dict;
  j["scans_file"] = a.scans;
  j["method"] = a.refine ? "RePOT" : "POT";
  j["device"] = ctx ? ctx->info().summary() : "CPU reference (Eigen, double)";
  j["map"] = a.out;
  if (!a.picture.empty() && !overall.empty()) {
    double lo[3], hi[3];
    overall.bounds(lo, hi);
    RasterSpec spec;
    spec.xmin = lo[0] - 5;
    spec.xmax = hi[0] + 5;
    spec.ymin = lo[1] - 5;
    spec.ymax = hi[1] + 5;
    spec.resolution = a.res;
    spec.z = dict.dim == 3 ? scans.front().origin()[2] : 0;
    if (!ctx) throw ArgumentError("map: --picture needs the device (drop --cpu)");
    RasterOptions ro;
    ro.write_npy = false;
    ro.progress = terminal_progress("picture");
    const RasterSummary rs = rasterize(*ctx, overall, spec, a.picture, ro);
    const std::string kp = a.picture + "_kernels.png";
    const KernelPictureSummary ks = write_kernel_picture(ctx.get(), overall, spec, kp);
    std::vector<std::string> files = rs.files;
    files.push_back(kp);
    std::fprintf(human,
                 "pictures       %zu x %zu at %.2f m; kernels coloured by 1/sqrt(gamma) "
                 "from %.2f m (dark) to %.2f m (bright):\n",
                 rs.width, rs.height, a.res, ks.min_length, ks.max_length);
    for (const auto& f : files) std::fprintf(human, "               %s\n", f.c_str());
    j["pictures"] = files;
  }
  if (a.json == "-")
    std::cout << j.dump(1) << "\n";
  else if (!a.json.empty())
    write_text_atomically(a.json, j.dump(1) + "\n");
  return 0;
}

}  // namespace

void register_map(CLI::App& app, Runner& runner) {
  CLI::App* cmd = app.add_subcommand(
      "map",
      "Map scans by parameter optimal transport: every scan's sectors matched with the "
      "dictionary's atoms, their kernels transported and accumulated into an overall map");
  auto a = std::make_shared<MapArgs>();
  auto device = add_device_option(cmd);
  cmd->add_option("--dict", a->dict, "Dictionary of atoms (potmap dict build)")->required();
  cmd->add_option("--scans", a->scans, "Scans to map: any dataset potmap reads")->required();
  cmd->add_option("-o,--out", a->out, "Overall map to write (.potmap, .csv or .npz)")->required();
  cmd->add_flag("--refine", a->refine,
                "RePOT: one persistent joint BHM that every scan updates with its training "
                "samples, seeded by the transported kernels where no sample reached yet");
  cmd->add_flag("--per-scan-refine", a->per_scan_refine,
                "RePOT the old way: refine each scan's transported weights on their own and "
                "merge the refined maps (--refine-min-variance and --em apply to it)");
  cmd->add_option("--refine-min-variance", a->refine_min_variance,
                  "RePOT per scan: floor on the transported weight variances (default 0)");
  cmd->add_option("--em", a->em, "RePOT per scan: BHM E-steps per scan (default 1)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--sectors", a->sectors, "Sectors per scan (default 5)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--rotations", a->rotations, "Rotations tried, evenly spaced (default 8)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--ranking", a->ranking,
                  "exhaustive: every atom at every rotation (the paper's); indexed: nearest "
                  "atoms by signature at estimated rotations, coarse to fine (large "
                  "dictionaries)")
      ->check(CLI::IsMember({"exhaustive", "indexed"}))
      ->capture_default_str();
  cmd->add_option("--candidates", a->candidates,
                  "Atoms ranked per sector after descriptor pre-selection (default 0: all)");
  cmd->add_option("--max-range", a->max_range,
                  "Sector radius, metres (default 0: the dictionary's)");
  cmd->add_option("--free-points", a->free_points,
                  "Free samples a side in the transport, thinned evenly (default 200)")
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
                  "wall kernels landing farther, metres (default 0: off; 0.5 for indoor logs "
                  "with atoms at samples)");
  cmd->add_option("--displacement-var", a->displacement_var,
                  "Weight variance added per m^2 the transport moved a kernel (default 0; 0.25 "
                  "in the experiments)");
  cmd->add_option("--merge-radius", a->merge_radius,
                  "Overall map: merge kernels closer than this in gamma*d^2 (default 0.25)");
  cmd->add_option("--max-kernels", a->max_kernels, "Overall map: hard cap (default 0: none)");
  cmd->add_option("--instantaneous", a->instantaneous,
                  "Folder for every scan's instantaneous map (scan_NNNNNN.potmap)");
  cmd->add_option(
      "--picture", a->picture,
      "Write PREFIX_prob.png, PREFIX_var.png and PREFIX_kernels.png of the overall map");
  cmd->add_option("--res", a->res, "Picture resolution, metres per pixel (default 0.25)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--json", a->json, "Write the summary as JSON to this path ('-': stdout)");
  cmd->add_flag("--cpu", a->cpu, "Use the CPU reference, one problem at a time (slow)");
  cmd->add_flag("--no-pipeline", a->no_pipeline,
                "Prepare each scan only after the previous one (no second thread)");
  cmd->add_flag("-q,--quiet", a->quiet, "No line per scan (a progress bar on a terminal)");
  cmd->callback(
      [&runner, a, device] { runner.action = [a, device] { return run_map(*a, *device); }; });
}

}  // namespace potmap::cli
