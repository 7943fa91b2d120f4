#pragma once
// Parameter Optimal Transport (SPEC section 4, steps 2 to 7; paper Sec. III, Algorithm 1):
// map a scan by transporting kernels from a dictionary of atoms instead of learning them.
//
// For every sector of the target scan, every (atom, rotation) candidate is ranked by the
// entropic OT cost between subsampled points (all candidates of the scan in one batched
// Sinkhorn launch); the best candidate of each sector is transported with the high-quality
// setting (batched across sectors); its kernels follow the out-of-sample barycentric map, are
// dropped beyond max_range of the sensor, unscaled and placed in the world frame. RePOT then
// refines the transported weights with one BHM update on the scan's own training samples.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/export.h"
#include "potmap/learn/bhm.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/ot/sinkhorn.hpp"
#include "potmap/pot/atom_descriptor.hpp"
#include "potmap/pot/atom_index.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// How each target sector's candidates are ranked.
enum class PotRanking {
  /// Every atom (or the `candidates` pre-selected ones) at every rotation of
  /// PotOptions::rotations, one Sinkhorn solve per term each: the paper's eq. 6. Cost grows
  /// with atoms x rotations.
  exhaustive,
  /// The PotOptions::index_neighbours atoms nearest in an AtomIndex, each at its estimated
  /// rotations (snapped to PotOptions::rotations by default), ranked coarse to fine. Cost
  /// nearly flat in the dictionary's size.
  indexed,
};

/// Where a scan's transported kernels are placed (PotOptions::placement).
enum class PotPlacement {
  /// Each atom kernel moves to its sample's barycentric image (SPEC step 5, the authors' rule).
  barycentric,
  /// Kernels on the target's own samples, thinned to PotOptions::anchor_spacing; each reads the
  /// plan backwards: the atom's logit at the source samples coupled with it, averaged by the plan
  /// (host/pot/placement_at_samples.cpp).
  target_samples,
};

/// The defaults are the settings that map real logs best, those `potmap mapping` runs: the
/// indexed ranking, kernels on the target's own samples and a 0.5 m wall clearance (on the
/// Intel log, 60 scans from the default dictionary: overall AUC / NLL 0.958 / 0.211 against
/// 0.880 / 1.302 with the authors' rules, in a fraction of the time). paper() gives the
/// authors' rules (SPEC section 4), as the paper's experiments ran them.
struct PotOptions {
  /// The authors' rules (SPEC section 4): the exhaustive ranking (eq. 6), barycentric
  /// placement and no wall clearance; every other field as the defaults.
  static PotOptions paper();

  /// Target cut: sectors per scan (default 5) and max_range, metres (0, the default: the
  /// dictionary's). The scale is taken from the dictionary.
  int sectors = 5;
  double max_range = 0;
  std::size_t min_samples = 4;  ///< target sectors with fewer samples are skipped
  /// Transported kernels that land farther than this from every training sample of their
  /// target sector, metres, are dropped (0, the default: no limit). The scan says nothing of
  /// the places it did not see; a kernel carried there describes the atom's place, not this one.
  double max_sample_distance = 0;

  /// Rotations tried for every atom by the exhaustive ranking, radians about the atom's
  /// centroid (vertical axis in 3D). Default: 45 degree steps, 8 rotations.
  std::vector<double> rotations = {0.0,
                                   0.7853981633974483,
                                   1.5707963267948966,
                                   2.356194490192345,
                                   3.141592653589793,
                                   3.9269908169872414,
                                   4.71238898038469,
                                   5.497787143782138};

  // Ranking (eq. 6, 7): points subsampled from each side, unnormalised scaled cost.
  std::size_t rank_hits = 200;  ///< at most this many hits a side
  std::size_t rank_free = 50;   ///< at most this many free samples a side
  double rank_epsilon = 0.005;  ///< cost units (scaled metres squared)
  int rank_max_iterations = 1000;
  double rank_tolerance = 1e-7;  ///< on ||P 1 - a||_1

