#include "potmap/render/kernel_picture.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "potmap/error.hpp"
#include "potmap/io/known_cells.hpp"
#include "render/png_writer.hpp"

namespace potmap {

namespace {

// The map's probability in grey underneath the dots (kernel_picture_grey), and where nothing
// was observed (io/known_cells.hpp's rule, as the probability pictures and exports decide it)
// the darker kKernelPictureUnknown: a window's empty margin must not read as free space.
void draw_background(Context& ctx, const KernelMap& map, const RasterSpec& spec, std::size_t w,
                     std::size_t h, std::vector<std::uint8_t>& rgb) {
  KnownEvaluator known(&ctx, map);
  std::vector<double> pts;
  pts.reserve(w * std::size_t(map.dim));
  for (std::size_t r = 0; r < h; ++r) {
    // Image rows run downwards from the window's top (raster.hpp's orientation).
    const double y = spec.ymin + (double(h - 1 - r) + 0.5) * spec.resolution;
    pts.clear();
    for (std::size_t c = 0; c < w; ++c) {
      pts.push_back(spec.xmin + (double(c) + 0.5) * spec.resolution);
      pts.push_back(y);
      if (map.dim == 3) pts.push_back(spec.z);
    }
    const KnownValues v = known.values(pts);
    for (std::size_t c = 0; c < w; ++c) {
      const Rgb g = v.known[c] && std::isfinite(v.prob[c]) ? kernel_picture_grey(v.prob[c])
                                                           : kKernelPictureUnknown;
      std::uint8_t* px = &rgb[(r * w + c) * 3];
      px[0] = g.r, px[1] = g.g, px[2] = g.b;
    }
  }
}

// The colour scale's ends, metres: the options', else the map's shortest and longest.
void length_range(const KernelMap& map, const KernelPictureOptions& o, double& lmin, double& lmax) {
  lmin = o.min_length, lmax = o.max_length;
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
}

}  // namespace

Rgb kernel_picture_grey(double p) {
  // White to a dark brown: walls stand out darkest, and no shade is the neutral grey of
  // never-observed space (kKernelPictureUnknown).
  const double t = std::min(1.0, std::max(0.0, p));
  auto mix = [t](double free, double occupied) {
    return static_cast<std::uint8_t>(std::lround(free + (occupied - free) * t));
  };
  return {mix(250, 110), mix(250, 70), mix(250, 40)};
}

KernelPictureSummary render_kernel_picture(Context* ctx, const KernelMap& map,
                                           const RasterSpec& spec, std::vector<std::uint8_t>& rgb,
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
  rgb.assign(w * h * 3, 255);
  if (o.background && !map.empty()) draw_background(*ctx, map, spec, w, h, rgb);
  double lmin = 0, lmax = 0;
  length_range(map, o, lmin, lmax);
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
  return s;
}

KernelPictureSummary write_kernel_picture(Context* ctx, const KernelMap& map,
                                          const RasterSpec& spec, const std::string& path,
                                          const KernelPictureOptions& o) {
  std::vector<std::uint8_t> rgb;
  const KernelPictureSummary s = render_kernel_picture(ctx, map, spec, rgb, o);
  detail::PngWriter png(path, s.width, s.height);
  for (std::size_t r = 0; r < s.height; ++r) png.write_row(&rgb[r * s.width * 3]);
  png.finish();
  return s;
}

}  // namespace potmap
