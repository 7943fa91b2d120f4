// The true town drawn for a person (town_picture.hpp).
#include "town_picture.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace potmap::cli {

experiment::Picture town_picture(const Town& town, const std::vector<double>& route,
                                 const double lo[3], const double hi[3], std::size_t max_pixels) {
  const double mpp = std::max(hi[0] - lo[0], hi[1] - lo[1]) / max_pixels;
  experiment::Picture p;
  p.width = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil((hi[0] - lo[0]) / mpp)));
  p.height = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil((hi[1] - lo[1]) / mpp)));
  p.rgb.assign(p.width * p.height * 3, 255);
  for (std::size_t j = 0; j < p.height; ++j)
    for (std::size_t i = 0; i < p.width; ++i)
      if (town.occupied(lo[0] + (i + 0.5) * mpp, hi[1] - (j + 0.5) * mpp))
        std::fill_n(&p.rgb[(j * p.width + i) * 3], 3, 40);
  // The route as a line a few pixels wide: its poses alone, a pixel each, are lost at 1200
  // pixels across.
  const long half = long(std::max<std::size_t>(1, std::max(p.width, p.height) / 600));
  const auto dot = [&](double i, double j) {
    for (long dj = -half; dj <= half; ++dj)
      for (long di = -half; di <= half; ++di) {
        const long x = long(i) + di, y = long(j) + dj;
        if (x < 0 || y < 0 || x >= long(p.width) || y >= long(p.height)) continue;
        std::uint8_t* px = &p.rgb[(std::size_t(y) * p.width + std::size_t(x)) * 3];
        px[0] = 220, px[1] = 20, px[2] = 20;
      }
  };
  for (std::size_t k = 0; k + 1 < route.size(); k += 2) {
    const double i = (route[k] - lo[0]) / mpp, j = (hi[1] - route[k + 1]) / mpp;
    const bool last = k + 3 >= route.size();
    const double i1 = last ? i : (route[k + 2] - lo[0]) / mpp;
    const double j1 = last ? j : (hi[1] - route[k + 3]) / mpp;
    const int steps = 1 + int(std::ceil(std::max(std::fabs(i1 - i), std::fabs(j1 - j))));
    for (int t = 0; t <= steps; ++t) dot(i + (i1 - i) * t / steps, j + (j1 - j) * t / steps);
  }
  return p;
}

std::vector<experiment::Swatch> town_swatches() {
  return {{Rgb{40, 40, 40}, "BUILDINGS AND OBSTACLES (TRUE TOWN)", 0},
          {Rgb{220, 20, 20}, "ROUTE OF THE SCANS", 0}};
}

void write_true_town(const Town& town, const std::string& name, const std::vector<double>& route,
                     const std::string& path) {
  const double lo[3] = {0, 0, 0}, hi[3] = {town.width(), town.height(), 0};
  const auto pixels = std::size_t(std::ceil(std::max(town.width(), town.height()) / 0.5));
  experiment::Picture body = town_picture(town, route, lo, hi, pixels);
  body.metres_per_pixel = std::max(town.width(), town.height()) / double(pixels);
  experiment::Legend legend;
  legend.swatches = town_swatches();
  legend.metres_per_pixel = body.metres_per_pixel;
  const experiment::Picture pic =
      experiment::captioned(body, "THE TRUE TOWN " + name + " AND THE ROUTE OF ITS SCANS", legend);
  experiment::write_side_by_side({&pic}, path);
}

}  // namespace potmap::cli