  // High-quality transport of the best candidate: cost divided by its maximum. Points beyond
  // the caps are thinned evenly (one per cell of the finest grid that leaves few enough), not at
  // random: evenly thinned samples of two matching places look alike, so their plan is cleaner
  // and converges sooner.
  std::size_t transport_points = 1500;  ///< at most this many hits a side (the authors' cap)
  /// At most this many free samples a side in the transport (default 200). The authors' cap of
  /// 1500 covers a sector's free samples too (about 1000 per sector of a 360-beam scan: a
  /// 1000 x 1000 problem per sector); 200 evenly thinned ones keep the map's scores at a small
  /// fraction of the time (docs/pot-measurements.md).
  std::size_t transport_free_points = 200;
  double transport_epsilon = 0.0005;  ///< unitless (normalised cost)
  int transport_max_iterations = 2000;
  /// On ||P 1 - a||_1 (default 1e-5: float32's marginal error floors near 1e-7 at 1500 x 1500).
  /// From 1e-6 up the transport is solved in single-precision sums (single_sums_reach()).
  double transport_tolerance = 1e-5;
  /// The free samples' plan (transport_free) stops at this ||P 1 - a||_1 instead (default 1e-2).
  /// Free space reads as the plan-weighted mean of the atom's logit at the coupled free samples,
  /// which are much alike, so the plan's last digits change no map: on the Intel and CSAIL logs
  /// and a simulated town's 360-beam scans, 1e-2 scores as 1e-5 to three decimals (AUC, NLL)
  /// with half the free problems' iterations, which are nine tenths of the transport's work
  /// (docs/pot-scale.md). The hits' plan, which puts the walls, keeps transport_tolerance.
  double transport_free_tolerance = 1e-2;
  /// Transport the free samples too (default true): a second plan between the winner's free
  /// samples and the target's, and every kernel follows the sample nearest to it, hit or free,
  /// through that sample's plan. The SPEC (step 4) transports hits only; the paper (Sec. III-A,
  /// III-B) associates kernels with the LIDAR samples, hits or free. With hits only, kernels in
  /// free space keep their offset from the nearest hit and miss the target's free space when
  /// the two sectors' hits lie at different distances from the sensor. false: the SPEC's rule.
  bool transport_free = true;
  /// Wall clearance of barycentric kernels, metres (default 0.5, about one kernel spacing of
  /// the BHM atoms; 0: off, the authors' rule; target_samples: anchor_clearance instead).
  /// > 0: a transported kernel with a negative weight (free-space
  /// evidence) that lands within this distance of one of the target sector's hits is dropped,
  /// and so is one with a positive weight (wall evidence) that lands farther than this from
  /// every hit. The two plans move hits onto hits and free samples onto free samples, but not
  /// the free space along a wall onto the free space along the target's wall: without the
  /// clearance, free-space kernels erase the target's walls (on Intel, overall AUC 0.880
  /// without it against 0.943 with it, docs/pot-measurements.md). RePOT's seeds and the drive
  /// mapper's transfer are barycentric.
  double wall_clearance = 0.5;
  /// Weight variance added per square metre that the transport moved a kernel beyond the
  /// chosen rotation (weight units^2 / m^2; 0, the default: none). The plan moves each kernel
  /// by its sample's barycentric image; in an atom that matches the place, samples barely move,
  /// while a poor match has to drag them far. The transported weight then says so.
  double displacement_variance = 0;
  /// Where kernels are placed (default target_samples: on the target's thinned samples, which
  /// keeps walls on the target's walls where a barycentric image would land between two walls
  /// the plan split a sample across; on the four Radish logs AUC +0.012 to +0.042 over the
  /// barycentric placement, docs/pot-measurements.md). The wall clearance then drops
  /// free-sample anchors near the sector's hits, and the displacement variance grows with the
  /// plan's mean squared move into each anchor. barycentric: the authors' rule (paper()).
  /// RePOT's persistent map places its seeds by MapperOptions::seed_placement instead.
  PotPlacement placement = PotPlacement::target_samples;
  /// target_samples: one anchor per cell of this edge, hits and free samples apart (metres;
  /// default 0.5, the source BHM's kernel spacing: kernels no denser than the maps they carry).
  double anchor_spacing = 0.5;
  /// target_samples: free-sample anchors within this distance of one of the sector's hits are
  /// dropped, metres (default 0.25, half the atoms' kernel spacing; 0: none dropped). With the
  /// anchors' weights solved together (anchor_sweeps) a free anchor this near a wall no longer
  /// erases it, and free space reaches closer to the walls: on the whole Intel log 0.25 m
  /// scored NLL 0.205 against 0.5 m's 0.229 (both solved; ACES, CSAIL and Freiburg 079 agree,
  /// docs/pot-measurements.md). The barycentric placement's kernels keep wall_clearance: at
  /// 0.25 m its free kernels, not solved, erased walls (Intel, 30 scans: the scans' own maps
  /// fell from AUC 0.92 to 0.76).
  double anchor_clearance = 0.25;
  /// target_samples: projected Gauss-Seidel sweeps that solve the anchors' weights so that the
  /// scan's map, walls and free space together, reads each anchor's value at the anchor
  /// (default 10; 0: each class's Nadaraya-Watson partition alone, which ignores the other
  /// class, so that a wall's kernels and the free kernels beside it blur each other over a
  /// kernel's width and free space near walls reads near 0.5). On the whole Intel log the
  /// solve took POT from AUC 0.944 / NLL 0.274 to 0.964 / 0.229 (anchor clearance 0.25 m; the
  /// other three Radish logs alike, docs/pot-measurements.md); 20 sweeps scored the same.
  int anchor_sweeps = 10;
  /// target_samples: the transported logit means are multiplied by this (default 1.5, fitted
  /// on the whole Intel log and checked on ACES, CSAIL and Freiburg 079, where the best gain
  /// was 1.5 to 2 as well). The atoms' BHMs learned each place from a few source scans under
  /// their prior, and the overall map averages scans instead of adding their evidence, so the
  /// transported map reads the right side of 0.5 but too near it: a logistic fit of the held-out
  /// labels on its logit gave slopes of 1.5 to 2 on all four logs. 1: the atoms' logits as
  /// they are.
  double logit_gain = 1.5;

