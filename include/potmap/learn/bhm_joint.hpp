#pragma once
// Online Bayesian Hilbert map with the joint Jaakkola-Jordan posterior (SPEC section 3).
//
// Kernels sit on a regular grid with one width, close enough to overlap (a continuous map needs
// neighbouring kernels to share samples). With overlap, the diagonal posterior of bhm.hpp
// counts every sample once per kernel it reaches and becomes overconfident; this learner keeps
// the whole posterior precision instead,
//
//   P   = diag(1/w_var0) + 2 sum_n lambda(xi_n) phi_n phi_n^T      (sparse: only kernels that
//   eta = w_mean0/w_var0 + sum_n (y_n - 1/2) phi_n                   share a sample couple)
//   mean = P^-1 eta
//
// and adds each scan to P and eta (the posterior of one scan is the prior of the next, exactly,
// for the xi of that scan). Each scan runs a few EM iterations over its own xi_n; the means are
// solved by conjugate gradients warm-started from the previous scan, on the kernels the scan
// reaches plus a margin. P is stored per kernel as the half of a stencil of its grid neighbours:
// its diagonal and its couplings to the kernels after it in raster order within two cut-off
// radii (P is symmetric; the products mirror them), 23 doubles in 2D and 126 in 3D at the
// default width and cut-off instead of the stencil's whole box of 9^2 and 9^3.
//
// Storage is in tiles of kernels (32 x 32 in 2D, 8 x 8 x 8 in 3D, larger when the stencil is
// wider than a tile, so 3D tiles are kept small), allocated when a sample or a seed first reaches
// them and found through a hash map of tile coordinates: memory grows with the area the samples
// cover, never with the number of scans (driving over the same place again allocates nothing). A
// kernel no sample or seed reached is never stored; it holds its prior (mean 0, variance prior_var)
// exactly, which is what an allocated but unreached kernel holds too. The grid may be unbounded
// (the growable constructor: kernels at integer multiples of the spacing) or clipped to bounds
// known in advance (kernels from lo to hi, as a dense grid over them would be).
//
// A KernelMap carries one variance per kernel, so the exported w_var is chosen to reproduce the
// posterior's predictive variance phi(x)^T P^-1 phi(x) at each kernel centre (computed on a
// local block of P around the kernel); see JointBhm::map().

#include <cstddef>
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"

// Internal (host/), declared outside the exported region so that it stays hidden: saves and
// restores the private state (Mapper::save_state).
namespace potmap::detail {
struct JointBhmState;
struct JointBhmDevice;
struct JointBhmMerge;
}  // namespace potmap::detail

