#pragma once
// Streams scans through POT (or RePOT) in order, keeping the device busy: the host prepares
// scan i+1 (labelling, sector cut, subsampling, batch assembly) on a second thread while scan i
// is solved. What to do with each instantaneous map (accumulate an overall map, write it,
// score it) is the caller's: map_scans() hands every result to a callback in scan order.
//
// Mapper is the incremental form for a program that receives scans one at a time (a ROS node,
// a SLAM front end): add_scan() maps one scan and adds it to an overall map. It gives the
// same instantaneous maps as map_scans() on the same scans in the same order, except with the
// indexed ranking: its warm candidates (PotOptions::warm_candidates) are the previous scan's
// atoms in add_scan(), the ones of the scan before that in map_scans() (whose next scan is
// prepared while the current one is solved). add_mapped() adds map_scans()' results instead.
//
// The overall map: POT merges the instantaneous maps into an OverallMap (overall_map.hpp).
// RePOT, by default (MapperOptions::persistent_refine), keeps one persistent joint BHM
// (RepotMap, a growable JointBhm) whose kernels every scan updates with its own training
// samples, the scan's transported kernels seeding only the space no sample has reached yet;
// its memory grows with the area driven, not with the number of scans.
//
// Checkpoints: Mapper::save_state() writes the mapper's whole state (overall map, persistent
// learner, scan count, warm candidates) to a file, and load_state() restores it into a mapper
// built with the same dictionary and options; mapping the remaining scans then gives the same
// overall map, bit for bit, as a mapper that never stopped. map_scans() continues a run from a
// restored mapper's continuation().
//
// Thread safety: a Dictionary is read-only once built and may be shared by any number of
// threads and mappers at once. A Mapper is used by one thread at a time; different mappers may
// run concurrently, on one Context too (their device work is then serialised on its queue).

#include <cstddef>
#include <functional>
#include <future>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "potmap/export.h"

#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/averaged_map.hpp"
#include "potmap/pot/overall_map.hpp"
#include "potmap/pot/transfer.hpp"
#include "potmap/runtime/context.hpp"

// Internal (host/), declared outside the exported region so that it stays hidden: the state file of
// Mapper::save_state (host/pot/mapper_state.cpp).
namespace potmap::detail {
struct MapperState;
}

POTMAP_CXX_API_BEGIN
namespace potmap {

/// The defaults are the settings that map real logs best, those `potmap mapping` runs
/// (PotOptions' defaults, the averaged overall map, barycentric seeds with a displacement
/// variance for RePOT's persistent map); paper() gives the authors' rules.
struct MapperOptions {
  /// The authors' rules (SPEC section 4, the paper's experiments): PotOptions::paper(), POT's
  /// instantaneous maps summed with merging (average_overall false) and RePOT's seeds placed as
  /// pot.placement places kernels, without displacement variance; every other field as the
  /// defaults.
  static MapperOptions paper();

