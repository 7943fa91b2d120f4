#pragma once
// The mapping methods the experiments compare (paper Sec. IV), behind one interface so that every
// method sees the same training data and is scored on the same held-out samples.
//
// A MapTask holds what a method may learn from: the target scans reduced to their training
// beams, their training samples, the area, and (for transfer methods) source-domain scans. The
// held-out samples are never part of it. Method::fit returns a FittedMap: a probability (and,
// where the model has one, variance) evaluator plus the wall time learning took. Adding a method
// is one more factory returning a Method.

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>
#include "potmap/export.h"

#include "potmap/data/labelled_points.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/experiments/ogm.hpp"
#include "potmap/learn/abhm.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/averaged_map.hpp"
#include "potmap/pot/overall_map.hpp"
#include "potmap/pot/transfer.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

/// What a method may learn from. Scan index t of a sample = first_index + position in
/// train_scans.
struct MapTask {
  int dim = 2;
  std::int64_t first_index = 0;
  /// Source-domain scans, all beams (transfer methods), one vector per place: places have
  /// world frames of their own (three simulated towns overlap), so each gets its own source
  /// map. May be empty.
  std::vector<std::vector<Scan>> source;
  /// Names the source (and seed) so that transfer methods can reuse the atoms they built from
  /// it for other targets; empty: no reuse.
  std::string source_key;
  std::vector<Scan> train_scans;  ///< target scans with only their training beams, in order
  LabelledPoints train;           ///< labelled samples of those beams
  double lo[3] = {0, 0, 0};       ///< area the map must cover, metres
  double hi[3] = {0, 0, 0};
  std::uint64_t seed = 0;  ///< for the method's own random choices
  /// Look-ahead (null, the default: none; lookahead.hpp): held-out samples a method that
  /// learns the scans in order scores, before each scan, on the map as it stands (their scan
  /// indices say which scan; the first scan's are not scored). The samples are the caller's,
  /// never learned from.
  const LabelledPoints* lookahead = nullptr;
};

/// Labels `scans` with `labels` (holdout_fraction is what splits the beams) and builds the task
/// from their training beams; the held-out samples go to `test`. Scan i is labelled with scan
/// index first_index + i, so a sequence cut from a longer log keeps the log's split. The area is
/// the bounds of the training samples, clipped to `area_margin` metres around the hits (far free
/// samples of no-return beams would otherwise stretch it to the sensor's range).
MapTask make_task(const std::vector<Scan>& scans, const LabelOptions& labels, LabelledPoints& test,
                  double area_margin = 5.0, std::int64_t first_index = 0);

/// The range cut of data/labelling.hpp, where the experiments have always found it.
using potmap::limit_range;

/// A learned map as the evaluation sees it.
struct FittedMap {
  /// Probability at n points (n * dim coordinates) into prob; var, if not null, receives the
  /// model's variance where it has one (NaN where it has none, e.g. an occupancy grid).
  std::function<void(const double* points, std::size_t n, double* prob, double* var)> query;
  /// Whether the model has observed each of n points (n * dim coordinates; 1 = observed): an
  /// occupancy grid's cell was updated by a beam, a kernel map's kernels there moved off their
  /// prior (io/known_cells.hpp). Empty: every point counts as observed. Pictures show the rest
  /// grey.
  std::function<void(const double* points, std::size_t n, std::uint8_t* known)> known;
  /// The kernels, for kernel maps (figures); null for other models.
  std::shared_ptr<const KernelMap> kernels;
  double fit_seconds = 0;              ///< wall time of learning, all scans of the task
  std::map<std::string, double> info;  ///< method-specific numbers (kernels, cell size, steps)
  /// With MapTask::lookahead: per sample of it, the probability the map gave before the
  /// sample's scan was learned (NaN where not scored). Empty: the method has no look-ahead
  /// (it learns every scan at once: the diagonal BHM, ABHM). Its scoring is not part of
  /// fit_seconds.
  std::vector<float> lookahead;
};

/// A mapping method.
struct Method {
  std::string name;   ///< row label, e.g. "BHM" or "OGM 0.5 m"
  std::string group;  ///< methods of one group compete (OGM: best cell size); default = name
  /// Whether fit reads task.source (transfer methods). The others give the same map whatever
  /// the source, so a runner may fit them once per target.
  bool uses_source = false;
  /// Learns a map from the task. `ctx` may be null: CPU references where the method has them.
  std::function<FittedMap(Context* ctx, const MapTask& task)> fit;
};