POTMAP_CXX_API_BEGIN
namespace potmap {

class Context;

/// Where update() lists a scan's features and adds its sums (the precision's outer products,
/// eta, the bias's couplings, each EM round's bound) when it is given a Context.
enum class JointBhmSums {
  /// On the context's device when it is a GPU with doubles (cl_khr_fp64), else on the host.
  /// On a CPU device the host's loops (vectorised along runs of cells, split over the
  /// context's two host threads) are as fast or faster: on PoCL on a quiet 2-core EPYC the
  /// device path took 1.0-1.1 times the host's update time on riverside-a keyframes 10-29 at
  /// 40 m, 1.1-1.2 on hku-1's and 1.5 on the Intel log's scans (potmap mapping --sums
  /// host|device, alternated runs); a GPU has the bandwidth the sums want.
  automatic,
  host,    ///< on the host (the reference the device path is tested against)
  device,  ///< on the device whatever its type (the host when it has no doubles)
};

struct JointBhmOptions {
  /// Grid spacing of the kernels, metres (default 0.5: the hinge spacing of the BHM authors'
  /// demo on the Intel log; about the thickness of an indoor wall, so walls come out as walls).
  double spacing = 0.5;
  /// Kernel width, 1/m^2; 0 (default): -ln(neighbour_phi) / spacing^2.
  double gamma = 0;
  /// With gamma 0: the feature value of a kernel at one spacing from its centre (default 0.19,
  /// as gamma 6.71 at 0.5 m in the BHM authors' Intel demo). Larger: smoother, blurrier maps.
  double neighbour_phi = 0.19;
  /// Prior weight variance (default 10: as the BHM authors' demo; with overlapping kernels a
  /// large prior lets neighbours cancel one another in unobserved gaps).
  double prior_var = 10;
  /// A bias weight with the same prior (default true): it sets the level of unobserved space.
  bool bias = true;
  /// EM iterations on a scan (default 3); each but the last is followed by an M-step.
  int em_iterations = 3;
  /// Feature cut-off exponent of the learner: a kernel with gamma d^2 > tau is not a feature
  /// of a sample at distance d (default 6: features below e^-6, 0.25 % of a kernel's peak, are
  /// dropped). An update costs the square of the features a sample has (2D: about 12 at 6, 34
  /// at the evaluators' 18; 3D: about 30 and 150) and each kernel's stencil shrinks with it,
  /// while the dropped products are below the prior's precision by orders of magnitude, and
  /// the held-out scores on the real logs and frames stay those of 18 (docs/pot-measurements.md).
  /// The maps it exports are evaluated with the evaluators' own cut-off.
  double tau = 6;
  /// Conjugate-gradient stop: relative residual of a scan's solve (default 1e-5).
  double cg_tolerance = 1e-5;
  /// At most this many CG iterations per solve (default 300).
  int cg_max_iterations = 300;
  /// Extra rings of kernels, in spacings, solved around the ones a scan reaches (default 4: the
  /// change of the mean decays over a few kernel widths).
  int solve_margin = 4;
  /// Seeds yield to data (default true): when a sample first reaches a kernel whose prior
  /// seed_unreached() set, the kernel's prior returns to the plain one (mean 0, variance
  /// prior_var) before the sample is added (its mean too, and sooner, with seeds_yield_fully,
  /// the default; without it the seeded mean stays as the point where that scan's
  /// Jaakkola-Jordan bound starts). So wherever data arrive the posterior is the unseeded
  /// model's, and a seed speaks for space no sample has reached. A seed is a guess from
  /// another place (RePOT's transported kernels): kept as the prior under the data it biased
  /// the posterior for good, and RePOT lost up to 0.001 AUC and NLL against the BHM it refines
  /// on the real logs (docs/pot-measurements.md). false: the seed stays the kernel's prior.
  bool seeds_yield = true;
  /// How far a seed yields (with seeds_yield). true (default): it yields when its kernel
  /// enters a scan's solve (a sample reaches it, or reaches a kernel within solve_margin of
  /// it), its mean with it, so the kernel starts the scan where an unseeded one starts. Every
  /// kernel within the margin of the data then holds what the unseeded model holds, up to the
  /// solve's tolerance (cg_tolerance), and seeds speak only for space farther from the data.
  /// Why the default: a seeded map is then never worse than the unseeded one where data
  /// arrived, whatever the source, which RePOT promises against the BHM it refines. false: a
  /// seed yields when a sample reaches its kernel and its mean starts that scan's bound (first
  /// xi) and solve; with three EM rounds that start lasts: higher F1 and lower NLL on most
  /// runs, but AUC up to 0.002 below BHM's on 28 of 78 committed runs, and NLL above it on
  /// some, most from a source unlike the target (docs/pot-measurements.md).
  bool seeds_yield_fully = true;
  /// At most this many stored kernels (default 2^26, the most the storage can address): a
  /// guard against runaway input (samples scattered over a huge area). Each stored kernel
  /// holds its half precision stencil: 1 + (m - 1) / 2 doubles, m the grid points within
  /// 2 sqrt(tau / gamma) of a kernel (23 in 2D, 126 in 3D at the defaults), and 4 more.
  std::size_t max_kernels = std::size_t(1) << 26;
  /// Forgetting (SPEC section 9): the data's part of the posterior halves every `half_life`
  /// seconds of sensor time (set_time()), P <- P_0 + a (P - P_0) and eta <- a eta with
  /// a = 2^(-dt / half_life), so evidence of a place that changed (a car that drove off) fades
  /// and the new evidence wins, and a place no longer seen drifts back to its prior. Seeds are
  /// priors and do not fade. 0 (default): never forget, the exact posterior of every scan.
  /// Why off by default: a map that forgets is a map of the recent past, a choice of the
  /// caller's (`potmap map|mapping --half-life`); docs/forgetting.md has what it does to held-out
  /// scores and to the places vehicles left, and how to choose the half-life.
  double half_life = 0;
  /// Where the sums run (default automatic: a GPU with doubles; see JointBhmSums).
  /// Either way the posterior is the same up to the rounding of sums taken in another order
  /// (relative 1e-12 in the tests).
  JointBhmSums sums = JointBhmSums::automatic;
};

/// Counters of the last update() (for tests, benchmarks and progress).
struct JointBhmStats {
  std::size_t samples = 0;        ///< samples of the scan inside the grid
  std::size_t active = 0;         ///< kernels solved for
  std::size_t cg_iterations = 0;  ///< summed over the EM iterations
  double residual = 0;            ///< relative residual at the end of the last solve
  bool sums_on_device = false;    ///< the features and sums ran on the context's device
};

/// The online learner. Not thread-safe (map() fills a cache; two threads may not call even
/// its const members at once); copyable and cheap to move.
class JointBhm {
 public:
  /// A growable map: kernels on the unbounded grid of `options.spacing` through the origin
  /// (`dim` = 2 or 3 axes), stored when first reached. Throws ArgumentError on bad options.
  explicit JointBhm(int dim, const JointBhmOptions& options = {});