  PotOptions pot;       ///< transfer settings (PotOptions::refine switches RePOT on)
  LabelOptions labels;  ///< labelling and the held-out split (default: 20 % of beams held out)
  /// Overlap the host's work with the device's (false: one thread, one stage at a time): the
  /// next scan is prepared, and the last one's kernels placed, on other threads while the
  /// current scan is ranked and transported. The same maps either way.
  bool pipeline = true;
  /// RePOT's overall map (read only with pot.refine; default true): one persistent joint BHM
  /// (RepotMap) that every scan updates with its own training samples, the priors of the
  /// kernels no sample has reached yet seeded from the scan's transported kernels. The scans
  /// are then transported without a per-scan refinement (their instantaneous maps are POT's);
  /// the refinement happens once, in the persistent map. Why the default: a per-scan
  /// refinement sees one scan only, and merging the refined maps averages overlapping kernels
  /// instead of accumulating the evidence of every scan (as the experiments' RePOT,
  /// experiment::PotSetup::persistent_refine). false: every scan refined on its own
  /// (PotOptions::refine_bhm) and merged into an OverallMap, as POT's. In 3D every stored
  /// kernel of the persistent map holds the half of its precision stencil, 126 doubles (1 KB)
  /// at the default width and cut-off, in tiles of 512 kernels: a long 3D drive may want a
  /// coarser refine_map.spacing or false here.
  bool persistent_refine = true;
  /// The persistent map's grid and prior (default JointBhmOptions{}: kernels 0.5 m apart,
  /// prior variance 10; unbounded, tiles allocated as the drive reaches them), and its
  /// forgetting (half_life, default 0: never; the scans' timestamps are its clock).
  JointBhmOptions refine_map;
  /// The persistent map's update given the context (JointBhm::update's ctx: its features and
  /// sums on the device as refine_map.sums says, its solve in two parts on the context's host
  /// helper; with refine_map.sums = host the same map bit for bit either way). Default false:
  /// on the 2-core EPYC virtual machine the host's merge ran slower that way inside the mapper
  /// (7.3-8.2 against 6.6-7.4 ms a town2 scan, alternated rounds), its two parts streaming the
  /// precision over a memory path the two cores share (docs/pot-scale.md).
  /// bench/joint_update --team both measures the difference on a machine.
  bool refine_on_host_team = false;
  /// Seeded prior variances are at least this (weight units squared; default 10, the
  /// persistent map's default prior variance: a seed then moves the prior mean only).
  /// Transported variances say how sure the source was, not how well the atom fits here; the
  /// experiments found smaller floors worse on the real logs. Clamped to refine_map.prior_var.
  double seed_min_variance = 10.0;
  /// Where the transported kernels that seed RePOT's persistent map go (read only with
  /// persistent_refine(); in place of pot.placement). Default barycentric: seeds matter only
  /// where no sample reaches a kernel, which kernels on the target's samples never are, while
  /// barycentric images reach past the scan's samples.
  PotPlacement seed_placement = PotPlacement::barycentric;
  /// Weight variance added to those seeds per square metre the transport moved them (weight
  /// units^2 / m^2; read only with persistent_refine(), in place of pot.displacement_variance).
  /// Default 0.25, the experiments': a seed moved 2 m gains variance 1, so the farther a poor
  /// match dragged it, the less it says. paper(): 0.
  double seed_displacement_variance = 0.25;
  /// POT's overall map (read unless RePOT's persistent map is on): the support-weighted average
  /// of the instantaneous maps (AveragedMap, true, the default) or their kernels summed with
  /// merging (OverallMap and the constructor's OverallMapOptions, false: the authors' rule,
  /// paper()). Why the default: summed kernels let one scan's free space erase another's walls;
  /// the average with PotOptions::placement = target_samples is what the experiments run
  /// (docs/pot-measurements.md: on the Radish logs AUC 0.93-0.96 where the sum of barycentric
  /// kernels gives 0.89-0.94).
  bool average_overall = true;
  AveragedMapOptions averaged;  ///< the averaged overall map's grid and solve
  /// Mapper::add_scan() returns once the scan is transferred, and its merge into the overall
  /// map (POT's merge, RePOT's persistent update) runs on another thread beside the caller's
  /// next add_scan(), whose preparation and transfer it overlaps (default false). The overall
  /// map is the same, bit for bit: every accessor of it, last_merge(), save_state(), reset()
  /// and the next add_scan() or add_mapped() first wait for the merge in flight, and an
  /// exception the merge threw is rethrown there (the overall map then lacks that scan).
  /// Why not the default: a caller that reads the overall map after every scan waits for the
  /// merge anyway, and gains nothing; one that reads it now and then (a planner at 1 Hz, a
  /// checkpoint) gets the scans through at the transfer's pace (docs/pot-scale.md). Ignored by
  /// map_scans(), whose pipeline overlaps scans already.
  bool async_merge = false;
};

/// Whether `o` asks for RePOT's persistent overall map (pot.refine and persistent_refine).
inline bool persistent_refine(const MapperOptions& o) {
  return o.pot.refine && o.persistent_refine;
}

/// The placement `potmap map --placement auto` chooses for `o`: kernels on the scan's samples,
/// except for the seeds of RePOT's persistent map, which stay barycentric (kernels on the
/// samples are all reached by samples and would seed nothing). The defaults' placements
/// (PotOptions::placement, MapperOptions::seed_placement) give the same.
inline PotPlacement auto_placement(const MapperOptions& o) {
  return persistent_refine(o) ? PotPlacement::barycentric : PotPlacement::target_samples;
}

/// The transfer settings a mapper transports each scan with: `o.pot`, except that with RePOT's
/// persistent map (persistent_refine(o)) the kernels are placed by seed_placement with
/// seed_displacement_variance, and refine is off (the persistent map does the refinement).
PotOptions mapper_transfer_options(const MapperOptions& o);

/// One mapped scan.
struct MappedScan {
  std::size_t index = 0;  ///< position in the input
  double time = 0;        ///< the scan's timestamp, seconds (Scan::timestamp)
  ScanTransfer transfer;  ///< instantaneous map, per-sector choices, stage timings
  /// The scan's held-out samples (never used for transport) within the sector radius of the
  /// sensor (PotOptions::max_range, else the dictionary's): no transported kernel reaches
  /// farther, so samples beyond are not mapped, neither held out nor used for training.
  LabelledPoints test;
  /// The scan's training samples within the sector radius (what the transport used), for the
  /// caller's persistent map: filled only when persistent_refine(options), else empty.
  LabelledPoints train;
  /// Wall-clock time of its solve and placement, milliseconds (with the pipeline, the wait
  /// for the callback while the next scan is solved is not counted).
  double wall_ms = 0;
};

/// RePOT's persistent overall map (MapperOptions::persistent_refine): a growable JointBhm with
/// MapperOptions::refine_map's settings. add() seeds the prior of its kernels no sample has
/// reached yet from a scan's transported kernels (JointBhm::seed_unreached with
/// MapperOptions::seed_min_variance), then updates it with the scan's training samples.
/// Memory grows with the area the samples cover, never with the number of scans.
class RepotMap {
 public:
  /// Throws ArgumentError for a dimension other than 2 or 3 or bad refine_map options.
  RepotMap(int dim, const MapperOptions& options);
  /// One scan: seeds from `transported` (may be empty), then learns `train`. Returns the
  /// number of kernels seeded. Throws ArgumentError on a dimension mismatch. `ctx` (default
  /// null: this thread alone): the update shares its work with the context's host helper
  /// (JointBhm::update; the same map bit for bit either way). `time`: the scan's timestamp,
  /// seconds, the learner's clock for forgetting (refine_map.half_life; JointBhm::set_time);
  /// NaN (default) leaves the clock where it is.
  std::size_t add(const KernelMap& transported, const LabelledPoints& train, Context* ctx = nullptr,
                  double time = std::numeric_limits<double>::quiet_NaN());
  /// The map (JointBhm::map(): kernels with a bias weight), exported on the first call after
  /// an add() and kept until the next one: call it when the map is needed, not every scan.
  const KernelMap& map() const;
  std::size_t size() const { return learner_.size(); }  ///< stored kernels
  /// The learner's bytes and the kept export's.
  std::size_t memory_bytes() const;
  const JointBhm& learner() const { return learner_; }

