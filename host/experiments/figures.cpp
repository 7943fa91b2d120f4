// Pictures of any fitted map, through its query function, so that grids and kernel maps are
// drawn the same way.
#include <algorithm>
#include <cmath>

#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/render/colormap.hpp"
#include "render/png_writer.hpp"

namespace potmap::experiment {

std::vector<std::string> write_figures(const FittedMap& map, int dim, const double lo[3],
                                       const double hi[3], const std::string& prefix,
                                       std::size_t max_pixels) {
  const double ex = hi[0] - lo[0], ey = hi[1] - lo[1];
  if (!(ex > 0 && ey > 0) || max_pixels == 0) throw ArgumentError("write_figures: empty window");
  if (dim != 2 && dim != 3) throw ArgumentError("write_figures: dim must be 2 or 3");
  const double cell = std::max(ex, ey) / double(max_pixels);
  const auto w = std::max<std::size_t>(1, std::size_t(std::ceil(ex / cell)));
  const auto h = std::max<std::size_t>(1, std::size_t(std::ceil(ey / cell)));
  std::vector<double> pts(w * h * dim, 0.0), prob(w * h), var(w * h);
  for (std::size_t r = 0; r < h; ++r)
    for (std::size_t c = 0; c < w; ++c) {
      double* p = &pts[(r * w + c) * dim];
      p[0] = lo[0] + (c + 0.5) * cell;
      p[1] = lo[1] + (h - 1 - r + 0.5) * cell;  // row 0 at the top, as raster.hpp
      if (dim == 3) p[2] = 0.5 * (lo[2] + hi[2]);
    }
  map.query(pts.data(), w * h, prob.data(), var.data());
  std::vector<std::string> files;
  std::vector<std::uint8_t> row(w * 3);
  auto put = [&](std::size_t c, Rgb col) {
    row[3 * c] = col.r;
    row[3 * c + 1] = col.g;
    row[3 * c + 2] = col.b;
  };
  {
    detail::PngWriter png(prefix + "_prob.png", w, h);
    for (std::size_t r = 0; r < h; ++r) {
      for (std::size_t c = 0; c < w; ++c) put(c, colormap(Colormap::Viridis, prob[r * w + c]));
      png.write_row(row.data());
    }
    png.finish();
    files.push_back(prefix + "_prob.png");
  }
  if (std::any_of(var.begin(), var.end(), [](double v) { return std::isfinite(v); })) {
    detail::PngWriter png(prefix + "_var.png", w, h);
    for (std::size_t r = 0; r < h; ++r) {
      for (std::size_t c = 0; c < w; ++c) {
        const double v = var[r * w + c];
        put(c, colormap(Colormap::Magma, std::isfinite(v) ? v / (1 + v) : NAN));
      }
      png.write_row(row.data());
    }
    png.finish();
    files.push_back(prefix + "_var.png");
  }
  if (map.kernels && !map.kernels->empty()) {
    const KernelMap& k = *map.kernels;
    double gmin = HUGE_VAL, gmax = -HUGE_VAL;
    for (double g : k.gamma) {
      gmin = std::min(gmin, std::log10(g));
      gmax = std::max(gmax, std::log10(g));
    }
    std::vector<std::uint8_t> img(w * h * 3, 255);
    for (std::size_t m = 0; m < k.size(); ++m) {
      const double x = k.position[m * k.dim], y = k.position[m * k.dim + 1];
      const long c = std::lround((x - lo[0]) / cell - 0.5);
      const long r = long(h) - 1 - std::lround((y - lo[1]) / cell - 0.5);
      const double t = gmax > gmin ? (std::log10(k.gamma[m]) - gmin) / (gmax - gmin) : 0.5;
      const Rgb col = colormap(Colormap::Viridis, t);
      for (long dr = -1; dr <= 1; ++dr)
        for (long dc = -1; dc <= 1; ++dc) {
          const long rr = r + dr, cc = c + dc;
          if (rr < 0 || cc < 0 || rr >= long(h) || cc >= long(w)) continue;
          std::uint8_t* px = &img[(std::size_t(rr) * w + std::size_t(cc)) * 3];
          px[0] = col.r;
          px[1] = col.g;
          px[2] = col.b;
        }
    }
    detail::PngWriter png(prefix + "_kernels.png", w, h);
    for (std::size_t r = 0; r < h; ++r) png.write_row(&img[r * w * 3]);
    png.finish();
    files.push_back(prefix + "_kernels.png");
  }
  return files;
}

}  // namespace potmap::experiment
