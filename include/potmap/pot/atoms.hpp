#pragma once
// Sectors and the dictionary of atoms (SPEC section 4, steps 1 and 8; paper Sec. III-A, Fig. 4).
//
// A scan's labelled samples are cut into equal angular sectors around the sensor (2D: circular
// sectors of radius max_range; 3D: cylindrical "pie slices", the angle taken about the vertical
// axis and the radius measured horizontally). Sector k holds the samples whose bearing from the
// sensor, measured counter-clockwise from the sensor's heading, lies in [k, k+1) * 2 pi / sectors.
// Each sector is expressed relative to its hit centroid (the free-sample centroid when it has no
// hits) and multiplied by `scale`: p' = (p - centre) * scale. An atom is a sector of a source
// scan plus the learned kernels whose positions fall in the same sector, in the same frame.
// Kernel widths (gamma, 1/m^2) and weights travel unchanged: they stay in world units.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// How scans are cut into sectors. The dictionary and the targets mapped with it must agree on
/// `scale` (checked by transfer_scan); the number of sectors may differ.
struct SectorOptions {
  int sectors = 5;            ///< equal angular sectors of the full circle (>= 1; default 5)
  double max_range = 0;       ///< sector radius, metres (> 0); 0: the scan's own max_range
  double scale = 1.0 / 50.0;  ///< s: multiplies centred coordinates (authors: 1/50 at 20 m)
  /// Sectors with fewer samples (hits + free) than this are dropped (default 4).
  std::size_t min_samples = 4;
};

/// One sector of one scan, centred and scaled.
struct Sector {
  int dim = 2;
  int index = 0;                          ///< sector number in [0, sectors)
  std::array<double, 3> centre{0, 0, 0};  ///< world-frame centroid the points are relative to, m
  std::array<double, 3> sensor{0, 0, 0};  ///< world-frame sensor position, metres
  double scale = 1.0 / 50.0;              ///< s used for this sector
  double max_range = 20;                  ///< sector radius, metres
  std::vector<double> hits;               ///< (p - centre) * scale, dim per point (y = 1 samples)
  std::vector<double> free;               ///< (p - centre) * scale, dim per point (y = 0 samples)
  std::size_t num_hits() const { return hits.size() / dim; }
  std::size_t num_free() const { return free.size() / dim; }
};

/// Heading of a scan's sensor (radians, counter-clockwise from +x): pose2d yaw in 2D, the yaw
/// of the rotation's x axis in 3D.
double scan_heading(const Scan& scan);

/// Cuts labelled samples seen from `sensor` (world frame, metres) with the sensor's `heading`
/// (radians) into sectors. Samples farther than max_range (horizontally) from the sensor are
/// ignored; sectors with fewer than options.min_samples samples are not returned. Sectors come
/// back in increasing index. Throws ArgumentError for bad options (max_range 0 is not allowed
/// here: there is no scan to take it from).
std::vector<Sector> cut_sectors(const LabelledPoints& samples, const std::array<double, 3>& sensor,
                                double heading, const SectorOptions& options);

/// A dictionary entry: a source sector and its kernels in the sector's frame.
struct Atom {
  Sector sector;
  /// Kernels whose positions fall in the sector (same bearing and radius rule as the samples),
  /// positions as (h - centre) * scale; gamma, w_mean, w_var unchanged (world units). No bias.
  KernelMap kernels;
  std::int64_t scan_index = 0;  ///< which source scan it came from
  std::string source;           ///< provenance: dataset or map name (free text, may be empty)
};

/// The dictionary of atoms of SPEC step 1.
struct Dictionary {
  int dim = 2;
  double scale = 1.0 / 50.0;  ///< s shared by every atom
  double max_range = 20;      ///< metres: the sector radius atoms were cut with
  int sectors = 5;            ///< sectors per source scan used when it was built
  std::vector<Atom> atoms;
  std::size_t size() const { return atoms.size(); }
  bool empty() const { return atoms.empty(); }
};

/// How build_dictionary() proceeds.
struct DictionaryOptions {
  SectorOptions sectors;  ///< the cut; max_range 0 takes each scan's own
  /// Labelling of the source scans. The dictionary uses every beam by default
  /// (holdout_fraction 0): source data are not the evaluation data.
  LabelOptions labels = [] {
    LabelOptions o;
    o.holdout_fraction = 0;
    return o;
  }();
  /// Kernels whose weight variance is above this are left out of atoms (default 1000; the
  /// priors are 1e4 for BHM and 900^2 for ABHM). A kernel the source data never reached keeps
  /// its prior: mean 0 and a huge variance, which carries no shape and, transported into
  /// observed space, pulls every probability near it to 0.5. Infinity keeps every kernel.
  double max_weight_variance = 1000;
  /// Kernels farther than this from every sample of their sector (hits and free samples of
  /// the atom's own scan), metres, are left out (0, the default: no limit). A map learned from
  /// many scans knows places one scan never saw; an atom must describe what its own samples
  /// describe, since only they steer where its kernels are transported.
  double max_sample_distance = 0;
  /// Kernels at the samples (metres; 0, the default: the map's own kernels). > 0: an atom's
  /// kernels are placed at its own hits and free samples, thinned to one per cell of this edge
  /// (hits and free samples apart), each with the map's width there and a weight that makes the
  /// atom reproduce the map's logit mean and variance at its samples (a Nadaraya-Watson
  /// partition over the atom's own kernels). Transport then moves every kernel exactly as
  /// its sample: wall kernels ride on hits onto the target's walls, free-space kernels on free
  /// samples. Map kernels the sector's samples do not reach carry nothing into the atom.
  double kernels_at_samples = 0;
  /// Atoms with fewer kernels than this are skipped (default 1).
  std::size_t min_kernels = 1;
  std::string source;  ///< provenance stored on every atom
};

/// Builds atoms from source scans and a map learned over the same place (world frame). Scans
/// and map must have the same dimension (ArgumentError otherwise). Appends to `dict` when it is
/// not empty (its dim, scale and max_range must match).
void build_dictionary(const std::vector<Scan>& scans, const KernelMap& map,
                      const DictionaryOptions& options, Dictionary& dict);

/// Appends the atoms of `from` to `into` (dictionaries of many places are built place by place,
/// each with its own map, then merged). An empty `into` takes `from`'s dim, scale, max_range and
/// sectors. Throws ArgumentError when dim, scale or max_range differ (atoms cut with another
/// radius or scale would be compared with targets on another scale); the sectors per source
/// scan may differ (the larger is kept: it is provenance, not part of the atoms' frame).
void merge_dictionary(const Dictionary& from, Dictionary& into);

/// Bytes a dictionary holds in memory: points, kernels and provenance of every atom.
std::size_t dictionary_memory_bytes(const Dictionary& dict);

}  // namespace potmap
POTMAP_CXX_API_END