/// OctoMap occupancy grid with `resolution` metres cells; every training beam of every scan
/// inserted in order (group "OGM").
Method ogm_method(double resolution);

/// BHM settings of the experiments: kernels on a grid over the task's area.
struct BhmSetup {
  /// The joint posterior of bhm_joint.hpp (default true: overlapping kernels, a continuous and
  /// calibrated map); false: the diagonal posterior of bhm.hpp with narrow, disjoint kernels.
  bool joint = true;
  double spacing = 0.5;  ///< grid spacing, metres (default 0.5: see JointBhmOptions::spacing)
  /// Width, 1/m^2; 0: the model's default for the spacing (joint: -ln(0.19) / spacing^2, so
  /// neighbours overlap; diagonal: 8 / spacing^2, as `potmap learn bhm`).
  double gamma = 0;
  std::size_t count = 0;  ///< if > 0: spacing chosen to give about this many kernels
  /// EM settings: em_iterations per scan (default 3) for both models; tau (the feature
  /// cut-off) for the diagonal model only, the joint one keeping JointBhmOptions::tau.
  BhmOptions options;
  /// Prior weight variance; 0: the model's default (joint 10, diagonal 1e4).
  double prior_var = 0;
  /// A bias weight with the same prior (default true): it sets the level of unobserved space
  /// (without it the gaps between narrow kernels sit at p = 0.5 exactly).
  bool bias = true;
  /// Joint model: each scan's samples gathered per voxel of this edge, metres, before they are
  /// learned (aggregate_voxels; default 0: every sample on its own, as the 2D defaults). 3D
  /// drives use half the kernel spacing (frame_setup_3d, drive defaults).
  double voxel = 0;
  /// Joint model: JointBhmOptions::tau, solve_margin and cg_tolerance where set (defaults 0,
  /// -1 and 0: the learner's own, chosen on the 2D logs). See drive_bhm_setup() for 3D.
  double tau = 0;
  int solve_margin = -1;
  double cg_tolerance = 0;
};

/// The joint learner's options of `setup` (spacing, width, prior variance when set, bias, EM
/// iterations); `setup.count` is ignored (learn_bhm derives the spacing from it).
JointBhmOptions joint_bhm_options(const BhmSetup& setup);

/// Learns the BHM of `setup` on a grid over [lo, hi] from `samples`, scan by scan (the
/// posterior after one scan is the prior of the next). The diagonal model runs on `ctx` when
/// it is given; the joint one on the host. `spacing_out`/`gamma_out` receive what was used;
/// `learner_bytes_out` the joint learner's memory at the end (JointBhm::memory_bytes; the
/// diagonal model: the map's kernels). `before_scan` (joint model only; optional): called with
/// the learner before each scan's update (the look-ahead).
KernelMap learn_bhm(
    Context* ctx, const BhmSetup& setup, int dim, const double lo[3], const double hi[3],
    const LabelledPoints& samples, double* spacing_out = nullptr, double* gamma_out = nullptr,
    std::size_t* learner_bytes_out = nullptr,
    const std::function<void(const JointBhm&, std::int64_t scan)>& before_scan = {});

/// Online BHM: the posterior after one scan is the prior of the next (bhm_update_sequential).
Method bhm_method(const BhmSetup& setup, const std::string& name = "BHM");

/// ABHM settings: Halton kernels over the task's area, trained offline on all training samples.
struct AbhmSetup {
  std::size_t count = 1000;  ///< kernels
  double gamma0 = 1.0;       ///< starting width, 1/m^2
  std::size_t steps = 2450;  ///< Adam steps
  std::size_t batch = 256;   ///< samples per step
};
Method abhm_method(const AbhmSetup& setup, const std::string& name = "ABHM");

