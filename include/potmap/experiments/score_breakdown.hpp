#pragma once
// Held-out scores broken down by where a sample lies: its horizontal range from the sensor of
// its beam, its height relative to that sensor, and what it is (a hit on the ground, another
// hit, a free sample of a beam that hit something, a free sample of a beam with no return within
// the range cut). `potmap experiment` prints the table and writes it in its JSON for 3D tasks,
// so that a method's loss can be placed (far range, ground, free space past the cut).

#include <cstdint>
#include <string>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/export.h"
#include "potmap/map/metrics.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

/// Where each held-out sample lies, one entry per sample of the test set.
struct SamplePlaces {
  std::vector<double> range;   ///< horizontal distance from its beam's sensor, metres
  std::vector<double> height;  ///< height above its beam's sensor, metres (negative below)
  /// 1: a free sample of a beam with no return within the scan's range (a no-return, or a
  /// return beyond the cut); 0: a hit, or a free sample of a beam that ends in a hit.
  std::vector<std::uint8_t> past_cut;
  /// Free samples of beams that end in a hit: their distance to that hit, metres; NaN for the
  /// others. Empty: not known (the axis "free to hit" is left out).
  std::vector<double> to_hit;
};

/// The held-out samples of make_task(scans, labels, test, margin, first_index) placed: walks
/// each scan's held-out beams (heldout_beams) in label_scan's order, a hit and then its free
/// samples, the no-returns last. Throws InputError when `test` is not that test set (sizes,
/// labels or scan indices disagree).
SamplePlaces place_test_samples(const std::vector<Scan>& scans, const LabelOptions& labels,
                                std::int64_t first_index, const LabelledPoints& test);

/// The bins. Range bins hold the samples of beams that end in a hit (hits and their free
/// samples); the free samples of beams past the cut form a range bin of their own.
struct BreakdownOptions {
  /// Range bin edges, metres, increasing (default 0, 10, 20, 30, 40); a sample at or past the
  /// last edge goes to the last bin.
  std::vector<double> range_edges{0, 10, 20, 30, 40};
  /// Height bin edges relative to the sensor, metres, increasing (default -1.2, 0, 2): below
  /// the first and above the last are bins of their own.
  std::vector<double> height_edges{-1.2, 0, 2};
  /// Hits lower than this relative to the sensor count as ground (default -1.2 m: a car's roof
  /// sensor is 1.8 to 2 m above the road), the others as walls and objects.
  double ground_below = -1.2;
  /// Bin edges of a free sample's distance to its beam's hit, metres (default 0.5, 1, 2, 4;
  /// open at both ends): how the map reads the space just before a surface.
  std::vector<double> to_hit_edges{0.5, 1, 2, 4};
};

/// What a sample is.
enum class SampleKind { ground_hit = 0, other_hit = 1, free_of_hit = 2, free_past_cut = 3 };
SampleKind sample_kind(bool hit, double height, bool past_cut, const BreakdownOptions& o);
const char* kind_name(SampleKind k);

/// Index of value `v` among the bins of increasing `edges`: with `open_below` (heights) bin 0
/// is below edges[0] and bin edges.size() above the last edge; without it (ranges) bin i is
/// [edges[i], edges[i+1]), values below edges[0] go to bin 0 and values at or past the last
/// edge to the last bin (edges.size() - 2). Throws ArgumentError for fewer than 2 edges
/// without open_below, none with it, or edges that do not increase.
std::size_t bin_index(double v, const std::vector<double>& edges, bool open_below);
/// Names of those bins, e.g. "10-20 m", "< -1.2 m", "0..2 m", ">= 2 m".
std::vector<std::string> bin_names(const std::vector<double>& edges, bool open_below);

/// The scores of the samples of one bin (NaN AUC where the bin holds one class).
struct BinScores {
  std::string axis;  ///< "range", "height", "kind", "kind@range" or "free to hit"
  std::string bin;   ///< the bin's name
  Scores scores;
};

/// Scores of `prob` (one per sample of `test`, in [0, 1]) in every bin: axis "range" (the
/// range bins and "past cut"), "height", "kind", "kind@range" (each kind per range bin;
/// past-cut free samples by their own range) and "free to hit" (free samples of beams that end
/// in a hit, by their distance to it; when places.to_hit is given). Empty bins are left out.
std::vector<BinScores> score_breakdown(const std::vector<double>& prob, const LabelledPoints& test,
                                       const SamplePlaces& places, const BreakdownOptions& o = {});

}  // namespace potmap::experiment
POTMAP_CXX_API_END
