#pragma once
// Labels on the plots of `potmap bench`: a 3 x 5 pixel font (digits, letters drawn as capitals,
// a few signs) scaled up, so that a plot names its axes without a font library.

#include <string>

#include "potmap/experiments/figure_panels.hpp"
#include "potmap/render/colormap.hpp"

namespace potmap::cli {

/// Pixels a character advances at `scale` (glyph 3 x scale wide plus one scale of space).
inline long text_advance(int scale) {
  return 4L * scale;
}

/// Draws `text` with its top-left corner at (x, y), glyphs 3 x 5 pixels times `scale`; pixels
/// outside the picture are skipped, characters without a glyph left blank.
void draw_text(experiment::Picture& pic, long x, long y, const std::string& text, Rgb colour,
               int scale = 2);

}  // namespace potmap::cli