  /// Kernels on a grid over [lo, hi] only (metres; `dim` = 2 or 3 axes used), starting at lo
  /// and `options.spacing` apart; samples and seeds reach no kernel outside it. Throws
  /// ArgumentError on bad options or bounds, or more than 2^26 kernels.
  JointBhm(int dim, const double lo[3], const double hi[3], const JointBhmOptions& options = {});

  /// Adds one scan's labelled samples (any scan index; samples beyond the grid's reach, or
  /// farther than 2^22 spacings from the origin, are ignored). Empty input does nothing.
  /// Throws ArgumentError on a dimension mismatch or when the map would pass
  /// options.max_kernels stored kernels (the posterior is unchanged then).
  ///
  /// `ctx` (default null: this thread alone): the scan's features and sums run on ctx's device
  /// (kernels/learn/bhm_joint_sums.cl; options.sums), the solve on the host, split in two
  /// parts on the calling thread and the context's host helper (Context::host_parallel_for).
  /// The device's sums are taken in a fixed order, so the same input gives the same posterior
  /// bit for bit on one device; the host's (options.sums = host) are the same bit for bit with
  /// or without a context, and differ from the device's by rounding.
  void update(const LabelledPoints& samples, Context* ctx = nullptr);

  /// The sensor time, seconds, of the data update() adds next (a scan's stamp; its index where
  /// a log has none). With options.half_life > 0 the data already learned fade by
  /// 2^(-(t - time()) / half_life); a time before time() changes nothing (data arriving out of
  /// order do not rejuvenate the map). The first call sets the clock without fading anything.
  /// The fading is applied lazily, a tile of kernels when an update reaches near it, when it
  /// retires or revives, or when the map is exported, so a scan costs what it costs without
  /// forgetting plus one pass over the tiles around it. Without half_life it only sets time().
  void set_time(double seconds);
  /// The clock set_time() last advanced (0 before any call).
  double time() const { return clock_; }
  /// Brings every tile's fading up to time() now (map() and the information form need it; they
  /// work on a copy when the learner is not up to date, so calling this first saves the copy).
  /// Later updates see the same posterior either way up to rounding (a fade in two steps is
  /// 2^-a 2^-b for 2^-(a+b)).
  void catch_up();

  /// Adds the samples of every scan index in increasing order, one update() per scan, each
  /// with `ctx` (default null: this thread alone; see update()). `before_scan` (optional) is
  /// called with each scan index before its update: the map as it stands can be read then
  /// (an experiment's look-ahead).
  void update_by_scan(const LabelledPoints& samples, Context* ctx = nullptr,
                      const std::function<void(std::int64_t scan)>& before_scan = {});

