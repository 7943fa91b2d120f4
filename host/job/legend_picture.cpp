#include "legend_picture.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "potmap/render/colormap.hpp"
#include "potmap/render/picture.hpp"
#include "potmap/render/picture_caption.hpp"

namespace potmap::job {

namespace {

const Rgb kUnknown = kUnknownGrey;

struct Pixels {
  std::size_t w = 0, h = 0, k = 1;  // k x k cells a pixel
  std::vector<float> prob, var;     // prob < 0: unknown
};

Pixels downsample(const std::vector<float>& prob, const std::vector<float>& var, std::size_t nx,
                  std::size_t ny, std::size_t k) {
  Pixels p;
  p.k = k;
  p.w = (nx + k - 1) / k;
  p.h = (ny + k - 1) / k;
  p.prob.assign(p.w * p.h, -1.0f);
  p.var.assign(p.w * p.h, 0.0f);
  for (std::size_t j = 0; j < ny; ++j)
    for (std::size_t i = 0; i < nx; ++i) {
      const std::size_t c = i + nx * j, q = i / k + p.w * (j / k);
      if (prob[c] > p.prob[q]) {
        p.prob[q] = prob[c];
        p.var[q] = var[c];
      }
    }
  return p;
}

// The map's pixels, top row the largest y, under its title and above its legend: the colour
// bar of the quantity, the grey of never-observed space and a scale bar in metres.
Picture picture(const Pixels& px, bool variance, double vmax, double metres_per_px,
                const std::string& title) {
  Picture body;
  body.width = px.w;
  body.height = px.h;
  body.metres_per_pixel = metres_per_px;
  body.rgb.resize(px.w * px.h * 3);
  for (std::size_t j = 0; j < px.h; ++j)
    for (std::size_t i = 0; i < px.w; ++i) {
      const std::size_t q = i + px.w * (px.h - 1 - j);
      Rgb c = kUnknown;
      if (px.prob[q] >= 0)
        c = variance ? colormap(Colormap::Magma, std::min(1.0, double(px.var[q]) / vmax))
                     : colormap(Colormap::Viridis, px.prob[q]);
      fill_box(body, i, j, 1, 1, c);
    }
  char hi[32];
  std::snprintf(hi, sizeof hi, "%.2g OR MORE", vmax);
  Legend legend;
  legend.bars = {variance
                     ? colour_bar("LOGIT VARIANCE", Colormap::Magma, "0", hi)
                     : colour_bar("P(OCCUPIED): 0 FREE, 1 OCCUPIED", Colormap::Viridis, "0", "1")};
  legend.swatches = {never_observed_swatch()};
  legend.metres_per_pixel = metres_per_px;
  return captioned(body, title, legend);
}

}  // namespace

LegendPictures write_legend_pictures(const std::vector<float>& prob, const std::vector<float>& var,
                                     std::size_t nx, std::size_t ny, std::size_t k, double cell,
                                     const std::string& prob_path, const std::string& var_path,
                                     const std::string& prob_title, const std::string& var_title) {
  const Pixels px = downsample(prob, var, nx, ny, std::max<std::size_t>(k, 1));
  std::vector<float> vs;
  for (std::size_t q = 0; q < px.prob.size(); ++q)
    if (px.prob[q] >= 0) vs.push_back(px.var[q]);
  double vmax = 1;
  if (!vs.empty()) {
    const std::size_t at = vs.size() * 99 / 100;
    std::nth_element(vs.begin(), vs.begin() + long(at), vs.end());
    vmax = std::max(1e-6, double(vs[at]));
  }
  const double mpp = cell * double(px.k);
  const Picture a = picture(px, false, 1, mpp, prob_title);
  const Picture b = picture(px, true, vmax, mpp, var_title);
  write_side_by_side({&a}, prob_path);
  write_side_by_side({&b}, var_path);
  return {px.w, px.h, mpp, vmax};
}

KernelPictureSummary write_kernel_legend_picture(Context& ctx, const KernelMap& map,
                                                 const RasterSpec& spec, const std::string& path) {
  KernelPictureOptions o;
  Picture body;
  const KernelPictureSummary s = render_kernel_picture(&ctx, map, spec, body.rgb, o);
  body.width = s.width;
  body.height = s.height;
  body.metres_per_pixel = spec.resolution;
  char lo[32], hi[32];
  std::snprintf(lo, sizeof lo, "%.2g", s.min_length);
  std::snprintf(hi, sizeof hi, "%.2g", s.max_length);
  // A map of one width (RePOT's regular grid) draws every dot in the scale's low colour: say so
  // rather than show a range from a length to itself.
  const bool one_length = std::string(lo) == hi;
  Legend legend;
  legend.bars = {colour_bar("KERNEL LENGTH SCALE, M (LOG)", o.colormap,
                            one_length ? "ALL " + std::string(lo) : lo, one_length ? "" : hi)};
  ColourBar ground{"P(OCCUPIED), WHITE TO BROWN", {}, "0", "1"};
  for (int i = 0; i < 160; ++i) ground.colours.push_back(kernel_picture_grey(i / 159.0));
  legend.bars.push_back(ground);
  legend.swatches = {never_observed_swatch(),
                     {colormap(o.colormap, one_length ? 0 : 0.5),
                      "A KERNEL'S CENTRE (EVERY DOT ONE SIZE)", o.dot_radius}};
  legend.metres_per_pixel = spec.resolution;
  char title[160];
  std::snprintf(title, sizeof title,
                "KERNELS: %zu DOTS, EACH A KERNEL'S CENTRE COLOURED BY ITS LENGTH SCALE "
                "1/SQRT(GAMMA), OVER THE MAP'S P(OCCUPIED)",
                s.kernels_drawn);
  const Picture pic = captioned(body, title, legend);
  write_side_by_side({&pic}, path);
  return s;
}

}  // namespace potmap::job
