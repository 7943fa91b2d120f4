#include "potmap/render/kernel_picture.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "render/png_writer.hpp"

namespace potmap {

KernelPictureSummary write_kernel_picture(Context* ctx, const KernelMap& map,
                                          const RasterSpec& spec, const std::string& path,
                                          const KernelPictureOptions& o) {
  spec.validate();
  map.validate("write_kernel_picture");
  if (o.background && !ctx)
    throw ArgumentError("write_kernel_picture: a background needs a device context");
  if (o.dot_radius < 0 || o.dot_radius > 64)
    throw ArgumentError("write_kernel_picture: dot_radius must be in [0, 64]");
  KernelPictureSummary s;
  s.width = spec.width();
  s.height = spec.height();
  const std::size_t w = s.width, h = s.height;
  std::vector<std::uint8_t> rgb(w * h * 3, 255);

  if (o.background && !map.empty()) {
    // Rows of the grid run upwards; image rows downwards (raster.hpp's orientation).
    GridSpec g;
    g.dim = map.dim;
    g.origin[0] = spec.xmin;
    g.origin[1] = spec.ymin;
    g.origin[2] = spec.z - 0.5 * spec.resolution;
    g.resolution = spec.resolution;
    g.count[0] = w;
    g.count[1] = h;
    g.count[2] = 1;
    MapEvaluator ev(*ctx, map);
    std::vector<float> prob(w * h);
    ev.evaluate_grid(g, nullptr, nullptr, prob.data());
    for (std::size_t r = 0; r < h; ++r)
      for (std::size_t c = 0; c < w; ++c) {
        const float p = prob[(h - 1 - r) * w + c];
        // Occupied dark, free light, unknown mid-grey; kept pale so the dots stand out.
        const auto v = static_cast<std::uint8_t>(std::isfinite(p) ? 235 - 135 * p : 128);
        std::fill_n(&rgb[(r * w + c) * 3], 3, v);
      }
  }

  double lmin = o.min_length, lmax = o.max_length;
  if (!(lmin > 0) || !(lmax > 0)) {
    double a = HUGE_VAL, b = 0;
    for (double g : map.gamma) {
      const double l = 1 / std::sqrt(g);
      a = std::min(a, l);
      b = std::max(b, l);
    }
    if (!(lmin > 0)) lmin = map.empty() ? 1 : a;
    if (!(lmax > 0)) lmax = map.empty() ? 1 : b;
  }
  if (lmax <= lmin) lmax = lmin * 1.0001;
  s.min_length = lmin;
  s.max_length = lmax;
  const double span = std::log(lmax / lmin);
  const int rad = o.dot_radius;
  for (std::size_t k = 0; k < map.size(); ++k) {
    const double* p = &map.position[k * map.dim];
    const double fc = (p[0] - spec.xmin) / spec.resolution;
    const double fr = (p[1] - spec.ymin) / spec.resolution;
    if (!(fc >= 0 && fc < double(w) && fr >= 0 && fr < double(h))) continue;
    ++s.kernels_drawn;
    const long c0 = static_cast<long>(fc), r0 = static_cast<long>(h - 1) - static_cast<long>(fr);
    const Rgb col = colormap(o.colormap, std::log(1 / std::sqrt(map.gamma[k]) / lmin) / span);
    for (long dr = -rad; dr <= rad; ++dr)
      for (long dc = -rad; dc <= rad; ++dc) {
        if (dr * dr + dc * dc > rad * rad) continue;
        const long r = r0 + dr, c = c0 + dc;
        if (r < 0 || c < 0 || r >= long(h) || c >= long(w)) continue;
        std::uint8_t* px = &rgb[(std::size_t(r) * w + std::size_t(c)) * 3];
        px[0] = col.r;
        px[1] = col.g;
        px[2] = col.b;
      }
  }
  detail::PngWriter png(path, w, h);
  for (std::size_t r = 0; r < h; ++r) png.write_row(&rgb[r * w * 3]);
  png.finish();
  return s;
}

}  // namespace potmap
