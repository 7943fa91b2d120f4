// Probability pictures in memory and the side-by-side comparison figure.
#include "potmap/experiments/figure_panels.hpp"

#include <algorithm>
#include <cmath>

#include "potmap/error.hpp"
#include "potmap/render/colormap.hpp"
#include "render/png_writer.hpp"

namespace potmap::experiment {

Picture probability_picture(const FittedMap& map, int dim, const double lo[3], const double hi[3],
                            std::size_t max_pixels) {
  if (dim != 2 && dim != 3) throw ArgumentError("probability_picture: dim must be 2 or 3");
  if (!map.query) throw ArgumentError("probability_picture: the map has no query");
  const double ex = hi[0] - lo[0], ey = hi[1] - lo[1];
  if (!(ex > 0 && ey > 0) || max_pixels == 0)
    throw ArgumentError("probability_picture: empty window");
  // The pixel grid of write_figures (figures.cpp), so that both pictures of a map agree.
  const double cell = std::max(ex, ey) / double(max_pixels);
  const auto w = std::max<std::size_t>(1, std::size_t(std::ceil(ex / cell)));
  const auto h = std::max<std::size_t>(1, std::size_t(std::ceil(ey / cell)));
  std::vector<double> pts(w * h * std::size_t(dim), 0.0), prob(w * h, NAN);
  for (std::size_t r = 0; r < h; ++r)
    for (std::size_t c = 0; c < w; ++c) {
      double* p = &pts[(r * w + c) * std::size_t(dim)];
      p[0] = lo[0] + (double(c) + 0.5) * cell;
      p[1] = lo[1] + (double(h - 1 - r) + 0.5) * cell;  // row 0 at the top
      if (dim == 3) p[2] = 0.5 * (lo[2] + hi[2]);
    }
  map.query(pts.data(), w * h, prob.data(), nullptr);
  Picture pic;
  pic.width = w;
  pic.height = h;
  pic.rgb.resize(w * h * 3);
  for (std::size_t i = 0; i < w * h; ++i) {
    const Rgb col = colormap(Colormap::Viridis, prob[i]);
    pic.rgb[3 * i] = col.r;
    pic.rgb[3 * i + 1] = col.g;
    pic.rgb[3 * i + 2] = col.b;
  }
  return pic;
}

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

}  // namespace potmap::experiment
