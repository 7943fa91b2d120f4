// Probability pictures in memory and the side-by-side comparison figure.
#include "potmap/experiments/figure_panels.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "potmap/error.hpp"
#include "potmap/render/colormap.hpp"
#include "render/png_writer.hpp"

namespace potmap::experiment {

namespace {

// The pixel grid of write_figures (figures.cpp), so that both pictures of a map agree.
struct PixelGrid {
  double cell = 0;
  std::size_t w = 0, h = 0;
};

PixelGrid pixel_grid(const double lo[3], const double hi[3], std::size_t max_pixels) {
  const double ex = hi[0] - lo[0], ey = hi[1] - lo[1];
  if (!(ex > 0 && ey > 0) || max_pixels == 0)
    throw ArgumentError("probability_picture: empty window");
  PixelGrid g;
  g.cell = std::max(ex, ey) / double(max_pixels);
  g.w = std::max<std::size_t>(1, std::size_t(std::ceil(ex / g.cell)));
  g.h = std::max<std::size_t>(1, std::size_t(std::ceil(ey / g.cell)));
  return g;
}

// The heights a 3D picture samples: the band every step, or the window's middle.
std::vector<double> picture_heights(int dim, const double lo[3], const double hi[3],
                                    const PictureView& view) {
  if (dim == 2) return {0.0};
  if (!(view.band_step > 0)) throw ArgumentError("probability_picture: band_step must be > 0");
  if (!(view.band_lo < view.band_hi)) return {0.5 * (lo[2] + hi[2])};
  std::vector<double> z;
  for (double v = view.band_lo; v <= view.band_hi + 1e-9; v += view.band_step) z.push_back(v);
  return z;
}

}  // namespace

Picture probability_picture(const FittedMap& map, int dim, const double lo[3], const double hi[3],
                            const PictureView& view) {
  if (dim != 2 && dim != 3) throw ArgumentError("probability_picture: dim must be 2 or 3");
  if (!map.query) throw ArgumentError("probability_picture: the map has no query");
  const PixelGrid g = pixel_grid(lo, hi, view.max_pixels);
  const std::vector<double> heights = picture_heights(dim, lo, hi, view);
  const std::size_t n = g.w * g.h;
  std::vector<double> best(n, -1.0);  // -1: no height known
  std::vector<double> pts(n * std::size_t(dim), 0.0), prob(n);
  std::vector<std::uint8_t> known(n, 1);
  for (const double z : heights) {
    for (std::size_t r = 0; r < g.h; ++r)
      for (std::size_t c = 0; c < g.w; ++c) {
        double* p = &pts[(r * g.w + c) * std::size_t(dim)];
        p[0] = lo[0] + (double(c) + 0.5) * g.cell;
        p[1] = lo[1] + (double(g.h - 1 - r) + 0.5) * g.cell;  // row 0 at the top
        if (dim == 3) p[2] = z;
      }
    std::fill(prob.begin(), prob.end(), NAN);
    map.query(pts.data(), n, prob.data(), nullptr);
    if (map.known) map.known(pts.data(), n, known.data());
    for (std::size_t i = 0; i < n; ++i)
      if (known[i] && !(prob[i] <= best[i])) best[i] = prob[i];  // NaN stays NaN: drawn as such
  }
  Picture pic;
  pic.width = g.w;
  pic.height = g.h;
  pic.metres_per_pixel = g.cell;
  pic.rgb.resize(n * 3);
  for (std::size_t i = 0; i < n; ++i) {
    const Rgb col = best[i] == -1.0 ? kUnknownGrey : colormap(Colormap::Viridis, best[i]);
    pic.rgb[3 * i] = col.r;
    pic.rgb[3 * i + 1] = col.g;
    pic.rgb[3 * i + 2] = col.b;
  }
  return pic;
}

Picture probability_picture(const FittedMap& map, int dim, const double lo[3], const double hi[3],
                            std::size_t max_pixels) {
  PictureView v;
  v.max_pixels = max_pixels;
  return probability_picture(map, dim, lo, hi, v);
}

void write_comparison(const std::vector<const Picture*>& panels,
                      const std::vector<std::string>& titles, const std::string& path) {
  write_comparison(panels, titles, path, {});
}

void write_comparison(const std::vector<const Picture*>& panels,
                      const std::vector<std::string>& titles, const std::string& path,
                      const std::vector<Swatch>& swatches) {
  if (panels.size() != titles.size())
    throw ArgumentError("write_comparison: " + std::to_string(panels.size()) + " panels, " +
                        std::to_string(titles.size()) + " titles");
  const std::size_t gap = kComparisonGap, title_h = kComparisonTitleRows;
  std::size_t w = 0, h = 0;
  double mpp = 0;
  for (const Picture* p : panels) {
    if (!p || p->width == 0 || p->height == 0) continue;
    if (p->rgb.size() != p->width * p->height * 3)
      throw ArgumentError("write_comparison: a panel's pixels do not match its size");
    w += (w > 0 ? gap : 0) + p->width;
    h = std::max(h, p->height);
    if (mpp == 0) mpp = p->metres_per_pixel;
  }
  if (w == 0) throw ArgumentError("write_comparison: no panel to write");
  Legend legend;
  legend.bars = {colour_bar("P(OCCUPIED)", Colormap::Viridis, "0", "1")};
  legend.swatches = {never_observed_swatch()};
  legend.swatches.insert(legend.swatches.end(), swatches.begin(), swatches.end());
  legend.metres_per_pixel = mpp;
  Picture fig;
  fig.width = std::max<std::size_t>(w, kComparisonMinWidth);
  fig.height = title_h + h + legend_height(legend, fig.width);
  fig.rgb.assign(fig.width * fig.height * 3, 255);
  std::size_t x = 0;
  for (std::size_t k = 0; k < panels.size(); ++k) {
    const Picture* p = panels[k];
    if (!p || p->width == 0 || p->height == 0) continue;
    std::string t = titles[k];
    const auto fits = std::size_t(std::max<long>(1, long(p->width) / text_advance(2)));
    if (t.size() > fits) t.resize(fits);
    draw_text(fig, long(x + 2), 4, t, Rgb{0, 0, 0}, 2);
    for (std::size_t r = 0; r < p->height; ++r)
      std::copy_n(&p->rgb[r * p->width * 3], p->width * 3,
                  &fig.rgb[((title_h + r) * fig.width + x) * 3]);
    x += p->width + gap;
  }
  draw_legend(fig, title_h + h, legend);
  write_side_by_side({&fig}, path, 0);
}

}  // namespace potmap::experiment
