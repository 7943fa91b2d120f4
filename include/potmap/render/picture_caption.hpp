#pragma once
// What a picture shows, drawn on it: a title above (the quantity, and where: the heights of a
// band), a legend below (colour bars with their quantity and ends, swatches such as the grey of
// never-observed space or a kernel's dot, and a scale bar in metres). Every picture potmap
// writes for a person takes its caption from here, so that all of them read alike.

#include <cstddef>
#include <string>
#include <vector>

#include "potmap/export.h"
#include "potmap/render/colormap.hpp"
#include "potmap/render/picture.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// A colour bar: `label` (the quantity) above, `colours` left to right (low to high), `low` and
/// `high` written under its ends.
struct ColourBar {
  std::string label;
  std::vector<Rgb> colours;
  std::string low, high;
};

/// The bar of a colour map from its value 0 (left) to 1 (right).
ColourBar colour_bar(const std::string& label, Colormap map, const std::string& low,
                     const std::string& high);

/// A sample of one colour and its meaning: a 12-pixel square, or with dot_radius > 0 a dot of
/// that radius (as a picture draws its points) on white.
struct Swatch {
  Rgb colour;
  std::string label;
  int dot_radius = 0;
};

/// The swatch of kUnknownGrey, "NEVER OBSERVED".
Swatch never_observed_swatch();

/// A legend: the bars, then the swatches, left to right in rows of kLegendRowHeight pixels,
/// then a scale bar in metres at the right end (none when metres_per_pixel is 0).
struct Legend {
  std::vector<ColourBar> bars;
  std::vector<Swatch> swatches;
  double metres_per_pixel = 0;
};

/// Rows a legend row takes; a legend takes 8 more (its top margin).
constexpr std::size_t kLegendRowHeight = 48;
/// Width a captioned picture takes at least, pixels (room for a bar, a swatch and a scale).
constexpr std::size_t kCaptionMinWidth = 480;

/// Rows `legend` takes in a picture `width` pixels wide.
std::size_t legend_height(const Legend& legend, std::size_t width);

/// Draws `legend` into `pic` from row `y` down (legend_height(legend, pic.width) rows).
void draw_legend(Picture& pic, std::size_t y, const Legend& legend);

/// Rows the title takes in a picture `width` pixels wide: its words wrapped over as many lines
/// as they need (18 rows each, 6 above the first). A no-break space ('\xA0', drawn blank) joins
/// words that must stay on one line, such as a height range.
std::size_t title_height(const std::string& title, std::size_t width);

/// `body` (its metres_per_pixel kept) under `title`, above `legend`, on white, at least
/// kCaptionMinWidth wide (the body at the left). Throws ArgumentError when the body's pixels do
/// not match its size.
Picture captioned(const Picture& body, const std::string& title, const Legend& legend);

}  // namespace potmap
POTMAP_CXX_API_END