  /// Seeds the prior of the kernels no sample has reached yet from another map over the same
  /// place (RePOT: the scan's transported kernels). Where `field`'s kernels weigh at least
  /// `min_support` (sum of their phi at the grid kernel), the grid kernel's prior becomes the
  /// weight and variance that reproduce field's logit mean and variance there, the variance
  /// clamped to [min_var, prior_var]. Kernels a sample already reached, or an earlier seed
  /// seeded, keep their posterior; the bias is untouched. Returns the number of kernels
  /// seeded. With options.seeds_yield a seed lasts until a sample reaches its kernel. Throws
  /// ArgumentError on a dimension mismatch.
  std::size_t seed_unreached(const KernelMap& field, double min_var = 1.0,
                             double min_support = 0.3);

  /// The map: its kernels with their posterior means, and the variance that reproduces the
  /// predictive variance at each centre (the prior variance where no sample or seed reached
  /// its block); the bias weight with its posterior. Bounded: every grid kernel, in raster
  /// order. Growable: every stored kernel (whole tiles, in storage order), then the retired
  /// tiles' as retire_far() left them (faded to time() with half_life); unstored kernels
  /// are at their prior mean 0 and left out. The means are polished by a solve over every
  /// reached kernel first (on a copy: the learner's state is unchanged, so when and how often
  /// a caller exports makes no difference to later updates). The variances, a small dense
  /// solve per kernel, are cached per tile and recomputed only for tiles whose precision
  /// changed since the last call. With half_life, the posterior at time(): tiles not yet
  /// faded to it are faded on a copy of the learner (catch_up() first avoids the copy).
  /// `ctx`: the polishing solve's products run on its host team and the variances on every
  /// core (the same map as without, bit for bit); null: the solve on the calling thread.
  /// `polish_tolerance`: the polishing solve's relative residual (default 1e-8, a thousandth
  /// of the updates' default cg_tolerance: in 2D it costs little, and maps learned by other
  /// routes agree to about that). A drive's mapper asks for 1e-6 (DriveMapper::map()).
  KernelMap map(Context* ctx = nullptr, double polish_tolerance = 1e-8) const;

  /// Mean and variance of the logit at n points (n * dim coordinates) as the last update left
  /// the map: the kernels' means as its solve left them (map() polishes them further), their
  /// exported variances (map()'s), the learner's own cut-off (tau), retired tiles as they
  /// retired. What a planner reads between keyframes, and a drive's look-ahead: it reads only
  /// the kernels the points reach, where map() polishes and exports the whole map (riverside-a
  /// at 40 m: about 50 ms on one core for the 6,000 held-out samples of a keyframe, most of it
  /// the exported variances of kernels the last update changed, which run on ctx's host team
  /// when ctx is given: the same values). Either output may be null.
  void predict(const double* points, std::size_t n, double* mean, double* var,
               Context* ctx = nullptr) const;
  /// Per point (n * dim coordinates), 1 if a sample has reached a kernel whose cut-off holds
  /// it (a kernel a sample touched, or one of a retired tile), else 0: space the sensor has
  /// not been yet, where only the prior and RePOT's seeds speak. `out` receives n bytes.
  void reached(const double* points, std::size_t n, std::uint8_t* out) const;

  /// Posterior mean and variance of the logit at n points (n * dim coordinates), exactly:
  /// phi^T P^-1 eta and phi^T P^-1 phi, by a sparse Cholesky factorisation of the whole
  /// stored precision and one solve per point (no conjugate gradients): for tests and small
  /// maps.
  void predict_exact(const double* points, std::size_t n, double* mean, double* var) const;

  /// Retires the stored tiles of a growable map whose centre lies farther than `radius` metres
  /// from `centre` in x and y (a drive's sensor has left them): each keeps only what a query
  /// needs, its kernels' posterior means and exported variances (map()), 8 bytes a kernel in
  /// place of its precision stencil (about 650 bytes in 3D at the drive defaults). Before they
  /// go, their means are held fixed in the posterior of the kernels that stay: each coupling
  /// P_ab to a retired kernel b moves into eta_a as -P_ab mean_b (and into the bias's), which is
  /// the stayed kernels' posterior given the retired means, exactly. A sample that later reaches
  /// a retired tile revives it with a diagonal prior holding each kernel's mean and variance:
  /// learning goes on there, without the couplings the tile had (its variances come out a
  /// little larger than a map that never retired it). Returns the tiles retired. Bounded maps
  /// and radius <= 0 retire nothing. `ctx` (default null: this thread alone): the retiring
  /// kernels' variances (a small dense solve each) run on this thread and the context's host
  /// helper; the same values either way.
  std::size_t retire_far(const double centre[3], double radius, Context* ctx = nullptr);
  /// Tiles retired and not revived.
  std::size_t retired_tiles() const { return retired_.size(); }

