#include "potmap/render/picture.hpp"

#include <algorithm>
#include <cmath>

#include "potmap/error.hpp"
#include "render/png_writer.hpp"

namespace potmap {

void write_side_by_side(const std::vector<const Picture*>& panels, const std::string& path,
                        std::size_t gap) {
  std::vector<const Picture*> use;
  for (const Picture* p : panels)
    if (p && p->width > 0 && p->height > 0) {
      if (p->rgb.size() != p->width * p->height * 3)
        throw ArgumentError("write_side_by_side: a panel's pixels do not match its size");
      use.push_back(p);
    }
  if (use.empty()) throw ArgumentError("write_side_by_side: no panel to write");
  std::size_t w = 0, h = 0;
  for (const Picture* p : use) {
    w += p->width;
    h = std::max(h, p->height);
  }
  w += gap * (use.size() - 1);
  std::vector<std::uint8_t> row(w * 3);
  detail::PngWriter png(path, w, h);
  for (std::size_t r = 0; r < h; ++r) {
    std::fill(row.begin(), row.end(), std::uint8_t(255));
    std::size_t x = 0;
    for (const Picture* p : use) {
      if (r < p->height) std::copy_n(&p->rgb[r * p->width * 3], p->width * 3, &row[x * 3]);
      x += p->width + gap;
    }
    png.write_row(row.data());
  }
  png.finish();
}

void fill_box(Picture& pic, std::size_t x0, std::size_t y0, std::size_t w, std::size_t h, Rgb c) {
  for (std::size_t y = y0; y < std::min(pic.height, y0 + h); ++y)
    for (std::size_t x = x0; x < std::min(pic.width, x0 + w); ++x) {
      std::uint8_t* p = &pic.rgb[(y * pic.width + x) * 3];
      p[0] = c.r;
      p[1] = c.g;
      p[2] = c.b;
    }
}

double round_scale(double metres) {
  const double target = metres / 5, p = std::pow(10.0, std::floor(std::log10(target)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= target) return m * p;
  return p;
}

}  // namespace potmap
