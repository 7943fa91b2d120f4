#include "legend_picture.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "potmap/experiments/figure_panels.hpp"
#include "potmap/render/colormap.hpp"

namespace potmap::job {

namespace {

const Rgb kUnknown = experiment::kUnknownGrey;
const Rgb kInk{0, 0, 0};

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

using experiment::draw_text;
using experiment::fill_box;
using experiment::round_scale;
using experiment::text_advance;

// The map above, then a strip: the colour bar (quantity and its ends), the grey of unknown
// space, and a scale bar in metres.
experiment::Picture picture(const Pixels& px, bool variance, double vmax, double metres_per_px,
                            const std::string& title) {
  const std::size_t strip = 70, w = std::max<std::size_t>(px.w, 420);
  experiment::Picture pic;
  pic.width = w;
  pic.height = px.h + strip;
  pic.rgb.assign(pic.width * pic.height * 3, 255);
  for (std::size_t j = 0; j < px.h; ++j)
    for (std::size_t i = 0; i < px.w; ++i) {
      const std::size_t q = i + px.w * (px.h - 1 - j);  // top row: the largest y
      Rgb c = kUnknown;
      if (px.prob[q] >= 0)
        c = variance ? colormap(Colormap::Magma, std::min(1.0, double(px.var[q]) / vmax))
                     : colormap(Colormap::Viridis, px.prob[q]);
      fill_box(pic, i, j, 1, 1, c);
    }
  const std::size_t y = px.h + 8, bar = 160;
  draw_text(pic, 6, long(y), title, kInk, 2);
  for (std::size_t i = 0; i < bar; ++i)
    fill_box(pic, 6 + i, y + 16, 1, 12,
             colormap(variance ? Colormap::Magma : Colormap::Viridis, double(i) / double(bar - 1)));
  char hi[32];
  std::snprintf(hi, sizeof hi, variance ? "%.2g" : "1", vmax);
  draw_text(pic, 6, long(y + 32), "0", kInk, 2);
  draw_text(pic, long(6 + bar - text_advance(2) * std::string(hi).size()), long(y + 32), hi, kInk,
            2);
  fill_box(pic, 6 + bar + 14, y + 16, 12, 12, kUnknown);
  draw_text(pic, long(6 + bar + 30), long(y + 16), "UNKNOWN", kInk, 2);
  const double len = round_scale(double(px.w) * metres_per_px);
  const auto len_px = std::size_t(std::lround(len / metres_per_px));
  const std::size_t sx = w > len_px + 10 ? w - len_px - 10 : 0;
  fill_box(pic, sx, y + 20, len_px, 4, kInk);
  char lab[32];
  std::snprintf(lab, sizeof lab, "%g M", len);
  draw_text(pic, long(sx), long(y + 32), lab, kInk, 2);
  return pic;
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
  const experiment::Picture a = picture(px, false, 1, mpp, prob_title);
  const experiment::Picture b = picture(px, true, vmax, mpp, var_title);
  experiment::write_side_by_side({&a}, prob_path);
  experiment::write_side_by_side({&b}, var_path);
  return {px.w, px.h, mpp, vmax};
}

}  // namespace potmap::job