/// POT / RePOT (paper Sec. III, SPEC section 4) as a method: a dictionary of atoms is built
/// from the task's source (a map learned on each source place, atoms cut from some of its
/// scans), then the target's scans are transferred one by one in order, each from its own
/// training samples only (the task's, never a held-out beam), and the instantaneous maps are
/// accumulated into an overall map (AveragedMap by default, OverallMap's merging on request). The
/// fitted map is the overall map (for a one-scan task: that scan's instantaneous map). fit_seconds
/// is the transfer of the target scans (the host preparation of scan i+1 overlaps the solve of scan
/// i, as map_scans does); building the dictionary is offline work and reported in info["atoms_s"].
struct PotSetup {
  /// Transfer settings; pot.refine switches RePOT on; pot.seed is task.seed. Default: the
  /// library's (PotOptions' defaults are the settings these experiments found best): kernels
  /// placed on the target's own samples (PotPlacement::target_samples: on the four Radish logs
  /// AUC +0.012 to +0.042 and NLL -0.017 to -0.040 over the barycentric placement with the
  /// averaged overall map, docs/pot-measurements.md) and a wall clearance of 0.5 m (about one
  /// kernel spacing of the BHM atoms). No displacement variance: with anchors on the target's
  /// samples the plan's spread of source logits already widens poor matches, and the move's
  /// variance made NLL worse (CSAIL 0.295 -> 0.312 at 0.25 per m^2). The indexed ranking
  /// (PotRanking::indexed): with these kernels it scores as the exhaustive one at a fraction of
  /// its time, and its time barely grows with the dictionary (docs/pot-scale.md).
  /// PotOptions::paper() runs the authors' rules instead.
  PotOptions pot;
  /// RePOT's seeds: placement and displacement variance of the transported kernels that seed
  /// the persistent map (defaults barycentric and 0.25 per m^2, a kernel moved 2 m gains
  /// variance 1). Seeds matter only where no sample reaches a kernel, which kernels on the
  /// target's samples never are; barycentric images reach past the scan's samples.
  PotPlacement seed_placement = PotPlacement::barycentric;
  double seed_displacement_variance = 0.25;
  /// Map the atoms' kernels come from: "bhm" (default; online BHM on a grid, fast) or "abhm"
  /// (the paper's choice: varied widths, much slower to learn).
  std::string atom_map = "bhm";
  /// The source map of "bhm" atoms: the experiments' BHM, bias included (default). Atoms
  /// carry no bias: kernels at samples take the map's whole logit there, bias and all, so that
  /// a wall reads what the source map reads at its walls (a bias-free source BHM reads about
  /// +0.7 there, one with its bias about +1.3; CSAIL NLL 0.320 -> 0.298).
  BhmSetup atom_bhm;
  AbhmSetup atom_abhm = [] {
    AbhmSetup a;
    a.count = 3000;
    return a;
  }();
  /// Source scans per place that atoms are cut from, evenly spaced over the place's drive
  /// (default 10; 0: all). Every source scan still trains the source map. Ranking cost grows
  /// with atoms x rotations per sector.
  std::size_t atom_scans = 10;
  /// RePOT's overall map (default true): one persistent joint BHM over the task's area (the
  /// experiments' BHM, `target_bhm`), which every scan updates with its own training samples,
  /// its kernels' priors seeded from the scan's transported kernels where no sample has
  /// reached them yet (until one does: JointBhmOptions::seeds_yield). false: each scan refined
  /// on its own (PotOptions::refine) and the instantaneous maps merged into an OverallMap, as
  /// POT's.
  bool persistent_refine = true;
  BhmSetup target_bhm;  ///< the persistent RePOT map (joint; the spacing and prior of BHM)
  /// Seeded prior variances are at least this (weight units squared; default 10, the joint
  /// BHM's prior: a seed then moves the prior mean only). Transported variances say how sure
  /// the source was, not how well the atom fits here; smaller floors (1, 3) made RePOT worse
  /// than BHM on the real logs (docs/results.md).
  double seed_min_variance = 10.0;
  /// Seeds of the persistent map yield to data (JointBhmOptions::seeds_yield; default true:
  /// a seed lasts until a sample reaches its kernel). false: seeds stay the kernels' priors
  /// under the data, as before (RePOT then lost to BHM on half the real-log runs,
  /// docs/pot-measurements.md).
  bool seeds_yield = true;
  /// Seeds yield fully (JointBhmOptions::seeds_yield_fully; default true: within the solve's
  /// margin of the data RePOT's map is the BHM's, so it is never worse than BHM on held-out
  /// beams). false: a seeded mean starts the first scan's bound where a sample reaches it.
  bool seeds_yield_fully = true;
  /// Sector cut and kernel filter of the atoms. Default: kernels at the atoms' own samples,
  /// thinned to 0.5 m (DictionaryOptions::kernels_at_samples).
  DictionaryOptions dictionary = [] {
    DictionaryOptions d;
    d.kernels_at_samples = 0.5;
    return d;
  }();
  /// How POT combines its instantaneous maps (default average: AveragedMap, each scan's logit
  /// weighted by its support; sum: OverallMap, kernels summed with merging, the authors' rule,
  /// which lets one scan's free space erase another's walls: docs/pot-measurements.md).
  enum class Combine { average, sum };
  Combine combine = Combine::average;
  AveragedMapOptions averaged;  ///< the averaged overall map (combine average)
  /// Merging of POT's overall map (combine sum). Default merge radius 0.5 (d^2 gamma; 0.27 m for
  /// the joint BHM's kernels): kernels at samples of successive scans land closer than the BHM
  /// grid.
  OverallMapOptions overall = [] {
    OverallMapOptions o;
    o.merge_radius = 0.5;
    return o;
  }();
  /// Prepare the next scan, place the last one's kernels, and add a scan to the overall map
  /// (RePOT's update, POT's averaged map) on other threads, beside the current scan's ranking
  /// and transport (default true; false: one scan at a time, the same maps).
  bool pipeline = true;
  /// Called with every target scan's transfer, in order (benchmarks read the chosen atoms);
  /// may be empty.
  std::function<void(std::size_t scan, const ScanTransfer& transfer)> on_scan;
};

