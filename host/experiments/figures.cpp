// Pictures of any fitted map, through its query function, so that grids and kernel maps are
// drawn the same way; each captioned (picture_caption.hpp) so that it says what it shows.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/experiments/figure_panels.hpp"
#include "potmap/render/colormap.hpp"

namespace potmap::experiment {

namespace {

// The window's pixels: w x h of `cell` metres, row 0 at the top (raster.hpp's orientation).
struct Grid {
  std::size_t w = 0, h = 0;
  double cell = 0;
};

Picture blank(const Grid& g) {
  Picture p;
  p.width = g.w;
  p.height = g.h;
  p.metres_per_pixel = g.cell;
  p.rgb.assign(g.w * g.h * 3, 255);
  return p;
}

void put(Picture& p, std::size_t i, Rgb c) {
  p.rgb[3 * i] = c.r;
  p.rgb[3 * i + 1] = c.g;
  p.rgb[3 * i + 2] = c.b;
}

Legend legend_of(const ColourBar& bar, double metres_per_pixel, bool unknown) {
  Legend l;
  l.bars = {bar};
  if (unknown) l.swatches = {never_observed_swatch()};
  l.metres_per_pixel = metres_per_pixel;
  return l;
}

// Each kernel a dot of radius 1 (the legend's swatch draws the same) coloured by log10 gamma,
// smallest to largest width.
Picture kernel_dots(const KernelMap& k, const Grid& g, const double lo[3], double& gmin,
                    double& gmax) {
  gmin = HUGE_VAL, gmax = -HUGE_VAL;
  for (double gamma : k.gamma) {
    gmin = std::min(gmin, std::log10(gamma));
    gmax = std::max(gmax, std::log10(gamma));
  }
  Picture pic = blank(g);
  for (std::size_t m = 0; m < k.size(); ++m) {
    const double x = k.position[m * k.dim], y = k.position[m * k.dim + 1];
    const long c = std::lround((x - lo[0]) / g.cell - 0.5);
    const long r = long(g.h) - 1 - std::lround((y - lo[1]) / g.cell - 0.5);
    const double t = gmax > gmin ? (std::log10(k.gamma[m]) - gmin) / (gmax - gmin) : 0.5;
    const Rgb col = colormap(Colormap::Viridis, t);
    for (long dr = -1; dr <= 1; ++dr)
      for (long dc = -1; dc <= 1; ++dc) {
        const long rr = r + dr, cc = c + dc;
        if (dr * dr + dc * dc > 1) continue;
        if (rr < 0 || cc < 0 || rr >= long(g.h) || cc >= long(g.w)) continue;
        put(pic, std::size_t(rr) * g.w + std::size_t(cc), col);
      }
  }
  return pic;
}

void write_captioned(const Picture& body, const std::string& title, const Legend& legend,
                     const std::string& path, std::vector<std::string>& files) {
  const Picture pic = captioned(body, title, legend);
  write_side_by_side({&pic}, path, 0);
  files.push_back(path);
}

}  // namespace

std::vector<std::string> write_figures(const FittedMap& map, int dim, const double lo[3],
                                       const double hi[3], const std::string& prefix,
                                       std::size_t max_pixels, const std::string& name) {
  const double ex = hi[0] - lo[0], ey = hi[1] - lo[1];
  if (!(ex > 0 && ey > 0) || max_pixels == 0) throw ArgumentError("write_figures: empty window");
  if (dim != 2 && dim != 3) throw ArgumentError("write_figures: dim must be 2 or 3");
  Grid g;
  g.cell = std::max(ex, ey) / double(max_pixels);
  g.w = std::max<std::size_t>(1, std::size_t(std::ceil(ex / g.cell)));
  g.h = std::max<std::size_t>(1, std::size_t(std::ceil(ey / g.cell)));
  const std::size_t n = g.w * g.h;
  const double z = 0.5 * (lo[2] + hi[2]);
  std::vector<double> pts(n * dim, 0.0), prob(n), var(n);
  for (std::size_t r = 0; r < g.h; ++r)
    for (std::size_t c = 0; c < g.w; ++c) {
      double* p = &pts[(r * g.w + c) * dim];
      p[0] = lo[0] + (c + 0.5) * g.cell;
      p[1] = lo[1] + (g.h - 1 - r + 0.5) * g.cell;
      if (dim == 3) p[2] = z;
    }
  map.query(pts.data(), n, prob.data(), var.data());
  std::vector<std::uint8_t> known(n, 1);
  if (map.known) map.known(pts.data(), n, known.data());
  const bool any_unknown = std::find(known.begin(), known.end(), 0) != known.end();
  // The titles: the method (when named), the quantity and, for a 3D map, the slice's height.
  std::string head = name.empty() ? "" : name + ": ", at;
  if (dim == 3) {
    char s[48];
    std::snprintf(s, sizeof s, " AT Z %.2f M", z);
    at = s;
  }
  std::vector<std::string> files;
  Picture p = blank(g);
  for (std::size_t i = 0; i < n; ++i)
    put(p, i, known[i] ? colormap(Colormap::Viridis, prob[i]) : kUnknownGrey);
  write_captioned(
      p, head + "P(OCCUPIED)" + at,
      legend_of(colour_bar("P(OCCUPIED): 0 FREE, 1 OCCUPIED", Colormap::Viridis, "0", "1"), g.cell,
                any_unknown),
      prefix + "_prob.png", files);
  if (std::any_of(var.begin(), var.end(), [](double v) { return std::isfinite(v); })) {
    // v / (1 + v): every variance on one bar, half-way at 1.
    for (std::size_t i = 0; i < n; ++i)
      put(p, i,
          known[i] ? colormap(Colormap::Magma, std::isfinite(var[i]) ? var[i] / (1 + var[i]) : NAN)
                   : kUnknownGrey);
    write_captioned(
        p, head + "LOGIT VARIANCE" + at,
        legend_of(colour_bar("LOGIT VARIANCE (ITS MIDDLE AT 1)", Colormap::Magma, "0", "INFINITE"),
                  g.cell, any_unknown),
        prefix + "_var.png", files);
  }
  if (map.kernels && !map.kernels->empty()) {
    double gmin = 0, gmax = 0;
    const Picture dots = kernel_dots(*map.kernels, g, lo, gmin, gmax);
    char lo_s[32], hi_s[32], title[96];
    std::snprintf(lo_s, sizeof lo_s, "%.2f", gmin);
    std::snprintf(hi_s, sizeof hi_s, "%.2f", gmax);
    std::snprintf(title, sizeof title, "KERNELS: %zu, EACH A DOT COLOURED BY LOG10 GAMMA",
                  map.kernels->size());
    Legend l = legend_of(
        colour_bar("LOG10 GAMMA, 1/M^2 (NARROW KERNELS HIGH)", Colormap::Viridis, lo_s, hi_s),
        g.cell, false);
    l.swatches = {{colormap(Colormap::Viridis, 0.5), "A KERNEL'S CENTRE (EVERY DOT ONE SIZE)", 1}};
    write_captioned(dots, head + title, l, prefix + "_kernels.png", files);
  }
  return files;
}

}  // namespace potmap::experiment