  /// How candidates are ranked (default indexed: on the committed experiments it scores within
  /// 0.005 AUC and NLL of the exhaustive ranking in 3.5 to 9 times less time, and its cost
  /// barely grows with the dictionary, docs/pot-scale.md). exhaustive: the paper's eq. 6
  /// (paper()).
  PotRanking ranking = PotRanking::indexed;

  /// Exhaustive ranking only: rank only this many atoms per target sector, pre-selected by a
  /// rotation-invariant descriptor (quantiles of the samples' distances from the sector centre,
  /// atom_descriptor.hpp) before the Sinkhorn ranking (0, the default: every atom). It keeps
  /// the full ranking's atom in fewer sectors than the indexed ranking does (docs/pot-scale.md).
  std::size_t candidates = 0;
  /// The dictionary's descriptors for `candidates`, built once (AtomPreselector(dict)); null:
  /// built on every call, O(samples of the dictionary). map_scans and Mapper build it.
  std::shared_ptr<const AtomPreselector> preselector;

  // Indexed ranking (PotRanking::indexed): candidates from the index, coarse-to-fine solves.
  /// Atoms per target sector taken from the nearest-neighbour query over the index's
  /// rotation-invariant signatures (default 16).
  std::size_t index_neighbours = 16;
  /// Rotation estimates per candidate atom, peaks of the angular cross-correlation at least
  /// 45 degrees apart (default 2: a sector's walls often match at two angles, e.g. a corridor).
  int index_rotations = 2;
  /// Add each sector's farthest atoms (AtomIndex::farthest) at a bad rotation to the coarse
  /// stage (default true): they set the normalisers of the score terms as the worst
  /// candidates set the exhaustive ranking's, so that hits and free samples weigh alike.
  bool index_anchors = true;
  /// Snap each estimated rotation to the nearest of `rotations` (default true: the estimate
  /// picks which of the exhaustive ranking's angles to solve, so both rank on the same grid;
  /// on the Radish logs this scored a little better than the raw estimate, docs/pot-scale.md).
  /// false: the estimate itself, finer than the grid.
  bool snap_rotations = true;
  /// Coarse stage: every (atom, estimated rotation) candidate is ranked on at most this many
  /// hits and free samples a side, thinned evenly (defaults 48 and 24; a fifteenth of the work
  /// of a 200 x 200 problem: thinned evenly, small samples of matching places still match).
  std::size_t coarse_hits = 48;
  std::size_t coarse_free = 24;
  /// Coarse stage's tolerance on ||P 1 - a||_1 (default 1e-5, solved in single-precision sums,
  /// see single_sums_reach()): it only orders candidates for the fine stage, and a cost
  /// converged to 1e-5 of the marginals orders them as one converged to rank_tolerance does
  /// (docs/pot-scale.md). The fine stage keeps rank_tolerance.
  double coarse_tolerance = 1e-5;
  /// Fine stage: the best this many coarse candidates per sector are ranked again with the
  /// ranking's caps (rank_hits, rank_free) and the best of them wins (default 3; 0: the coarse
  /// winner wins). Their score terms are normalised by the coarse stage's largest values,
  /// rescaled by how the survivors' fine costs compare with their coarse ones.
  std::size_t fine_candidates = 3;
  /// Atoms the previous scans chose join every sector's candidates (default true): consecutive
  /// scans see the same place. Callers pass them to prepare_transfer().
  bool warm_candidates = true;
  /// The dictionary's index for the indexed ranking, built once (AtomIndex(dict)); null: built
  /// on every call. map_scans and Mapper build it.
  std::shared_ptr<const AtomIndex> index;

