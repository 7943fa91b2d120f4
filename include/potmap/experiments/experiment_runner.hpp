#pragma once
// The experiments' harness, which `potmap experiment` runs: the machinery shared by its runners:
// datasets by name, the methods chosen on the command line, one evaluation path for every (source,
// target, method, seed), aggregation, the paper-style table and the JSON record.

#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include "potmap/data/scan.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/experiments/figure_panels.hpp"
#include "potmap/experiments/score_breakdown.hpp"
#include "potmap/experiments/structure_score.hpp"
#include "potmap/experiments/wavemap_method.hpp"

#include "potmap/export.h"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::experiment::runner {

struct Settings {
  std::vector<std::uint64_t> seeds{0, 1, 2};
  std::size_t scans = 0;          ///< cap on scans taken from each dataset (0: all)
  std::size_t source_scans = 10;  ///< intra-domain: scans that form the source
  std::size_t sim_scans = 200;    ///< scans of each simulated drive
  double sim_spacing = 2.0;       ///< metres driven between simulated scans
  int moving = 40;                ///< moving vehicles of the dynamic scene
  std::string methods = "ogm,bhm,abhm,pot,repot";
  std::vector<double> ogm_cells{0.1, 0.5, 1, 5, 10};
  /// wavemap (builds with POTMAP_WITH_WAVEMAP only): one method per cell size.
  std::vector<double> wavemap_cells{0.1, 0.2};
  experiment::WavemapSetup wavemap;
  experiment::BhmSetup bhm;
  experiment::AbhmSetup abhm;
  experiment::PotSetup pot;   ///< POT and RePOT (refine is set per method)
  std::size_t rotations = 8;  ///< POT: rotations tried per atom, evenly spaced
  /// Every scan (real logs: 80 m lasers) cut at this range, metres, for every method: POT's
  /// sector radius and the simulated towns' range (0: keep each scan's own).
  double max_range = 20;
  double free_per_metre = 1.0;
  double holdout = 0.2;
  std::string json, figures;
  std::size_t figure_pixels = 400;
  /// Structural score (structure_score.hpp): raster cell and tolerance, metres, and the most
  /// cells a case's raster may have before it is coarsened.
  double structure_cell = 0.1;
  double structure_tolerance = 0.2;
  std::size_t structure_max_cells = 4000000;
  bool cpu = false;
  std::string device;
  /// Per-time-unit: time per scan the matched learners get, ms (0: POT's, measured on the
  /// first seed).
  double budget_ms = 0;
  std::string source;  ///< per-time-unit: POT's source (empty: the other targets)
  /// Look-ahead (default false; sequences, not instantaneous maps): each scan's held-out
  /// samples also scored on each method's map before that scan was learned (lookahead.hpp),
  /// all of them and those beyond every earlier training sample's reach.
  bool lookahead = false;
  /// The look-ahead's reach, metres (0, the default: twice the BHM's kernel spacing, the
  /// distance its kernels carry a sample: 1 m in 2D, 2 m on drives).
  double lookahead_reach = 0;
  /// Where the harness writes: a note per case and method to `err`; the tables to `out` (to
  /// `err` with json "-", whose JSON then goes to `out`). Null: nowhere.
  std::ostream* out = nullptr;
  std::ostream* err = nullptr;
  /// Opens the device named `device` (empty: a Context of that name, ContextOptions::device).
  std::function<Context(const std::string& device)> open_device;
};

/// One score of one method on one case (one seed; one scan for instantaneous maps).
struct Record {
  std::string source, target, method, group;
  std::uint64_t seed = 0;
  long scan = -1;  ///< instantaneous maps: the scan; -1 for a whole sequence
  Scores scores;
  /// Occupied cells against the OGM reference of the case (NaN: not scored, e.g. a 3D task).
  StructureScore structure;
  double structure_cell_m = NAN, structure_tolerance_m = NAN;
  double structure_s = 0;  ///< wall time of the score: the map's query on the raster, the EDTs
  std::size_t scans = 0;   ///< scans the method learned from
  double fit_s = 0, per_scan_ms = 0, query_s = 0;
  std::map<std::string, double> info;
  /// Look-ahead scores (Settings::lookahead; n 0 and NaN where the method has none): on every
  /// scan's held-out samples but the first scan's, and on those beyond reach.
  Scores lookahead{NAN, NAN, NAN, 0}, lookahead_beyond{NAN, NAN, NAN, 0};
  /// Held-out scores by range, height and kind of sample (3D tasks; score_breakdown.hpp).
  std::vector<experiment::BinScores> breakdown;
  std::vector<std::string> figures;
  /// Probability picture for the case's comparison figure (figure records only).
  std::shared_ptr<const experiment::Picture> picture;
};

/// The structural reference of one task: the OGM of its training scans at the raster's cell
/// size, as occupied cells of the raster, and its probability picture when figures are made.
struct StructureReference {
  experiment::StructureGrid grid;
  std::vector<std::uint8_t> occupied;
  std::shared_ptr<const experiment::Picture> picture;
  std::string name;  ///< panel label, e.g. "OGM 0.1 m (reference)"
  double seconds = 0;
};

class Harness {
 public:
  Harness(std::string experiment, Settings settings);
  ~Harness();
  Settings& settings() { return s_; }
  Context* context();

