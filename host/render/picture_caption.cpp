// Titles and legends drawn on pictures (picture_caption.hpp).
#include "potmap/render/picture_caption.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "potmap/error.hpp"

namespace potmap {

namespace {

constexpr Rgb kInk{0, 0, 0};
constexpr int kScale = 2;               // text scale: glyphs 6 x 10 pixels
constexpr std::size_t kMargin = 6;      // left and right margin, pixels
constexpr std::size_t kItemGap = 16;    // between legend items
constexpr std::size_t kBarWidth = 160;  // a colour bar's colours
constexpr std::size_t kTitleLine = 18;  // rows a title line takes

std::size_t text_width(const std::string& s) {
  return s.size() * std::size_t(text_advance(kScale));
}

// A legend item: its width and how it draws itself at (x, y).
struct Item {
  std::size_t width = 0;
  const ColourBar* bar = nullptr;
  const Swatch* swatch = nullptr;
};

std::vector<Item> items_of(const Legend& l) {
  std::vector<Item> items;
  for (const ColourBar& b : l.bars)
    items.push_back({std::max({kBarWidth, text_width(b.label), text_width(b.low + " " + b.high)}),
                     &b, nullptr});
  for (const Swatch& s : l.swatches) items.push_back({16 + text_width(s.label), nullptr, &s});
  return items;
}

// The scale bar: a round length near a fifth of the picture, and its label.
struct Scale {
  std::size_t px = 0;
  std::string label;
};

Scale scale_of(const Legend& l, std::size_t width) {
  if (!(l.metres_per_pixel > 0)) return {};
  const double len = round_scale(double(width) * l.metres_per_pixel);
  char lab[32];
  std::snprintf(lab, sizeof lab, "%g M", len);
  return {std::size_t(std::lround(len / l.metres_per_pixel)), lab};
}

// Each item's row and column: left to right, a new row where the next would pass the width.
// The scale bar ends the last row at the right, or takes a row of its own.
struct Placed {
  std::vector<std::size_t> x, row;
  std::size_t rows = 0, scale_row = 0;
};

Placed place(const std::vector<Item>& items, const Scale& sc, std::size_t width) {
  Placed p;
  std::size_t x = kMargin, row = 0;
  for (const Item& it : items) {
    if (x > kMargin && x + it.width + kMargin > width) {
      ++row;
      x = kMargin;
    }
    p.x.push_back(x);
    p.row.push_back(row);
    x += it.width + kItemGap;
  }
  p.rows = items.empty() ? 0 : row + 1;
  const std::size_t need = std::max(sc.px, text_width(sc.label));
  if (need > 0) {
    if (p.rows == 0 || x + need + kMargin > width) ++p.rows;
    p.scale_row = p.rows - 1;
  }
  return p;
}

void draw_bar(Picture& pic, std::size_t x, std::size_t y, const ColourBar& b) {
  draw_text(pic, long(x), long(y), b.label, kInk, kScale);
  const std::size_t n = b.colours.size();
  for (std::size_t i = 0; i < kBarWidth && n > 0; ++i)
    fill_box(pic, x + i, y + 16, 1, 12, b.colours[std::min(n - 1, i * n / kBarWidth)]);
  draw_text(pic, long(x), long(y + 32), b.low, kInk, kScale);
  const long hx = long(x + kBarWidth) - long(text_width(b.high));
  draw_text(pic, std::max(long(x + text_width(b.low)) + 8, hx), long(y + 32), b.high, kInk, kScale);
}

void draw_swatch(Picture& pic, std::size_t x, std::size_t y, const Swatch& s) {
  if (s.dot_radius <= 0) {
    fill_box(pic, x, y + 16, 12, 12, s.colour);
  } else {
    const long r = s.dot_radius, cx = long(x) + 6, cy = long(y) + 22;
    for (long dy = -r; dy <= r; ++dy)
      for (long dx = -r; dx <= r; ++dx)
        if (dx * dx + dy * dy <= r * r)
          fill_box(pic, std::size_t(cx + dx), std::size_t(cy + dy), 1, 1, s.colour);
  }
  draw_text(pic, long(x + 16), long(y + 17), s.label, kInk, kScale);
}

std::vector<std::string> title_lines(const std::string& title, std::size_t width) {
  const std::size_t fits =
      std::max<std::size_t>(1, (width - 2 * kMargin) / std::size_t(text_advance(kScale)));
  std::vector<std::string> lines;
  std::istringstream words(title);
  std::string w, line;
  while (words >> w) {
    if (!line.empty() && line.size() + 1 + w.size() > fits) {
      lines.push_back(line);
      line.clear();
    }
    line += (line.empty() ? "" : " ") + w;
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

}  // namespace

ColourBar colour_bar(const std::string& label, Colormap map, const std::string& low,
                     const std::string& high) {
  ColourBar b{label, {}, low, high};
  for (std::size_t i = 0; i < kBarWidth; ++i)
    b.colours.push_back(colormap(map, double(i) / double(kBarWidth - 1)));
  return b;
}

Swatch never_observed_swatch() {
  return {kUnknownGrey, "NEVER OBSERVED", 0};
}

std::size_t legend_height(const Legend& legend, std::size_t width) {
  const Placed p = place(items_of(legend), scale_of(legend, width), width);
  return p.rows == 0 ? 0 : 8 + p.rows * kLegendRowHeight;
}

void draw_legend(Picture& pic, std::size_t y, const Legend& legend) {
  const std::vector<Item> items = items_of(legend);
  const Scale sc = scale_of(legend, pic.width);
  const Placed p = place(items, sc, pic.width);
  y += 8;
  for (std::size_t k = 0; k < items.size(); ++k) {
    const std::size_t at = y + p.row[k] * kLegendRowHeight;
    if (items[k].bar) draw_bar(pic, p.x[k], at, *items[k].bar);
    if (items[k].swatch) draw_swatch(pic, p.x[k], at, *items[k].swatch);
  }
  if (sc.px == 0) return;
  const std::size_t at = y + p.scale_row * kLegendRowHeight;
  const std::size_t sx = pic.width > sc.px + 10 ? pic.width - sc.px - 10 : 0;
  draw_text(pic, long(sx), long(at), "SCALE", kInk, kScale);
  fill_box(pic, sx, at + 20, sc.px, 4, kInk);
  draw_text(pic, long(sx), long(at + 32), sc.label, kInk, kScale);
}

std::size_t title_height(const std::string& title, std::size_t width) {
  const std::size_t n = title_lines(title, width).size();
  return n == 0 ? 0 : 6 + n * kTitleLine;
}

Picture captioned(const Picture& body, const std::string& title, const Legend& legend) {
  if (body.rgb.size() != body.width * body.height * 3)
    throw ArgumentError("captioned: the picture's pixels do not match its size");
  Picture pic;
  pic.width = std::max(body.width, kCaptionMinWidth);
  pic.metres_per_pixel = body.metres_per_pixel;
  const std::size_t top = title_height(title, pic.width);
  pic.height = top + body.height + legend_height(legend, pic.width);
  pic.rgb.assign(pic.width * pic.height * 3, 255);
  const std::vector<std::string> lines = title_lines(title, pic.width);
  for (std::size_t k = 0; k < lines.size(); ++k)
    draw_text(pic, long(kMargin), long(6 + k * kTitleLine), lines[k], kInk, kScale);
  for (std::size_t r = 0; r < body.height; ++r)
    std::copy_n(&body.rgb[r * body.width * 3], body.width * 3, &pic.rgb[(top + r) * pic.width * 3]);
  draw_legend(pic, top + body.height, legend);
  return pic;
}

}  // namespace potmap
