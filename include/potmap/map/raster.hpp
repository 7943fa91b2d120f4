#pragma once
// Rasterising a kernel map: probability and variance on a regular window, written as pictures
// (8-bit indexed-colour PNG) and as data (NumPy .npy float32), streamed in bands of rows so
// that a window larger than memory works.
//
// Orientation: image row 0 is the top of the picture = the highest y; column 0 = the lowest x.
// The .npy arrays use the same order (row 0 = highest y), so they display the right way up with
// matplotlib's imshow (origin='upper'); flip with np.flipud for a y-up array.
//
// Cell (row r, column c) has its centre at
//   x = xmin + (c + 0.5) * resolution,   y = ymin + (height - 1 - r + 0.5) * resolution
// with width = ceil((xmax - xmin) / resolution), height = ceil((ymax - ymin) / resolution), so
// the window may reach up to one cell past xmax / ymax.
//
// Colours:
//   * probability p in [0, 1] -> the colour map directly (viridis by default);
//   * variance s2 >= 0 -> s2 / (1 + s2), then the colour map (magma by default). This fixed
//     rule needs no first pass over the data (streaming) and is the same for every map and
//     window, so pictures are comparable. s2 = 1 sits mid-scale: that is where the variance
//     starts to pull p towards 0.5 (p = sigmoid(mu / sqrt(1 + pi s2 / 8))); s2 = 9 gives 0.9.
//   * NaN (non-finite input) is drawn mid-grey (128, 128, 128).
//   * The pictures are indexed colour (a palette of 256 entries, a third of the bytes of RGB):
//     the mapped value t in [0, 1] is quantised to k = round(254 t), drawn as colormap(k / 254);
//     entry 255 is the NaN grey. The colours are those of the continuous map to within one
//     step of 1/254 (at most 2 units of 255 a channel for viridis and magma).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "potmap/export.h"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/render/colormap.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// The window to rasterise, in map coordinates (metres).
struct RasterSpec {
  double xmin = 0, xmax = 0;  ///< metres, xmin < xmax
  double ymin = 0, ymax = 0;  ///< metres, ymin < ymax
  double resolution = 0.1;    ///< cell edge, metres, > 0; default 0.1
  double z = 0.0;             ///< height of the slice for 3D maps, metres; ignored in 2D
  /// Height band of a 3D map, metres in the map frame. When both are finite, every cell holds
  /// the largest probability over the heights band_lo..band_hi and the variance at that height
  /// (map/height_band.hpp), and z is unused: a planner's view of what stands between the ground
  /// and a vehicle's roof. Default NaN: no band, the slice at z.
  double band_lo = NAN, band_hi = NAN;
  /// Largest spacing of the band's levels, metres (both ends are levels: height_band_levels);
  /// 0 (default): default_band_step(map), the standard deviation of the map's narrowest kernel,
  /// finer than which the map does not change along z (why: height_band.hpp).
  double band_step = 0;
  bool has_band() const { return !std::isnan(band_lo) || !std::isnan(band_hi); }
  std::size_t width() const;   ///< ceil((xmax - xmin) / resolution)
  std::size_t height() const;  ///< ceil((ymax - ymin) / resolution)
  /// Throws ArgumentError naming the bad value (non-finite, empty window, resolution <= 0,
  /// more than 10^6 cells along an axis: the PNG limit; a band with one end NaN, band_lo above
  /// band_hi, band_step negative or not finite).
  void validate() const;
};

/// How to rasterise.
struct RasterOptions {
  /// Most cells evaluated at once. Host memory is about 8 bytes per cell of a band (variance
  /// and probability in float) plus the device's buffers (12 bytes a cell); default 4 Mi cells
  /// (~80 MB in all). A band is a whole number of 64-row blocks, at least one.
  std::size_t max_band_cells = std::size_t(1) << 22;
  bool write_png = true;  ///< write PREFIX_prob.png and PREFIX_var.png; default true
  bool write_npy = true;  ///< write PREFIX_prob.npy and PREFIX_var.npy; default true
  Colormap prob_colormap = Colormap::Viridis;  ///< default viridis
  Colormap var_colormap = Colormap::Magma;     ///< default magma
  EvalOptions eval;  ///< options of the device evaluator (cut-off); defaults as EvalOptions
  /// Called after each band with the fraction of cells done, in (0, 1]. May be empty. An
  /// exception thrown from it aborts the run (no file is left behind).
  std::function<void(double fraction)> progress;
};

/// What a run did.
struct RasterSummary {
  std::size_t width = 0, height = 0;  ///< pixels
  std::size_t cells = 0;              ///< width * height
  std::size_t bands = 0;              ///< number of bands evaluated
  std::size_t levels = 0;             ///< heights of the height band sampled; 0 for a slice
  double level_spacing = 0;           ///< metres between those heights; 0 for fewer than 2
  double seconds = 0;                 ///< wall time of the whole run, seconds
  float prob_min = 0, prob_max = 0;   ///< over finite cells (0 if none)
  float var_min = 0, var_max = 0;     ///< over finite cells (0 if none)
  std::vector<std::string> files;     ///< files written, in order prob.png, var.png, prob.npy,
                                      ///< var.npy (those enabled)
};

/// The heights a raster of `spec` samples on `map`, metres: empty for a slice (no band), else
/// height_band_levels(band_lo, band_hi, band_step or default_band_step(map)). Throws
/// ArgumentError for a band on a 2D map or a band that height_band_levels refuses.
std::vector<double> raster_levels(const RasterSpec& spec, const KernelMap& map);

/// Evaluates `map` on the window and writes PREFIX_prob.png, PREFIX_var.png, PREFIX_prob.npy and
/// PREFIX_var.npy (as enabled). Every file is written to a temporary name and renamed only when
/// all of them are complete; on any error no new file is left behind. The result does not
/// depend on max_band_cells (bands are whole multiples of 64 rows, counted from the window's
/// bottom, and the evaluator's tiles, RasterTuning::tile, divide 64, so every cell is computed by
/// the same tile either way).
/// Throws ArgumentError for a bad spec, potmap::Error naming the file on a write failure.
RasterSummary rasterize(Context& ctx, const KernelMap& map, const RasterSpec& spec,
                        const std::string& out_prefix, const RasterOptions& options = {});

}  // namespace potmap
POTMAP_CXX_API_END
