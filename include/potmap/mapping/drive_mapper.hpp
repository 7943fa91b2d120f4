#pragma once
// Online mapping of a 3D drive with the joint BHM (SPEC section 8): keyframes one at a time, each
// cut at a horizontal range, labelled (20 % of its beams held out for scoring), its training
// samples gathered per voxel and added to one growable joint BHM. The mapper holds the learner,
// the kept held-out samples and nothing of a keyframe after add() returns, so a drive is read a
// keyframe at a time (data/drive.hpp).
//
// The defaults are chosen for driving on real drives (docs/drives-3d.md has the measurements):
//  - a 40 m cut: a car's LIDAR returns lie within 60 m (riverside-a: median 12 m, 99 % within
//    63 m); 40 m holds the road and the buildings beside it, where a planner looks, and costs
//    about three times a 20 m cut's time (more kernels a keyframe); past it, the few long beams
//    add kernels and free space far from the road;
//  - kernels 1 m apart (the vertical spacing of a 64-ring sensor's rings at 20-30 m), the 2D
//    overlap (phi 0.19 at one spacing);
//  - 0.5 free samples a metre of beam, gathered per 0.5 m voxel (a third of the samples, the
//    same AUC to 0.001 on riverside-a);
//  - feature cut-off gamma d^2 <= 4.5 (features below 1.1 % of a kernel's peak dropped: the
//    stencil and a sample's features shrink by 40 %, scores unchanged to 0.001), one ring of
//    solve margin, two EM rounds a keyframe, CG to a relative residual of 1e-4.
// With them the joint BHM takes 0.3 to 0.6 times OctoMap's (0.2 m) time per keyframe on the
// ../shared drives at both 20 and 40 m cuts (bench/drive3d.py).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/export.h"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/transfer.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

class Context;

/// The joint BHM options of the drive defaults above.
JointBhmOptions drive_bhm_options();

/// RePOT's transfer on a drive: the indexed ranking (nearest atoms by signature: its time
/// barely grows with the dictionary), 8 rotations, kernels at the barycentric images of the
/// atoms' (they reach past the keyframe's samples, where seeds matter) with 0.25 weight variance
/// per m^2 moved, free-space kernels dropped within 1 m (one kernel spacing) of a hit, and 500
/// hits a side in the transport (the 2D cap of 1500 makes a 3D sector's transport 9 times the
/// work: riverside-a at 20 m, POT 79 ms a keyframe with 500 for AUC / NLL 0.977 / 0.132, 439 ms
/// with 1500 for 0.978 / 0.124).
PotOptions drive_pot_options();

struct DriveMapperOptions {
  /// Horizontal range cut, metres (default 40, see above): returns farther become free space
  /// up to the cut (limit_range).
  double range_cut = 40;
  /// Labelling: free samples a metre (default 0.5), held-out fraction (0.2), seed (0).
  LabelOptions labels = [] {
    LabelOptions l;
    l.free_per_metre = 0.5;
    return l;
  }();
  /// Voxel edge the training samples are gathered in, metres (default 0.5, half the kernel
  /// spacing; 0: every sample on its own).
  double voxel = 0.5;
  /// The learner (default drive_bhm_options(): the defaults above). Its clock for forgetting
  /// (bhm.half_life, default 0: never) is the keyframes' timestamps.
  JointBhmOptions bhm = drive_bhm_options();
  /// After each keyframe the learner's tiles farther than this from the sensor (metres, in x
  /// and y) are retired (JointBhm::retire_far): memory follows the place, not the drive. -1
  /// (default): the range cut plus 16 m (two 3D tiles: no sample of the next keyframe reaches a
  /// tile retired, unless the drive turns back); 0: never.
  double retire_radius = -1;
  /// RePOT (SPEC section 4): a dictionary of 3D atoms (null, the default: the joint BHM alone).
  /// Each keyframe's gathered training samples are transported from it (transfer_scan() with
  /// `pot`) and the transported kernels seed the learner's prior where no sample has reached
  /// yet (JointBhm::seed_unreached): the map reaches past the data with the atoms' shapes,
  /// and where samples reach it is the BHM's (the seeds yield to data).
  std::shared_ptr<const Dictionary> dictionary;
  /// The transfer's settings (default drive_pot_options()).
  PotOptions pot = drive_pot_options();
  /// Seeded prior variances are at least this (default 10, the joint BHM's prior: a seed
  /// moves the prior mean only, as RePOT's in the experiments).
  double seed_min_variance = 10;
  /// RePOT transfers every this many keyframes (default 4; 1: every keyframe). A seed lasts
  /// until a sample reaches its kernel, and a car moves about 8 m a keyframe while a transfer
  /// seeds the whole 20 m disc of the atoms around it, so the seeds ahead of the car are there
  /// before the data. A transfer costs 14 ms (hku-1) to 46 ms (riverside-a, 40 m cut) on the
  /// 2-core EPYC: every keyframe, RePOT took 228 ms a keyframe on riverside-a against 201 ms
  /// every 4th, for the same held-out scores.
  std::size_t transfer_every = 4;
  /// Every this many held-out samples one is kept for scoring (default 4: a drive's held-out
  /// samples would otherwise hold 200 MB over 281 keyframes; a quarter of them scores to the
  /// third decimal).
  std::size_t test_stride = 4;
  /// Look-ahead (default false): before each keyframe after the first is learned, or
  /// transferred from, the map as it stands (JointBhm::predict) is scored on the held-out
  /// samples kept of it, and each is marked beyond reach where no earlier sample had reached
  /// a kernel there (JointBhm::reached): what transfer is for, a prior where the sensor has
  /// not been yet (lookahead()). The map is the same; the scoring costs riverside-a about 35 ms
  /// a keyframe at the 40 m cut on 2 cores (KeyframeStats::lookahead_ms, outside the others:
  /// mostly the exported variances of the kernels the samples reach, which the last keyframe
  /// changed).
  bool lookahead = false;
};

