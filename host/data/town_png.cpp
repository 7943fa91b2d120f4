// A top view of a simulated town, for humans checking what the simulator drew.
#include <cmath>
#include <vector>

#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "render/png_writer.hpp"

namespace potmap {

void write_town_png(const Town& town, const std::vector<double>& route, const std::string& path,
                    double mpp) {
  if (!(mpp > 0)) throw ArgumentError("write_town_png: metres_per_pixel must be > 0");
  const int w = static_cast<int>(std::ceil(town.width() / mpp));
  const int h = static_cast<int>(std::ceil(town.height() / mpp));
  std::vector<unsigned char> img(static_cast<std::size_t>(w) * h * 3, 235);
  auto put = [&](double x, double y, unsigned char r, unsigned char g, unsigned char b) {
    const int i = static_cast<int>(x / mpp), j = h - 1 - static_cast<int>(y / mpp);
    if (i < 0 || i >= w || j < 0 || j >= h) return;
    unsigned char* p = &img[(static_cast<std::size_t>(j) * w + i) * 3];
    p[0] = r, p[1] = g, p[2] = b;
  };
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) {
      const double x = (i + 0.5) * mpp, y = (h - 1 - j + 0.5) * mpp;
      if (town.occupied(x, y)) put(x, y, 70, 70, 70);
    }
  for (const Obstacle& o : town.obstacles()) {  // small things over the building fill
    if (o.kind == Obstacle::kBuilding) continue;
    const unsigned char g = o.kind == Obstacle::kCar ? 60 : 160;
    if (o.polygon.empty()) {
      put(o.cx, o.cy, 30, g, 40);
    } else {
      for (std::size_t k = 0; k + 1 < o.polygon.size(); k += 2)
        put(o.polygon[k], o.polygon[k + 1], 40, g, 200);
    }
  }
  for (std::size_t k = 0; k + 1 < route.size(); k += 2) put(route[k], route[k + 1], 220, 20, 20);

  // The shared writer: atomic (a full disk leaves a previous picture), every write checked.
  detail::PngWriter png(path, static_cast<std::size_t>(w), static_cast<std::size_t>(h));
  for (int j = 0; j < h; ++j) png.write_row(&img[static_cast<std::size_t>(j) * w * 3]);
  png.finish();
}

}  // namespace potmap
