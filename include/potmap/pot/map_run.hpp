#pragma once
// A mapping run scored on its own held-out beams, as `potmap map`, `potmap mapping` and the
// Python potmap.map_recording() report it: the scans streamed through map_scans() into a
// Mapper, every scan's held-out samples (never used for transport) scored on its own
// instantaneous map as it comes and, at the end, on the overall map.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/export.h"
#include "potmap/map/metrics.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/pot/transfer.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// The per-scan totals of a scored run: what the summary is computed from, and what a
/// checkpointed run saves so that a resumed run ends with the summary of an uninterrupted one.
struct MapRunTotals {
  std::vector<float> inst_prob;      ///< held-out samples on their instantaneous maps
  std::vector<std::uint8_t> labels;  ///< their labels
  LabelledPoints test;               ///< the held-out samples, scored on the overall map
  PotTiming timing;                  ///< sums over the scans
  double wall_ms = 0, max_wall_ms = 0;
  std::size_t kernels = 0;  ///< instantaneous kernels, summed
  std::size_t scans = 0;
  double seconds = 0;  ///< wall-clock time of the earlier stretches of the run (resumed ones)
  /// Look-ahead (map_scored's `lookahead`): per held-out sample of every scan after the run's
  /// first, the overall map's probability before that scan joined it, its label, and 1 where no
  /// earlier sample had reached a kernel there (JointBhm::reached). Empty without.
  std::vector<float> ahead_prob;
  std::vector<std::uint8_t> ahead_label, ahead_beyond;
  double ahead_ms = 0;  ///< the look-ahead's scoring, outside the scans' times
};

/// Maps scans[mapper.scans() ..] (a mapper restored from a checkpoint continues where it
/// stopped) with map_scans() and the mapper's options, and adds each to `mapper` in order
/// (Mapper::add_mapped), its held-out samples and timings to `totals` (whose test.dim must be
/// the dictionary's). `after_scan`, when set, is called after each scan's merge with the scan
/// as the mapper keeps it (Mapper::last()); an exception from it stops the run and propagates.
/// With mapper.options().pipeline, everything after a scan's transfer (its scores, its merge,
/// `after_scan`) runs on a worker beside the next scan's transfer, which reads none of it: the
/// scans still reach the mapper one at a time and in order, so the maps are a serial run's.
/// `lookahead` (default false; RePOT's persistent map only, ArgumentError otherwise): before
/// each scan after the mapper's first joins the map, the map as it stands scores the scan's
/// held-out samples into totals.ahead_* (JointBhm::predict; the map is unchanged).
void map_scored(Context* ctx, Mapper& mapper, const std::vector<Scan>& scans, MapRunTotals& totals,
                const std::function<void(const MappedScan&)>& after_scan = {},
                bool lookahead = false);

/// What a scored run came to.
struct MapRunSummary {
  Scores instantaneous;  ///< every scan's held-out samples on its own instantaneous map
  Scores overall;        ///< every scan's held-out samples on the final overall map
  std::size_t scans = 0;
  PotTiming mean_timing;    ///< per scan
  double mean_wall_ms = 0;  ///< per scan, solve to callback
  double max_wall_ms = 0;
  std::size_t kernels_per_scan = 0;  ///< instantaneous kernels
};

/// The per-scan means of `totals`, and the overall map of `mapper` scored on every held-out
/// sample of `totals` (on the device of `ctx`; null: the exact sum on the host).
MapRunSummary summarise_run(Context* ctx, const Mapper& mapper, const MapRunTotals& totals);

/// The same for an overall map made elsewhere (the parts of a run mapped apart and merged):
/// `totals` are the parts' totals together (add_totals()).
MapRunSummary summarise_run(Context* ctx, const KernelMap& overall, const MapRunTotals& totals);

/// Appends the totals of a later part of a run to `into`: its held-out samples and per-scan
/// values after `into`'s, its sums added, the largest scan time kept. Throws ArgumentError when
/// the held-out samples' dimensions differ.
void add_totals(MapRunTotals& into, const MapRunTotals& part);

}  // namespace potmap
POTMAP_CXX_API_END
