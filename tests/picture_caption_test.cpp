// Captions on pictures: a title above that wraps over lines, a legend below with its colour
// bars, swatches and scale bar, the picture itself untouched between them.
#include "potmap/experiments/figure_panels.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "potmap/error.hpp"

using namespace potmap;
using namespace potmap::experiment;

namespace {

Picture plain(std::size_t w, std::size_t h, Rgb c) {
  Picture p;
  p.width = w;
  p.height = h;
  p.metres_per_pixel = 0.1;
  p.rgb.resize(w * h * 3);
  for (std::size_t i = 0; i < w * h; ++i) {
    p.rgb[3 * i] = c.r;
    p.rgb[3 * i + 1] = c.g;
    p.rgb[3 * i + 2] = c.b;
  }
  return p;
}

Rgb pixel_at(const Picture& p, std::size_t x, std::size_t y) {
  const std::uint8_t* q = &p.rgb[(y * p.width + x) * 3];
  return {q[0], q[1], q[2]};
}

bool same(Rgb a, Rgb b) {
  return a.r == b.r && a.g == b.g && a.b == b.b;
}

// Whether rows [y0, y1) hold colour c somewhere.
bool rows_hold(const Picture& p, std::size_t y0, std::size_t y1, Rgb c) {
  for (std::size_t y = y0; y < std::min(y1, p.height); ++y)
    for (std::size_t x = 0; x < p.width; ++x)
      if (same(pixel_at(p, x, y), c)) return true;
  return false;
}

// Whether `text`, drawn by draw_text at scale 2 in ink, appears in `p` exactly: every pixel of
// its box ink where a glyph is and not ink elsewhere (so "P(OCCUPIED)" is not found inside a
// longer word drawn over it, nor in a smudge of ink).
bool holds_text(const Picture& p, const std::string& text) {
  const Rgb ink{0, 0, 0};
  Picture stamp;
  stamp.width = text.size() * std::size_t(text_advance(2));
  stamp.height = 10;
  stamp.rgb.assign(stamp.width * stamp.height * 3, 255);
  draw_text(stamp, 0, 0, text, ink, 2);
  if (stamp.width > p.width || stamp.height > p.height) return false;
  for (std::size_t y = 0; y + stamp.height <= p.height; ++y)
    for (std::size_t x = 0; x + stamp.width <= p.width; ++x) {
      bool match = true;
      for (std::size_t sy = 0; sy < stamp.height && match; ++sy)
        for (std::size_t sx = 0; sx < stamp.width && match; ++sx)
          match = same(pixel_at(stamp, sx, sy), ink) == same(pixel_at(p, x + sx, y + sy), ink);
      if (match) return true;
    }
  return false;
}

// The longest run of ink along one row of [y0, y1): a scale bar's length in pixels.
std::size_t longest_ink_run(const Picture& p, std::size_t y0, std::size_t y1) {
  std::size_t best = 0;
  for (std::size_t y = y0; y < std::min(y1, p.height); ++y) {
    std::size_t run = 0;
    for (std::size_t x = 0; x < p.width; ++x) {
      run = same(pixel_at(p, x, y), Rgb{0, 0, 0}) ? run + 1 : 0;
      best = std::max(best, run);
    }
  }
  return best;
}

Legend probability_legend(double mpp) {
  Legend l;
  l.bars = {colour_bar("P(OCCUPIED)", Colormap::Viridis, "0", "1")};
  l.swatches = {never_observed_swatch()};
  l.metres_per_pixel = mpp;
  return l;
}

}  // namespace