  /// A dataset by name: a file any reader takes, or sim:TOWN[+TOWN...] (built-in towns driven
  /// with this seed's route; simdyn:TOWN adds the moving vehicles). Capped by settings.scans.
  std::vector<Scan> load(const std::string& spec, std::uint64_t seed);
  /// The same, one vector per place (each simulated town on its own; a file is one place).
  std::vector<std::vector<Scan>> load_places(const std::string& spec, std::uint64_t seed);
  /// Short label of a dataset name (file stem or the spec itself).
  static std::string label(const std::string& spec);

  /// The methods of settings.methods (ogm: one per cell size; bhm; abhm; pot; repot; wavemap:
  /// one per cell size, in builds with wavemap).
  std::vector<experiment::Method> methods() const;

  /// Maps `target` (scans labelled from first_index on) with every method and scores the held-out
  /// samples; `source` is handed to transfer methods. Baselines are fitted once per (target,
  /// seed) and reused for other sources. Figures for the first seed.
  void run_case(const std::string& source_label, const std::vector<std::vector<Scan>>& source,
                const std::string& target_label, const std::vector<Scan>& target,
                std::int64_t first_index, std::uint64_t seed,
                const std::vector<experiment::Method>& methods);
  /// Instantaneous maps: every scan of `target` mapped on its own, scored on its own held-out
  /// beams (one record per scan).
  void run_instantaneous(const std::string& source_label,
                         const std::vector<std::vector<Scan>>& source,
                         const std::string& target_label, const std::vector<Scan>& target,
                         std::uint64_t seed, const std::vector<experiment::Method>& methods);
  /// Builds the OpenCL programs of the kernel learners and of POT on one scan so that no timing
  /// includes a program build.
  void warm_up(const std::vector<Scan>& scans);
  /// Mean time per scan, ms, of a method group's records on a target (NaN when none).
  double mean_ms_per_scan(const std::string& target_label, const std::string& group) const;
  /// Adds a record made elsewhere (per-time-unit calibration results).
  void add(Record r) { records_.push_back(std::move(r)); }
  /// settings.pot with the rotations applied and refine set (RePOT).
  experiment::PotSetup pot_setup(bool refine) const;
  /// wavemap's methods (settings.wavemap_cells); an ArgumentError in builds without wavemap.
  void add_wavemap(std::vector<experiment::Method>& out) const;
  /// Fits and scores one method on one task (no caching); figures when `figures` is set; the
  /// structural score against `reference` when it is not null; the breakdown of the scores
  /// when `places` (of the test samples) is not null; the look-ahead's when the task asks for
  /// one, `beyond` marking the test samples beyond reach.
  // The pictures' view of a task: 3D tasks top down over a height band about the sensors.
  experiment::PictureView picture_view(const experiment::MapTask& task) const;
  Record fit_and_score(const experiment::Method& m, const experiment::MapTask& task,
                       const LabelledPoints& test, bool figures, const std::string& case_label,
                       const StructureReference* reference = nullptr,
                       const experiment::SamplePlaces* places = nullptr,
                       const std::vector<std::uint8_t>* beyond = nullptr);
  /// The structural reference of a task (null for a task that is not 2D), with its picture
  /// when `picture` is set.
  std::shared_ptr<const StructureReference> make_reference(const experiment::MapTask& task,
                                                           bool picture) const;

  /// Aggregates, prints the table on stdout, writes JSON (settings.json) and removes the
  /// figures of group members that lost (OGM cell sizes). `spread` says what the ± is over.
  /// Writes one comparison figure per case with figures (EXPERIMENT_CASE_compare_prob.png):
  /// the OGM reference's probability, then the member of each group that represents it in the
  /// table (OGM: the chosen cell size), in method order.
  void finish(const std::string& spread);

 private:
  std::ostream& out();
  std::ostream& err();
  std::ostream nowhere_{nullptr};  // a stream without a buffer: what it is given is dropped
  /// Writes the side-by-side figure of each case (the reference, then each group's chosen
  /// member, chosen[case * groups + group], empty where none) and returns their JSON records.
  nlohmann::json write_compare_figures(
      const std::vector<std::pair<std::string, std::string>>& cases,
      const std::vector<std::string>& groups, const std::vector<std::string>& chosen) const;

  std::string experiment_;
  Settings s_;
  std::unique_ptr<Context> ctx_;
  bool ctx_made_ = false;
  std::map<std::string, std::vector<Scan>> files_;
  std::vector<Record> records_;
  std::map<std::string, std::vector<Record>> cache_;  // baselines by (target, seed)
  // Structural references by (target, seed, first scan), shared by every method and source.
  std::map<std::string, std::shared_ptr<const StructureReference>> references_;
  // The reference panel of each (source, target) case with figures.
  std::map<std::pair<std::string, std::string>, std::shared_ptr<const StructureReference>>
      compare_refs_;
  std::shared_ptr<experiment::AtomCache> atoms_ = std::make_shared<experiment::AtomCache>();
};

/// Splits `s` at `sep`, empty items dropped ("ogm,,bhm" -> ogm, bhm).
std::vector<std::string> split_list(const std::string& s, char sep);

}  // namespace potmap::experiment::runner
POTMAP_CXX_API_END
