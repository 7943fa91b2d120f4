#pragma once
// Pictures a person reads: 8-bit RGB pixels, boxes, a pixel font for titles and labels, a
// scale bar's round length, and panels written side by side into a PNG. The captions built on
// them: picture_caption.hpp.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "potmap/export.h"
#include "potmap/render/colormap.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

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

}  // namespace potmap
POTMAP_CXX_API_END