 private:
  friend struct detail::MapperState;
  JointBhm learner_;
  double seed_min_variance_ = 10;
  mutable std::optional<KernelMap> export_;
};

/// Maps `scans` in order with the dictionary. `ctx` null: CPU reference. Scans whose dimension
/// differs from the dictionary's raise ArgumentError naming the scan. Exceptions from the
/// callback stop the run and propagate (the pending preparation is waited for first). With
/// persistent_refine(options) the scans are transported without a per-scan refinement and
/// MappedScan::train carries their training samples: the caller's RepotMap does the rest
/// (RepotMap::add(m.transfer.map, m.train)), as Mapper does.
void map_scans(Context* ctx, const Dictionary& dict, const std::vector<Scan>& scans,
               const MapperOptions& options, const std::function<void(MappedScan&&)>& on_scan);

/// Where map_scans() starts: a run that continues after scan `first - 1` (a checkpoint; see
/// Mapper::continuation()). The warm candidates of scan i are the atoms chosen for scan i - 2
/// (the pipeline prepares scan i while scan i - 1 is solved, with or without a second thread),
/// so a run continues exactly only with the atoms of the two scans before `first`.
struct MapScansStart {
  std::size_t first = 0;          ///< index of the first scan to map (those before are skipped)
  std::vector<long> warm_before;  ///< chosen_atoms() of scan first - 2 (empty if none)
  std::vector<long> warm_last;    ///< chosen_atoms() of scan first - 1 (empty if none)
};

/// map_scans() from `start`: scans[start.first ..] are mapped with their own indices (which seed
/// the labelling and subsampling), as they would be in a run over every scan. start.first past
/// the end maps nothing.
void map_scans(Context* ctx, const Dictionary& dict, const std::vector<Scan>& scans,
               const MapperOptions& options, const std::function<void(MappedScan&&)>& on_scan,
               const MapScansStart& start);

/// What Mapper::add_scan() did to the overall map.
struct MapperMerge {
  OverallMapAddStats stats;  ///< kernels added, merged, retired, fused (POT's OverallMap)
  /// RePOT's persistent map: its kernels whose prior the scan's transported kernels seeded.
  std::size_t seeded = 0;
  /// Wall-clock time of the merge, milliseconds (the persistent map's update counts as the
  /// scan's refinement, ScanTransfer::timing.refine_ms, not here; with
  /// MapperOptions::async_merge it is counted here, since the scan was handed back before it).
  double merge_ms = 0;
};

/// Incremental POT/RePOT mapping with an overall map (SPEC steps 2 to 7 per scan, step 6
/// across scans). Scans are prepared and solved on the calling thread, one at a time.
class Mapper {
 public:
  /// `ctx` null: the CPU reference (slow; for checks). `ctx` must outlive the mapper; the
  /// dictionary is shared (never changed by the mapper). options.pipeline is ignored: the next
  /// scan is not known before add_scan() is called. Throws ArgumentError for a null or empty
  /// dictionary or bad options.
  Mapper(Context* ctx, std::shared_ptr<const Dictionary> dict, const MapperOptions& options = {},
         const OverallMapOptions& overall = {});
  /// Copies and moves wait for the source's merge in flight (async_merge) first; the
  /// destructor waits for this one's.
  Mapper(const Mapper&) = default;
  Mapper(Mapper&&) = default;
  Mapper& operator=(const Mapper&) = default;
  Mapper& operator=(Mapper&&) = default;
  ~Mapper();