  /// RePOT (SPEC step 7): refine the transported weights with a BHM update on the scan's own
  /// training samples (default false: plain POT).
  bool refine = false;
  /// The refinement's EM settings (default: BhmOptions{}, 3 EM iterations). With the
  /// diagonal E-step (refine_joint false) one iteration is better: it overshoots where
  /// transported kernels overlap and more rounds make maps worse.
  BhmOptions refine_bhm;

  /// RePOT prior: transported weight variances below this are raised to it before the update
  /// (weight units squared; default 1; 0: the transported variances as they are, as SPEC step 7
  /// reads). A source posterior's variance says how sure the source data made the weight where
  /// it was learned, not how well it fits the place it was moved to; the floor lets the scan's
  /// own samples correct it (docs/pot-measurements.md).
  double refine_min_variance = 1;

  /// RePOT's E-step solves the Jaakkola-Jordan system for the weight means as a whole (sparse
  /// conjugate gradients on the host) instead of BHM's diagonal of it; the variances stay BHM's
  /// diagonal ones (default true). The diagonal update lets every kernel answer every sample it
  /// reaches as if it were alone, so where transported kernels overlap (they pile up where the
  /// plan contracts) the map overshoots. false: bhm_update() as SPEC step 7 reads.
  bool refine_joint = true;

  std::uint64_t seed = 0;  ///< subsampling seed (with the scan index: reproducible per scan)
};

/// `n` rotations evenly spaced over a full turn, radians: 0, 2 pi / n, ..., 2 pi (n - 1) / n
/// (PotOptions::rotations from a count, as the commands' --rotations; n <= 0 gives none).
std::vector<double> evenly_spaced_rotations(int n);

/// What happened to one target sector.
struct SectorTransfer {
  int sector = 0;               ///< sector index in the target scan
  std::size_t target_hits = 0;  ///< samples of the target sector
  std::size_t target_free = 0;
  long atom = -1;               ///< chosen atom (index into the dictionary), -1 if none
  double rotation = 0;          ///< chosen rotation, radians
  double score = 0;             ///< ranking score of the chosen candidate (smaller is better)
  bool rank_converged = false;  ///< the chosen candidate's ranking problems converged
  bool transport_converged = false;
  int transport_iterations = 0;
  std::size_t kernels_placed = 0;   ///< kernels that survived the range filter
  std::size_t kernels_dropped = 0;  ///< kernels transported beyond max_range or filtered out
};

