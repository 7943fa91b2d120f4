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

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

/// An 8-bit RGB picture, rows top first.
struct Picture {
  std::size_t width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  ///< width * height * 3 bytes
  /// Metres a pixel spans (0: not a map, no scale bar in a comparison figure).
  double metres_per_pixel = 0;
};

/// The grey of places a map has never observed (FittedMap::known), apart from free space's
/// dark blue and occupied space's yellow.
constexpr Rgb kUnknownGrey{150, 150, 150};

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

/// Paints the w x h box of `pic` at (x0, y0) (clipped to the picture) in colour c.
void fill_box(Picture& pic, std::size_t x0, std::size_t y0, std::size_t w, std::size_t h, Rgb c);

/// A round length for a scale bar: 1, 2 or 5 times a power of ten, near a fifth of `metres`.
double round_scale(double metres);

/// Pixels a character of draw_text advances at `scale` (glyph 3 x scale wide plus one scale of
/// space).
inline long text_advance(int scale) {
  return 4L * scale;
}

/// Draws `text` with its top-left corner at (x, y), glyphs 3 x 5 pixels times `scale` (letters
/// as capitals); pixels outside the picture are skipped, characters without a glyph left blank.
void draw_text(Picture& pic, long x, long y, const std::string& text, Rgb colour, int scale = 2);

/// Writes `panels` left to right into the PNG `path`, `gap` white columns between neighbours
/// (default 4: enough to see the edge of a panel whose border is dark), tops aligned, a panel
/// shorter than the tallest padded with white below. Null panels are skipped. Throws
/// ArgumentError when no panel has pixels, potmap::Error when the file cannot be written.
void write_side_by_side(const std::vector<const Picture*>& panels, const std::string& path,
                        std::size_t gap = 4);

}  // namespace potmap::experiment
POTMAP_CXX_API_END