  /// Maps one scan (its index is the number of scans added since construction or reset(), which
  /// seeds the labelling and subsampling as in map_scans) and adds it to the overall map: POT
  /// merges its instantaneous map, RePOT (persistent) seeds and updates the persistent map with
  /// it. Returns the mapped scan, valid until the next add_scan() or reset(). Throws
  /// ArgumentError when the scan's dimension differs from the dictionary's; the mapper is
  /// unchanged then.
  const MappedScan& add_scan(const Scan& scan);

  /// Adds a scan mapped elsewhere (map_scans() with this mapper's options(), e.g. pipelined)
  /// to the overall map, as add_scan() would have after mapping it: its index must be scans()
  /// (ArgumentError otherwise, the mapper unchanged). m.transfer.timing.refine_ms gains the
  /// persistent map's update. Returns what the merge did.
  const MapperMerge& add_mapped(MappedScan&& m);

  /// Where map_scans() continues this mapper's run: scans() and the atoms of the two last scans.
  MapScansStart continuation() const;

  /// Makes this mapper, which has no scans yet, map a part of a longer run that starts at scan
  /// `index`: the next scan gets that index (which seeds its labelling and subsampling, so the
  /// part's held-out samples are the whole run's), and scans() counts from it. The part starts
  /// without warm candidates (those of a run's scans index - 2 and index - 1). The parts' maps
  /// merge into the whole run's (merge_joint_bhm, AveragedMap::add_map: `mpirun potmap
  /// mapping`). Throws ArgumentError when the mapper already has scans.
  void start_at(std::size_t index);

  /// Writes the mapper's state to `path` (a binary container, written atomically: a
  /// half-written file never replaces an earlier one): the overall map (POT's merged kernels
  /// with their counts and ages, or RePOT's persistent learner with its precision, natural
  /// parameters and caches), the scan count, the warm candidates of the next scans, and
  /// fingerprints of the dictionary and options. `extra`: the caller's own bytes (e.g. its
  /// position in the input), returned by load_state() (default: none). Throws potmap::Error
  /// naming the path when it cannot be written. The last mapped scan (last()) is not saved.
  void save_state(const std::string& path, const std::string& extra = {}) const;