TEST(PictureCaption, TitleAboveLegendBelowPictureUntouched) {
  const Rgb body_colour{10, 200, 30};
  const Picture body = plain(600, 300, body_colour);
  const Legend legend = probability_legend(0.1);
  const Picture pic = captioned(body, "P(OCCUPIED) OF A TEST", legend);
  const std::size_t top = title_height("P(OCCUPIED) OF A TEST", 600);
  const std::size_t below = legend_height(legend, 600);
  EXPECT_GT(top, 0u);
  EXPECT_GT(below, 0u);
  EXPECT_EQ(pic.width, 600u);
  EXPECT_EQ(pic.height, top + 300 + below);
  EXPECT_EQ(pic.metres_per_pixel, 0.1);
  // The title is ink on white above; the body is where it was put, every pixel of it.
  EXPECT_TRUE(rows_hold(pic, 0, top, Rgb{0, 0, 0}));
  EXPECT_FALSE(rows_hold(pic, 0, top, body_colour));
  for (std::size_t y = 0; y < 300; y += 37)
    for (std::size_t x = 0; x < 600; x += 41)
      EXPECT_TRUE(same(pixel_at(pic, x, top + y), body_colour));
  // The legend: the colour bar's ends, the grey of never-observed space, ink of its words.
  const std::size_t y0 = top + 300;
  EXPECT_TRUE(rows_hold(pic, y0, pic.height, colormap(Colormap::Viridis, 0)));
  EXPECT_TRUE(rows_hold(pic, y0, pic.height, colormap(Colormap::Viridis, 1)));
  EXPECT_TRUE(rows_hold(pic, y0, pic.height, kUnknownGrey));
  EXPECT_TRUE(rows_hold(pic, y0, pic.height, Rgb{0, 0, 0}));
  // The words themselves: the title, the bar's quantity and ends, the grey's name, the scale.
  EXPECT_TRUE(holds_text(pic, "P(OCCUPIED) OF A TEST"));
  EXPECT_TRUE(holds_text(pic, "NEVER OBSERVED"));
  EXPECT_TRUE(holds_text(pic, "SCALE"));
  EXPECT_TRUE(holds_text(pic, "0"));
  EXPECT_TRUE(holds_text(pic, "1"));
  // 600 pixels of 0.1 m: 60 m across, a fifth of it rounded to 10 m, drawn 100 pixels long.
  EXPECT_TRUE(holds_text(pic, "10 M"));
  EXPECT_EQ(longest_ink_run(pic, y0, pic.height), 100u);
  // Nothing of the legend is in the body's rows, and the search tells words apart.
  EXPECT_FALSE(holds_text(pic, "UNKNOWN"));
  EXPECT_FALSE(holds_text(captioned(body, "", Legend{}), "NEVER OBSERVED"));
}

TEST(PictureCaption, LongTitlesWrapAndNarrowPicturesWiden) {
  // The heights joined by no-break spaces (\xA0), as drive_band_picture.cpp writes them.
  const std::string title =
      "LOGIT VARIANCE WHERE THE BAND'S P(OCCUPIED) IS HIGHEST, "
      "Z\xA0-1.00\xA0TO\xA0+0.50\xA0M ABOUT THE SENSOR'S PATH";
  // Wider than 480 pixels at 8 a character: more than one line.
  EXPECT_GT(title_height(title, kCaptionMinWidth), title_height("P(OCCUPIED)", kCaptionMinWidth));
  const Picture pic = captioned(plain(100, 50, Rgb{1, 2, 3}), title, probability_legend(0.5));
  EXPECT_EQ(pic.width, kCaptionMinWidth);
  EXPECT_EQ(pic.height, title_height(title, kCaptionMinWidth) + 50 +
                            legend_height(probability_legend(0.5), kCaptionMinWidth));
  // 58 characters a line at 480 pixels: wrapped at a space, the heights kept whole on the next
  // line, nothing of the title lost.
  EXPECT_TRUE(holds_text(pic, "LOGIT VARIANCE WHERE THE BAND'S P(OCCUPIED) IS HIGHEST,"));
  EXPECT_TRUE(holds_text(pic, "Z -1.00 TO +0.50 M ABOUT THE SENSOR'S PATH"));
  // No title and no legend: the picture as it was, widened.
  const Picture bare = captioned(plain(100, 50, Rgb{1, 2, 3}), "", Legend{});
  EXPECT_EQ(bare.height, 50u);
  Picture broken = plain(10, 10, Rgb{0, 0, 0});
  broken.rgb.pop_back();
  EXPECT_THROW(captioned(broken, "X", Legend{}), ArgumentError);
}

TEST(PictureCaption, LegendTakesMoreRowsWhenItsItemsDoNotFit) {
  Legend many = probability_legend(0.1);
  for (int i = 0; i < 6; ++i)
    many.bars.push_back(colour_bar("KERNEL LENGTH SCALE, M", Colormap::Magma, "0.1", "2"));
  EXPECT_EQ(legend_height(probability_legend(0.1), 600), 8 + kLegendRowHeight);
  EXPECT_GT(legend_height(many, 600), 8 + 2 * kLegendRowHeight);
  // A dot swatch draws its dot: the colour appears in the legend.
  Legend dot;
  dot.swatches = {{Rgb{200, 10, 10}, "ONE KERNEL", 2}};
  const Picture pic = captioned(plain(480, 20, Rgb{255, 255, 255}), "", dot);
  EXPECT_TRUE(rows_hold(pic, 20, pic.height, Rgb{200, 10, 10}));
  EXPECT_TRUE(holds_text(pic, "ONE KERNEL"));
  // Every bar of the long legend is drawn, on rows of its own below the first.
  const Picture tall = captioned(plain(600, 20, Rgb{255, 255, 255}), "", many);
  EXPECT_TRUE(holds_text(tall, "KERNEL LENGTH SCALE, M"));
  EXPECT_TRUE(
      rows_hold(tall, 20 + 8 + 2 * kLegendRowHeight, tall.height, colormap(Colormap::Magma, 1)));
}