/// Wall-clock time of each stage of one scan, milliseconds.
struct PotTiming {
  double prepare_ms = 0;  ///< cutting, subsampling, batch assembly
  /// The batched ranking solves, with the transport's target samples thinned on the host
  /// while the first of them runs on the device.
  double ranking_ms = 0;
  /// The batched high-quality transport, with the placement's anchor sites (AnchorSites)
  /// found on the host while it runs.
  double transport_ms = 0;
  double placement_ms = 0;  ///< out-of-sample map, filter, world frame
  double refine_ms = 0;     ///< RePOT's BHM update (0 for POT)
  double total_ms() const {
    return prepare_ms + ranking_ms + transport_ms + placement_ms + refine_ms;
  }
};

/// The instantaneous map of one scan and how it was made.
struct ScanTransfer {
  KernelMap map;  ///< transported kernels, world frame (no bias)
  std::vector<SectorTransfer> sectors;
  PotTiming timing;
};

/// The host half of a transfer: the scan cut into sectors and every ranking problem assembled.
/// Kept apart from the solve so that a mapper can prepare the next scan while the device works
/// on the current one (Mapper does). Plain data; finish_transfer() consumes it.
struct PreparedTransfer {
  struct Candidate {
    std::size_t atom = 0;
    double angle = 0;            ///< radians
    long hits_problem = -1;      ///< index in `ranking`, -1 when hits are not ranked
    long free_problem = -1;      ///< index in `ranking`, -1 when free samples are not ranked
    bool hits_mismatch = false;  ///< only one side has hits: the hits term scores 1
    bool free_mismatch = false;  ///< only one side has free samples: the free term scores 1
  };
  std::vector<Sector> sectors;
  /// Per sector: every candidate of the exhaustive ranking, or the coarse stage's candidates of
  /// the indexed one.
  std::vector<std::vector<Candidate>> candidates;
  SinkhornBatch ranking;  ///< every candidate's problems (the coarse stage's when indexed)
  /// Indexed ranking: per sector, the target's samples at the ranking's caps, for the fine stage.
  std::vector<Eigen::MatrixXd> rank_hits, rank_free;
  LabelledPoints train;  ///< the scan's training samples (RePOT)
  std::array<double, 3> sensor{0, 0, 0};
  std::int64_t scan_index = 0;
  double max_range = 0;  ///< metres, the cut's radius
  PotRanking ranking_mode = PotRanking::exhaustive;
  PotTiming timing;  ///< prepare_ms filled
};

/// Cuts and assembles (host only, thread-safe for a shared dictionary). Arguments as for
/// transfer_scan(); `warm_atoms`: atoms chosen for recent scans (ScanTransfer::sectors[].atom),
/// added to every sector's candidates by the indexed ranking when PotOptions::warm_candidates
/// is set (ignored otherwise; indices outside the dictionary are ignored too). `ctx`: its host
/// helper assembles the indexed ranking's sectors beside this thread (Context::
/// host_parallel_for; the device is not used); null (the default): this thread alone. The
/// result is the same either way.
PreparedTransfer prepare_transfer(const Dictionary& dict, LabelledPoints train,
                                  const std::array<double, 3>& sensor, double heading,
                                  std::int64_t scan_index, const PotOptions& options = {},
                                  const std::vector<long>& warm_atoms = {}, Context* ctx = nullptr);

/// The atoms a transfer chose, for the next scans' prepare_transfer(): one per sector that got
/// one, in sector order.
std::vector<long> chosen_atoms(const ScanTransfer& transfer);

