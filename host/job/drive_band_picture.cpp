#include "drive_band_picture.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "legend_picture.hpp"
#include "potmap/io/ros_map.hpp"

namespace potmap::job {

namespace {

// The band's heights as the titles give them: relative to the path, which a band follows. No-break
// spaces (picture_caption.hpp) keep "Z -1.00 TO +0.50 M" on one line of a wrapped title.
std::string band_heights(double low, double high) {
  char s[96];
  std::snprintf(s, sizeof s, "Z\xA0%+.2f\xA0TO\xA0%+.2f\xA0M ABOUT THE SENSOR'S PATH", low, high);
  return s;
}

}  // namespace

BandFiles write_band_files(const std::vector<float>& prob, const std::vector<float>& var,
                           std::size_t nx, std::size_t ny, const double origin[2], double res,
                           const std::string& prefix, double picture_res, std::size_t pixels,
                           double band_low, double band_high) {
  BandFiles out;
  // The ROS map at the band's own resolution.
  RosMapOptions ro;
  ro.resolution = res;
  std::vector<double> p(prob.begin(), prob.end());
  std::vector<std::uint8_t> known(prob.size());
  for (std::size_t c = 0; c < prob.size(); ++c) known[c] = prob[c] >= 0;
  const RosMapSummary ros = write_ros_cells(p, known, nx, ny, origin, prefix + "_band.yaml", ro);
  // The pictures.
  const std::size_t k = picture_res > 0
                            ? std::max<std::size_t>(1, std::size_t(std::lround(picture_res / res)))
                            : std::max<std::size_t>(1, (std::max(nx, ny) + pixels - 1) / pixels);
  const LegendPictures px = write_legend_pictures(
      prob, var, nx, ny, k, res, prefix + "_band_prob.png", prefix + "_band_var.png",
      "P(OCCUPIED), THE HIGHEST IN THE BAND " + band_heights(band_low, band_high) +
          ", SEEN FROM ABOVE",
      "LOGIT VARIANCE WHERE THE BAND'S P(OCCUPIED) IS HIGHEST, " +
          band_heights(band_low, band_high));
  const double mpp = px.metres_per_pixel;
  out.files = {prefix + "_band_prob.png", prefix + "_band_var.png", ros.yaml, ros.pgm};
  char line[256];
  std::snprintf(line, sizeof line,
                "band           pictures %zu x %zu at %.2f m; ROS map %zu x %zu at %.2f m: %zu "
                "occupied, %zu free, %zu unknown\n",
                px.width, px.height, mpp, ros.width, ros.height, res, ros.occupied, ros.free,
                ros.unknown);
  out.summary = line;
  out.json = {{"picture_m_per_px", mpp}, {"picture_px", {px.width, px.height}},
              {"ros_res_m", res},        {"ros_occupied", ros.occupied},
              {"ros_free", ros.free},    {"ros_unknown", ros.unknown}};
  return out;
}

}  // namespace potmap::job