  /// Kernels (without the bias): bounded, the grid's; growable, the stored and retired ones.
  std::size_t size() const;
  /// Stored tiles.
  std::size_t tiles() const { return tiles_.size(); }
  /// Whether the grid is clipped to the bounds of the constructor.
  bool bounded() const { return bounded_; }
  /// Bytes held: the tiles' precision stencils, natural parameters, means, flags and cached
  /// variances, the tile index and the solver's scratch (capacities, not sizes).
  std::size_t memory_bytes() const;
  double gamma() const { return gamma_; }
  const JointBhmOptions& options() const { return o_; }
  const JointBhmStats& last_stats() const { return stats_; }

  /// Fingerprints of the data learned: one 64-bit hash of each non-empty scan update() added
  /// (its positions, labels and weights), in the order added, and those add_data_id() or a
  /// merge brought. Merging (bhm_joint_merge.hpp) refuses maps that share one, so a map is
  /// never fused with itself, or with a map of the same scans, without being told to. Mapper
  /// states and checkpoints keep them; one saved before them restores a learner that records
  /// only the scans learned after the restore. 8 bytes a scan, the one part of the learner that
  /// grows with the number of scans rather than the area (left out of memory_bytes()).
  const std::vector<std::uint64_t>& data_ids() const { return data_ids_; }
  /// Records that the map holds data known by `id` (a caller's own fingerprint of a scan,
  /// e.g. its log and time stamp).
  void add_data_id(std::uint64_t id) { data_ids_.push_back(id); }

