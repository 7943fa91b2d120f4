#pragma once
// Streams scans through POT (or RePOT) in order, keeping the device busy: the host prepares
// scan i+1 (labelling, sector cut, subsampling, batch assembly) on a second thread while scan i
// is solved. What to do with each instantaneous map (accumulate an overall map, write it,
// score it) is the caller's: map_scans() hands every result to a callback in scan order.
//
// Mapper is the incremental form for a program that receives scans one at a time (a ROS node,
// a SLAM front end): add_scan() maps one scan and merges it into an overall map. It gives the
// same instantaneous maps as map_scans() on the same scans in the same order.
//
// Thread safety: a Dictionary is read-only once built and may be shared by any number of
// threads and mappers at once. A Mapper is used by one thread at a time; different mappers may
// run concurrently, on one Context too (their device work is then serialised on its queue).

#include <cstddef>
#include <functional>
#include <memory>
#include <vector>
#include "potmap/export.h"

#include "potmap/atoms.hpp"
#include "potmap/context.hpp"
#include "potmap/labelling.hpp"
#include "potmap/overall_map.hpp"
#include "potmap/pot.hpp"
#include "potmap/scan.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct MapperOptions {
  PotOptions pot;        ///< transfer settings (PotOptions::refine switches RePOT on)
  LabelOptions labels;   ///< labelling and the held-out split (default: 20 % of beams held out)
  bool pipeline = true;  ///< prepare the next scan on a second thread (false: one thread)
};

/// One mapped scan.
struct MappedScan {
  std::size_t index = 0;  ///< position in the input
  ScanTransfer transfer;  ///< instantaneous map, per-sector choices, stage timings
  /// The scan's held-out samples (never used for transport) within the sector radius of the
  /// sensor (PotOptions::max_range, else the dictionary's): no transported kernel reaches
  /// farther, so samples beyond are not mapped, neither held out nor used for training.
  LabelledPoints test;
  double wall_ms = 0;  ///< wall-clock time from the start of its solve to the callback
};

/// Maps `scans` in order with the dictionary. `ctx` null: CPU reference. Scans whose dimension
/// differs from the dictionary's raise ArgumentError naming the scan. Exceptions from the
/// callback stop the run and propagate (the pending preparation is waited for first).
void map_scans(Context* ctx, const Dictionary& dict, const std::vector<Scan>& scans,
               const MapperOptions& options, const std::function<void(MappedScan&&)>& on_scan);

/// What Mapper::add_scan() did to the overall map.
struct MapperMerge {
  OverallMapAddStats stats;  ///< kernels added, merged, retired, fused
  double merge_ms = 0;       ///< wall-clock time of the merge, milliseconds
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

  /// Maps one scan (its index is the number of scans added since construction or reset(), which
  /// seeds the labelling and subsampling as in map_scans) and merges its instantaneous map into
  /// the overall map. Returns the mapped scan, valid until the next add_scan() or reset().
  /// Throws ArgumentError when the scan's dimension differs from the dictionary's; the mapper
  /// is unchanged then.
  const MappedScan& add_scan(const Scan& scan);

  /// The last mapped scan (index 0 and an empty map before the first add_scan()).
  const MappedScan& last() const { return last_; }
  /// What the last add_scan() did to the overall map.
  const MapperMerge& last_merge() const { return merge_; }
  /// The accumulated map of every scan since construction or reset().
  const OverallMap& overall() const { return overall_; }
  /// Scans added since construction or reset().
  std::size_t scans() const { return scans_; }
  const Dictionary& dictionary() const { return *dict_; }
  const MapperOptions& options() const { return options_; }

  /// Forgets every scan: empty overall map, scan index back to 0 (same options).
  void reset();

 private:
  Context* ctx_;
  std::shared_ptr<const Dictionary> dict_;
  MapperOptions options_;
  OverallMap overall_;
  MappedScan last_;
  MapperMerge merge_;
  std::size_t scans_ = 0;
};

}  // namespace potmap
POTMAP_CXX_API_END