/// Atoms shared between the POT and RePOT methods of one run, keyed by MapTask::source_key.
struct AtomCache {
  std::map<std::string, std::shared_ptr<const Dictionary>> dictionaries;
  std::map<std::string, double> build_seconds;
};

/// Builds the dictionary of `setup` from source places (labels: every beam, `seed`).
/// `map_kernels`, if not null, receives the total number of kernels of the source maps.
Dictionary build_atoms(Context* ctx, const std::vector<std::vector<Scan>>& places,
                       const PotSetup& setup, std::uint64_t seed,
                       std::size_t* map_kernels = nullptr);

/// The training samples POT gets for scan i of the task (scan index first_index + i): those of
/// task.train with that index, within `range` metres of the scan's sensor (horizontally).
LabelledPoints scan_training_samples(const MapTask& task, std::size_t i, double range);

/// POT (setup.pot.refine false) or RePOT (true); uses_source. `cache` may be null.
Method pot_method(const PotSetup& setup, const std::string& name,
                  std::shared_ptr<AtomCache> cache = nullptr);

/// A kernel map as a FittedMap (device evaluator when ctx is given, exact CPU sum otherwise).
FittedMap kernel_fitted_map(Context* ctx, std::shared_ptr<const KernelMap> map);

/// A fitted map's probabilities at labelled points, each in [0, 1]; query_seconds receives the
/// wall time of the query.
std::vector<double> query_map(const FittedMap& map, const LabelledPoints& test,
                              double* query_seconds = nullptr);

/// Scores a fitted map on labelled points; query_seconds receives the wall time of the query.
Scores score_map(const FittedMap& map, const LabelledPoints& test, double* query_seconds = nullptr);

/// Figures of a fitted map of dimension `dim` over [lo, hi] (x, y; metres; a 3D map at the
/// height halfway between lo[2] and hi[2]), at most max_pixels along the longer side:
/// PREFIX_prob.png (viridis), PREFIX_var.png (the logit variance v coloured v / (1 + v), magma;
/// only when the model has one) and, for kernel maps, PREFIX_kernels.png (each kernel a dot at
/// its position coloured by log10 gamma, viridis from the smallest to the largest width). Places
/// the model has not observed (FittedMap::known) are grey. Each picture is captioned
/// (picture_caption.hpp): a title with `name` (the method, when given), the quantity and a 3D
/// map's height above, the colour bar, the never-observed grey and a metres scale bar below.
/// Returns the files written.
std::vector<std::string> write_figures(const FittedMap& map, int dim, const double lo[3],
                                       const double hi[3], const std::string& prefix,
                                       std::size_t max_pixels = 400, const std::string& name = "");

}  // namespace potmap::experiment
POTMAP_CXX_API_END