/// The look-ahead samples (DriveMapperOptions::lookahead): per kept held-out sample of every
/// keyframe after the first, the map's probability before that keyframe was added.
struct LookAhead {
  std::vector<float> prob;           ///< p(occupied) the map gave before the keyframe
  std::vector<std::uint8_t> label;   ///< 1 = occupied (hit), 0 = free
  std::vector<std::uint8_t> beyond;  ///< 1: no earlier sample had reached a kernel there
  std::size_t size() const { return label.size(); }
};

/// Scores of a look-ahead: over every sample into `all`, over those beyond reach into `beyond`
/// (metrics.hpp: AUC NaN with one class; n 0 and NaN scores where there are none).
void lookahead_scores(const LookAhead& ahead, Scores& all, Scores& beyond);

/// What one add() did.
struct KeyframeStats {
  std::size_t samples = 0;       ///< training samples before gathering
  std::size_t gathered = 0;      ///< weighted samples the learner took
  std::size_t held_out = 0;      ///< held-out samples kept
  double label_ms = 0;           ///< cut, labelling and gathering
  bool on_device = false;        ///< the samples were gathered on the device (gather_keyframe)
  bool sums_on_device = false;   ///< the learner's features and sums ran on the device
  double update_ms = 0;          ///< the learner's update and the retiring of tiles left
  double transfer_ms = 0;        ///< RePOT's transfer and seeding (0 without a dictionary)
  double lookahead_ms = 0;       ///< the look-ahead's scoring (0 without; not in the others)
  std::size_t seeded = 0;        ///< kernels RePOT seeded
  std::size_t retired = 0;       ///< tiles retired after this keyframe
  std::size_t memory_bytes = 0;  ///< the mapper's after the keyframe
};

class DriveMapper {
 public:
  /// Throws ArgumentError on a range cut that is not positive, bad learner options or a
  /// dictionary that is not 3D.
  explicit DriveMapper(const DriveMapperOptions& options = {});

  /// Adds keyframe `index` (world frame, 3D): the index seeds its labelling, so a run resumed
  /// at any keyframe continues as an uninterrupted one. With `ctx` the training samples are
  /// drawn and gathered per voxel on its device (gather_keyframe(): the same samples as the
  /// host's) and the learner's update runs on its host team. Throws ArgumentError for a 2D scan.
  KeyframeStats add(const Scan& keyframe, std::int64_t index, Context* ctx = nullptr);

  /// The map (JointBhm::map(): with `ctx`, polished on its host team, the same bits), its means
  /// polished to a relative residual of 1e-6: a hundredth of the keyframes' own cg_tolerance
  /// (1e-4). To 1e-8 a Livox walk's final polish took 271 iterations against 168, 0.3 s more
  /// for held-out scores equal in four decimals. The map carries the learner's feature cut-off
  /// (KernelMap::cutoff_tau = JointBhmOptions::tau, 4.5 by default): its weights were learned
  /// from features that end there, and its exports visit a fraction of the kernels that the
  /// evaluators' own 18 reaches (riverside-a's volume and band in 3.3 s against 5.9, held-out
  /// scores equal to five decimals).
  KernelMap map(Context* ctx = nullptr) const;
  /// The held-out samples kept (every test_stride-th of every keyframe's).
  const LabelledPoints& held_out() const { return test_; }
  const JointBhm& learner() const { return learner_; }
  const DriveMapperOptions& options() const { return o_; }
  /// The look-ahead so far (empty unless DriveMapperOptions::lookahead).
  const LookAhead& lookahead() const { return ahead_; }
  /// Keyframes added.
  std::size_t keyframes() const { return keyframes_; }
  /// Bytes held: the learner's and the held-out samples'.
  std::size_t memory_bytes() const;

  /// Writes the whole state (the learner, the kept held-out samples, the keyframe count) and
  /// the caller's `extra` bytes (a run's record) to `path`, atomically: a mapper restored from
  /// it continues bit for bit as this one would.
  void save_state(const std::string& path, const std::string& extra = {}) const;
  /// The bytes save_state() writes, for a caller that writes them itself (on another thread,
  /// while the mapper goes on: `potmap mapping`'s checkpoints).
  std::string state_bytes(const std::string& extra = {}) const;
  /// Restores a state that save_state() wrote with the same options; returns its extra bytes.
  /// Throws InputError naming the file and byte for a damaged file or one saved with other
  /// options (the mapper is then unchanged).
  std::string load_state(const std::string& path);
  /// The extra bytes of a state file alone (a caller checks its own record before the
  /// mapper's options). Throws InputError as load_state().
  static std::string state_extra(const std::string& path);

 private:
  DriveMapperOptions o_;
  JointBhm learner_;
  LabelledPoints test_;
  LookAhead ahead_;
  std::size_t keyframes_ = 0;
  // Scores the map as it stands on the held-out samples from test_[first] on (lookahead).
  void look_ahead(std::size_t first, Context* ctx);
};

}  // namespace potmap
POTMAP_CXX_API_END
