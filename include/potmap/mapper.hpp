#pragma once
// Streams scans through POT (or RePOT) in order, keeping the device busy: the host prepares
// scan i+1 (labelling, sector cut, subsampling, batch assembly) on a second thread while scan i
// is solved. What to do with each instantaneous map (accumulate an overall map, write it,
// score it) is the caller's: map_scans() hands every result to a callback in scan order.

#include <cstddef>
#include <functional>
#include <vector>
#include "potmap/export.h"

#include "potmap/atoms.hpp"
#include "potmap/context.hpp"
#include "potmap/labelling.hpp"
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

}  // namespace potmap
POTMAP_CXX_API_END
