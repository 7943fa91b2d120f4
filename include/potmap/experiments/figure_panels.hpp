#pragma once
// Comparison figures of the experiments: the probability pictures of several maps of one case,
// side by side at one scale, so that a map's shape can be judged against its neighbours'.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>
#include "potmap/export.h"

#include "potmap/experiments/experiment.hpp"
#include "potmap/render/colormap.hpp"
#include "potmap/render/picture.hpp"
#include "potmap/render/picture_caption.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

// Pictures, their text and captions (potmap/render/picture.hpp, picture_caption.hpp).
using potmap::captioned;
using potmap::colour_bar;
using potmap::ColourBar;
using potmap::draw_legend;
using potmap::draw_text;
using potmap::fill_box;
using potmap::kCaptionMinWidth;
using potmap::kLegendRowHeight;
using potmap::kUnknownGrey;
using potmap::Legend;
using potmap::legend_height;
using potmap::never_observed_swatch;
using potmap::Picture;
using potmap::round_scale;
using potmap::Swatch;
using potmap::text_advance;
using potmap::title_height;
using potmap::write_side_by_side;

/// What a probability picture shows.
struct PictureView {
  /// Pixels along the window's longer side (default 400, as write_figures).
  std::size_t max_pixels = 400;
  /// 3D maps: a pixel shows the largest probability over the heights band_lo to band_hi (world
  /// z, metres) sampled every band_step metres (default 0.2), and is known where any of them
  /// is: a top-down view of what stands between the ground and a vehicle's roof. band_lo not
  /// below band_hi (the default, NaN): the one slice halfway between the window's lo[2] and
  /// hi[2].
  double band_lo = NAN, band_hi = NAN, band_step = 0.2;
};

/// The probability picture of a map in memory: the map's query() at the pixel centres over
/// [lo, hi] (x, y; metres), pixels of max(extent) / max_pixels metres, coloured viridis, places
/// the map says it has not observed (FittedMap::known) grey. Maps of one window thus give
/// pictures of one size and scale. Throws ArgumentError for an empty window, max_pixels 0, a
/// band_step not positive or dim not 2 or 3.
Picture probability_picture(const FittedMap& map, int dim, const double lo[3], const double hi[3],
                            const PictureView& view);
/// The same at the default view with `max_pixels` (write_figures' PREFIX_prob.png, in memory).
Picture probability_picture(const FittedMap& map, int dim, const double lo[3], const double hi[3],
                            std::size_t max_pixels = 400);

/// A comparison figure's layout: rows of titles above the panels, of the legend below them (one
/// row of picture_caption.hpp's legend; more where the swatches need a second row), 4 white
/// columns between panels, and the least width (the legend's).
constexpr std::size_t kComparisonTitleRows = 22, kComparisonLegendRows = 56, kComparisonGap = 4,
                      kComparisonMinWidth = 480;

/// A comparison figure: `panels` left to right, each titled above (`titles`, one a panel), and
/// below them a legend (picture_caption.hpp): the colour bar of P(occupied) from 0 to 1, the
/// grey of never-observed space, and a scale bar in metres (from the first panel's
/// metres_per_pixel). picture_caption.hpp's overload adds swatches of its own. Throws ArgumentError
/// when no panel has pixels or titles and panels differ in number, potmap::Error when the file
/// cannot be written.
void write_comparison(const std::vector<const Picture*>& panels,
                      const std::vector<std::string>& titles, const std::string& path);

/// The comparison figure above with `swatches` after its own in the legend (what a
/// panel that is not a probability shows: a true town's buildings, a route).
void write_comparison(const std::vector<const Picture*>& panels,
                      const std::vector<std::string>& titles, const std::string& path,
                      const std::vector<Swatch>& swatches);

}  // namespace potmap::experiment
POTMAP_CXX_API_END