  /// Restores a state written by save_state() into this mapper, which must have been built
  /// with the same dictionary (same atoms) and options: mapping the remaining scans then gives
  /// what the saved mapper would have given, bit for bit. Returns the caller's `extra` bytes.
  /// Throws InputError "<path>: byte offset <n>: ..." for a missing, truncated or corrupt file
  /// (checksum), or a state saved with another dictionary, options or dimension (the mapper is
  /// unchanged then). last() afterwards is an empty scan with index scans() - 1.
  std::string load_state(const std::string& path);

  /// The `extra` bytes of a state file, without restoring anything (a caller checks its own
  /// record of the run, e.g. which input it was, before load_state()). Throws as load_state()
  /// for a missing, truncated or corrupt file.
  static std::string state_extra(const std::string& path);

  /// The last mapped scan (index 0 and an empty map before the first add_scan()).
  const MappedScan& last() const { return last_; }
  /// What the last add_scan() did to the overall map (waits for a merge in flight).
  const MapperMerge& last_merge() const {
    settle();
    return merge_;
  }
  /// The merged map of every scan since construction or reset(): POT's, or RePOT's without
  /// persistent_refine; empty for RePOT's persistent map (see overall_map(), repot()).
  const OverallMap& overall() const {
    settle();
    return overall_;
  }
  /// The overall map whichever the kind: overall().map(), or the persistent map's export
  /// (RepotMap::map(): computed on the first call after a scan, then kept).
  const KernelMap& overall_map() const;
  /// Kernels of the overall map (the persistent map's stored kernels).
  std::size_t overall_kernels() const;
  /// Bytes held by the overall map.
  std::size_t overall_memory_bytes() const;
  /// RePOT's persistent map; null unless persistent_refine(options()).
  const RepotMap* repot() const {
    settle();
    return repot_ ? &*repot_ : nullptr;
  }
  /// POT's averaged overall map; null unless options().average_overall and no persistent
  /// RePOT map.
  const AveragedMap* averaged() const {
    settle();
    return averaged_ ? &*averaged_ : nullptr;
  }
  /// Scans added since construction or reset().
  std::size_t scans() const { return scans_; }
  const Dictionary& dictionary() const { return *dict_; }
  const MapperOptions& options() const { return options_; }

  /// Forgets every scan: empty overall map, scan index back to 0 (same options). A merge in
  /// flight is waited for and its error, if any, forgotten with it.
  void reset();

 private:
  friend struct detail::MapperState;
  // Merges `m` into the overall map, recording what it did in `out`.
  void merge_scan(MappedScan& m, MapperMerge& out, bool refine_into_scan);
  // Waits for the merge in flight (async_merge) and rethrows its exception.
  void settle() const;
  // The merge of last_ in flight (async_merge). Copying or moving one first waits for the
  // source's merge, and it is the first member, so a Mapper copied, moved or assigned while a
  // merge runs copies finished maps; ~Mapper() waits for it before the maps go.
  class MergeSlot {
   public:
    MergeSlot() = default;
    MergeSlot(const MergeSlot& o) { o.wait(); }  // a copy has nothing in flight
    MergeSlot(MergeSlot&& o) noexcept : f_((o.wait(), std::move(o.f_))) {}
    MergeSlot& operator=(const MergeSlot& o) {
      wait();
      o.wait();
      return *this;
    }
    MergeSlot& operator=(MergeSlot&& o) noexcept {
      wait();
      o.wait();
      f_ = std::move(o.f_);
      return *this;
    }
    ~MergeSlot() = default;
    void wait() const {
      if (f_.valid()) f_.wait();
    }
    void start(std::future<void> f) { f_ = std::move(f); }
    // Waits and rethrows the merge's exception (once: get() leaves the future empty).
    void settle() const {
      if (f_.valid()) f_.get();
    }
    void forget() {
      wait();
      f_ = {};
    }

   private:
    mutable std::future<void> f_;
  };
  MergeSlot merging_;
  Context* ctx_;
  std::shared_ptr<const Dictionary> dict_;
  MapperOptions options_;
  OverallMap overall_;
  std::optional<AveragedMap> averaged_;  // options_.average_overall (and no RePOT map)
  std::optional<RepotMap> repot_;
  MappedScan last_;
  MapperMerge merge_;
  std::size_t scans_ = 0;
  std::vector<long> warm_[2];  // chosen atoms of scans scans_ - 2 and scans_ - 1
};

}  // namespace potmap
POTMAP_CXX_API_END