 private:
  friend struct detail::JointBhmState;
  friend struct detail::JointBhmDevice;
  friend struct detail::JointBhmMerge;
  static constexpr std::uint32_t kNone = 0xffffffffu;
  struct Feature {
    std::uint32_t kernel;  // storage index (kNone: not stored, at its prior)
    std::int32_t cell[3];  // grid coordinates
    double phi;
  };
  struct Tile {
    std::int32_t coord[3];  // tile coordinates: cells coord * tile_ .. coord * tile_ + tile_-1
    std::int32_t nb[27];    // neighbour tiles (dx+1) + 3 (dy+1) + 9 (dz+1); -1: not stored
  };
  // update(): a scan's features, flat (per feature: kernel, phi and stencil-linear cell; per
  // sample: its first feature, its first run of features with consecutive cells, its weight
  // and its label as +-1/2 times the weight; the runs as (first feature, length) pairs).
  struct FeatureList {
    std::vector<std::uint32_t> kernel, start, runs, run_start;
    std::vector<double> phi, yc, w;
    std::vector<std::int64_t> lin;
    std::size_t bytes() const;
  };
  // Buffers kept across scans (no state: a copy or a restore may start them empty). The
  // scan's features are the Scratch's own list (on a host team the first half of the samples'
  // is listed there, the second's in `second`, then appended).
  struct Scratch : FeatureList {
    std::vector<double> r, z, p, q;
    double rb = 0;  // the bias row's residual, beside r's (solve())
    std::vector<std::uint32_t> reached, rows;
    std::vector<double> lambda, next, mu;  // update(): per sample (mu: phi . x, xi's pass)
    FeatureList second;
    std::vector<std::int32_t> sample_tiles;    // update(): 8 per sample (span_tiles())
    std::vector<std::uint8_t> bits, bits_tmp;  // dilate_rows()
    std::vector<std::uint32_t> rows_tmp;       // dilate_rows()
    // solve(): a box of cells around the rows (box_rows()), x in it, the offsets of the
    // stencil's half runs. The box is cut in two parts at cell `box_split` (raster order): a
    // part's rows, and the kernels around them, with their places in the box, and the part's
    // own box of y (a kernel's half stencil reaches only cells after its own, at most
    // `box_reach` later, so part 0's y spills into part 1 by at most that much).
    std::vector<double> pbox;
    std::vector<double> ybox[2];
    std::vector<std::int64_t> box_off;
    std::vector<std::int32_t> box_len;
    std::vector<std::uint32_t> part_rows[2], part_around[2];
    std::vector<std::int64_t> part_at[2], part_around_at[2];
    std::vector<std::uint8_t> sample_parts;  // update(): per sample, bit p: a feature in part p
    std::vector<std::uint32_t> row_of;       // the device's update: per reached kernel, its row
    std::int64_t box_lo[3] = {0, 0, 0}, box_n[3] = {1, 1, 1};
    std::int64_t box_split = 0, box_reach = 1;
    bool boxed = false;  // box_rows() accepted the rows
    std::size_t bytes() const;
  };
  void init(int dim, const JointBhmOptions& o);
  static std::uint64_t tile_key(const std::int64_t t[3]);
  std::int64_t find_tile(const std::int64_t t[3]) const;
  std::uint32_t make_tile(const std::int64_t t[3]);
  // Storage index of grid cell g, or -1 when not stored; `hint` a stored tile within one tile
  // of g's (faster: no hashing), or -1.
  std::int64_t find_cell(const std::int64_t g[3], std::int64_t hint = -1) const;
  void cell_of(std::uint32_t s, std::int64_t g[3]) const;
  // The smallest box of cells holding every one of `kernels` (lo > hi when there are none).
  void cell_bounds(const std::vector<std::uint32_t>& kernels, std::int64_t lo[3],
                   std::int64_t hi[3]) const;
  bool in_grid(const std::int64_t g[3]) const;
  // A sample's features: the span of cells within its cut-off (false: none in the grid), the
  // tiles of the span that the cut-off reaches (made when `create`; -1: not stored; at most
  // two an axis, indexed ((tz - ta_z) * 2 + ty - ta_y) * 2 + tx - ta_x from the span's first
  // tile), and emit(kernel, cell, phi) for each kernel within the cut-off, in raster order.
  bool feature_span(const double* x, std::int64_t a[3], std::int64_t b[3]) const;
  // feature_span() of a sample, false too where a coordinate is not finite.
  bool sample_span(const double* x, std::int64_t a[3], std::int64_t b[3]) const;
  void span_tiles(const double* x, const std::int64_t a[3], const std::int64_t b[3], bool create,
                  std::int32_t tile_id[8]);
  template <class Emit>
  void span_features(const double* x, const std::int64_t a[3], const std::int64_t b[3],
                     const std::int32_t tile_id[8], Emit emit) const;
  void features(const double* x, std::vector<Feature>& out, bool create);
  void features(const double* x, std::vector<Feature>& out) const;
  // P += c phi phi^T for sample i of the scan's features in `f` (not the bias's own precision,
  // pbb_); `part` >= 0: only the rows of the kernels of that part of the box (mark_ holds each
  // row's part during update()).
  void add_outer(const Scratch& f, std::size_t i, double c, int part);
  // update()'s parts: the input's checks; the scan's features listed on the host (into the
  // scratch); the kernels they reach and the rows of the solve (seeds in them yield); the
  // bias's products with the kernels outside the rows, and the rows' box; the EM rounds on the
  // host. detail::JointBhmDevice (bhm_joint_device.cpp) lists and sums on the device instead.
  void check_samples(const LabelledPoints& samples) const;
  void list_features(const LabelledPoints& samples, Context* ctx);
  void reach_rows(Scratch& sc);
  double prepare_solve(Scratch& sc);
  void update_on_host(const LabelledPoints& samples, Context* ctx);
  void em_on_host(double bias_outside, bool boxed, Context* ctx);
  // Returns seeded kernel k, which no sample has reached, to its prior (its mean to 0 too
  // with `with_mean`).
  void yield_seed(std::uint32_t k, bool with_mean);
  // rows += the stored kernels within mg cells (mz in z) of a reached one, sorted.
  void dilate_rows(std::vector<std::uint32_t>& rows, const std::vector<std::uint32_t>& reached,
                   std::int64_t mg, std::int64_t mz, Scratch& sc);
  void mark_dirty(std::uint32_t s);
  // f(tile coordinates, first cell, last cell) for every tile the box of cells [a, b] overlaps
  // (stored or not), with the part of the box inside it.
  template <class F>
  void for_each_tile_part(const std::int64_t a[3], const std::int64_t b[3], F f) const;
  // f(first storage index, first cell, length) for every run along x of stored cells in the
  // box of cells [a, b].
  template <class F>
  void for_each_stored_line(const std::int64_t a[3], const std::int64_t b[3], F f) const;
  // P(a, b) for stored kernel a and kernel b (storage index, -1: not stored) at cell offset o
  // from a, read from the half stencil of whichever comes first in raster order.
  double coupling(std::int64_t a, std::int64_t b, const std::int64_t o[3]) const;
  // Places the rows `rows` (sorted storage indices) in a box of cells around them (the products
  // below); false when the box would be much larger than the rows.
  bool box_rows(const std::vector<std::uint32_t>& rows, Scratch& sc) const;
  // y = P x on the rows, and the bias row when with bias, in the box of box_rows(), its two
  // parts on ctx's host team; `x_outside`: x may be non-zero outside the rows (otherwise it
  // is zero there).
  void multiply_box(const std::vector<double>& x, double xb, bool x_outside,
                    const std::vector<std::uint32_t>& rows, std::vector<double>& y, double& yb,
                    Scratch& sc, Context* ctx) const;
  // The same without a box, each coupling found through the tiles: for rows scattered far
  // apart, where box_rows() declines.
  void multiply_sparse(const std::vector<double>& x, double xb,
                       const std::vector<std::uint32_t>& rows, std::vector<double>& y,
                       double& yb) const;
  // `rows_boxed`: box_rows(rows, s) was called since the rows last changed (its answer is in
  // s.boxed); otherwise solve() calls it. `bias_outside`: the sum of bcoup_ x over the kernels
  // outside the rows, when known (otherwise summed here). `residual_given`: s.r (on the rows)
  // and s.rb already hold eta - P x (bias_outside is then unused); on return they hold the
  // residual of the new x either way.
  double solve(const std::vector<std::uint32_t>& rows, std::vector<double>& x, double& xb,
               double tol, int max_it, std::size_t* its, Scratch& s, bool rows_boxed = false,
               Context* ctx = nullptr, const double* bias_outside = nullptr,
               bool residual_given = false) const;
  bool near_data(const std::int64_t g[3], std::int64_t hint) const;
  double predictive_var_at(const std::int64_t g[3], std::int64_t hint,
                           std::vector<double>& block_scratch) const;
  double exported_var(const std::int64_t g[3], std::int64_t s, std::vector<double>& scratch) const;
  // The mean and variance a retired tile keeps for the kernel at `cell` (faded to time() as
  // map() gives them); false where no retired tile holds it.
  bool retired_kernel(const std::int32_t cell[3], double& mean, double& var) const;
  // A retired kernel's mean and variance with its evidence faded by `a` (fade_since()).
  void fade_retired(double a, double& mean, double& var) const;