/// Where one target sector's kernels will sit under PotPlacement::target_samples, and which
/// column of its plan each reads: what the placement needs that the winning atom does not
/// change, so a transfer finds it while the device solves the transport. Per class (0 hits,
/// 1 free samples; empty where the class is not transported).
struct AnchorSites {
  /// The sector samples that carry a kernel: indices into Sector::hits or Sector::free (in
  /// points), thinned to PotOptions::anchor_spacing (the first sample of each cell).
  std::array<std::vector<std::size_t>, 2> sample;
  /// For each of them the plan column it reads: the index of the transport target sample
  /// nearest it, kDroppedByWall (a free sample within wall_clearance of a hit: no kernel,
  /// counted in SectorTransfer::kernels_dropped) or kNoColumn (no target: no kernel).
  std::array<std::vector<long>, 2> column;
  static constexpr long kDroppedByWall = -1;
  static constexpr long kNoColumn = -2;
};

/// A transfer ranked and transported but not yet placed: the device half of
/// finish_transfer(). Kept apart so that a mapper can place one scan's kernels on the host
/// while the device ranks the next (map_scans() does). Plain data; place_transfer() consumes
/// it.
struct SolvedTransfer {
  PreparedTransfer prepared;  ///< what solve_transfer() was given (sectors, samples, timing)
  /// Per sector its atom, rotation and score (chosen_atoms() reads them), the timing so far;
  /// no kernels yet.
  ScanTransfer transfer;
  SinkhornBatch transport;  ///< the winners' high-quality transport problems
  /// Per sector: the index in `transport` of its hits problem and of its free-sample problem
  /// (-1: none).
  std::vector<std::array<long, 2>> problem_of;
  /// The solutions of `transport`, in order: their plans (couplings, or barycentric images for
  /// PotPlacement::barycentric) and statistics; the dual potentials are not read back.
  std::vector<SinkhornResult> plans;
  /// PotPlacement::target_samples: per sector, its anchors' sites, found beside the transport's
  /// solve. Empty (or another placement): place_transfer() finds them itself.
  std::vector<AnchorSites> anchor_sites;
};

/// Ranks a prepared scan and solves its winners' transport. `ctx` null: the CPU reference, one
/// problem at a time. `dict` and `options` must be those it was prepared with.
SolvedTransfer solve_transfer(Context* ctx, const Dictionary& dict, PreparedTransfer&& prepared,
                              const PotOptions& options = {});

/// Places a solved transfer's kernels (host only) and, for RePOT's per-scan refinement
/// (PotOptions::refine), refines them on `ctx` (null: the CPU reference). `dict` and `options`
/// as for solve_transfer(). Thread-safe for a shared dictionary when options.refine is off.
ScanTransfer place_transfer(Context* ctx, const Dictionary& dict, SolvedTransfer&& solved,
                            const PotOptions& options = {});

/// Ranks, transports, places and (for RePOT) refines a prepared scan:
/// place_transfer(solve_transfer(...)). `ctx` null: the CPU reference, one problem at a time.
/// `dict` and `options` must be those it was prepared with.
ScanTransfer finish_transfer(Context* ctx, const Dictionary& dict, PreparedTransfer&& prepared,
                             const PotOptions& options = {});

/// The atoms a solved transfer chose (chosen_atoms(solved.transfer)).
std::vector<long> chosen_atoms(const SolvedTransfer& solved);

/// Transfers one scan: finish_transfer(prepare_transfer(...)). `train` are the scan's training
/// samples (world frame), seen from `sensor` (world frame, metres) with `heading` (radians);
/// `scan_index` seeds the subsampling. `ctx` null: the same algorithm one problem at a time on the
/// CPU reference Sinkhorn (double precision), the baseline the batched path is compared with.
/// Throws ArgumentError when the dictionary is empty or of another dimension.
ScanTransfer transfer_scan(Context* ctx, const Dictionary& dict, const LabelledPoints& train,
                           const std::array<double, 3>& sensor, double heading,
                           std::int64_t scan_index, const PotOptions& options = {});

}  // namespace potmap
POTMAP_CXX_API_END