  JointBhmOptions o_;
  int dim_ = 2;
  double gamma_ = 0, rcut_ = 0;
  double step_q_ = 1;  // exp(-2 gamma spacing^2): span_features()'s recurrence
  bool bounded_ = false;
  double lo_[3] = {0, 0, 0};       // position of grid cell (0, 0, 0)
  std::int64_t n_[3] = {1, 1, 1};  // bounded: kernels per axis, cells 0 .. n-1
  std::int64_t pad_ = 0;           // stencil half-width, in cells
  std::int64_t box_ = 0;           // 2 * pad + 1
  std::int64_t slots_ = 0;         // box^dim: the stencil's whole box
  std::int64_t hb_ = 0;            // half-width of the exported variance's block
  std::int64_t tile_ = 32;         // cells per tile axis
  std::int64_t tile_cells_ = 1;    // tile^dim
  std::int64_t centre_lin_ = 0;    // sum_d pad box^d: the stencil's centre slot
  // P is symmetric, so a kernel stores only its diagonal and the couplings to the kernels after
  // it in raster order (z, y, x) that can be non-zero: runs along x of its stencil's box, each
  // starting at a cell offset d and at index `at` of the kernel's stored half.
  struct HalfRun {
    std::int32_t slot, len, at;  // first slot in the box, length, first index in the half
    std::int32_t d[3];           // the first slot's cell offset
  };
  std::vector<HalfRun> half_;
  std::int64_t half_slots_ = 1;        // doubles a kernel stores: the diagonal and half_'s slots
  std::vector<std::int32_t> half_at_;  // per slot of the box: its index in the half, or -1
  std::vector<Tile> tiles_;
  std::unordered_map<std::uint64_t, std::uint32_t> tile_index_;
  std::vector<double> prec_;                      // storage x half_slots_ (the half stencil)
  std::vector<double> eta_;                       // storage
  std::vector<double> mean_;                      // storage
  std::vector<double> bcoup_;                     // storage: P(bias, k)
  std::vector<std::uint8_t> touched_;             // storage: a sample reached it
  std::vector<std::uint8_t> seeded_;              // storage: its prior came from seed_unreached()
  std::vector<std::uint8_t> mark_;                // storage: update()'s scratch, zero between calls
  mutable std::vector<double> var_;               // storage: exported variance cache
  mutable std::vector<std::uint8_t> tile_dirty_;  // per tile: var_ out of date
  double grid_sum_ = 1, grid_sum2_ = 1;  // sum of phi, phi^2 of the grid at an interior kernel
  double sum_phi2_ = 1;                  // sum of phi^2 over the variance block
  // The variance block (predictive_var_at()): its cells' offsets from the centre (3 each) and
  // features in the order the block lists them, and per pair (u, v) of them the index in the
  // half stencil that holds their coupling (-1: none) and whether u's row holds it (else v's).
  std::vector<std::int64_t> vb_off_;
  std::vector<double> vb_phi_;
  std::vector<std::int32_t> vb_at_;
  std::vector<std::uint8_t> vb_u_first_;
  double pbb_ = 0, etab_ = 0, meanb_ = 0;
  Scratch scratch_;
  JointBhmStats stats_;
  // Retired tiles (retire_far()): coordinates, then per kernel its mean and exported variance.
  struct RetiredTile {
    std::int32_t coord[3];
    std::vector<float> mean, var;
    double clock = 0;  // time() when it retired (half_life: its fading since)
  };
  std::vector<RetiredTile> retired_;
  std::unordered_map<std::uint64_t, std::uint32_t> retired_index_;
  std::vector<std::uint64_t> data_ids_;  // data_ids()
  // Forgetting (half_life): the clock, whether set_time() set it, and per stored tile the time
  // its data's part was last faded to (tile_clock_[t] <= clock_; equal: up to date).
  double clock_ = 0;
  bool clock_set_ = false;
  std::vector<double> tile_clock_;
  // The fading from `since` to clock_, 2^(-(clock_ - since) / half_life) (1 without forgetting).
  double fade_since(double since) const;
  // Fades tile t's data to clock_, and marks the variances its block reaches out of date.
  void catch_up_tile(std::size_t t);
  // Fades the tiles of `rows` and their neighbours (whose half stencils couple to them): what a
  // scan's solve reads.
  void catch_up_around(const std::vector<std::uint32_t>& rows);
  // Whether some tile or retired tile has fading not applied.
  bool behind() const;
  // map() on a learner whose fading is applied.
  KernelMap map_current(Context* ctx, double polish_tolerance) const;
  void fold_retiring(const std::vector<std::uint8_t>& going);
  void compact(const std::vector<std::uint8_t>& going);
  void revive(std::uint32_t id, std::uint64_t key);
  // span_tiles(): the last tiles it found (a tile's id changes only when retire_far() removes
  // tiles, which forgets these).
  std::uint64_t recent_key_[4] = {~0ull, ~0ull, ~0ull, ~0ull};
  std::int64_t recent_id_[4] = {-1, -1, -1, -1};
  int recent_next_ = 0;
};

}  // namespace potmap
POTMAP_CXX_API_END
