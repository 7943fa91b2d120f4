#pragma once
// A 3D map's height band as files a person and a robot read: PREFIX_band_prob.png and
// PREFIX_band_var.png (viridis probability and magma variance, never-observed space grey, a
// title with the quantity and the band's heights, a colour bar and a scale bar in metres) and
// the ROS map
// PREFIX_band.yaml + .pgm.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>
#include <vector>

namespace potmap::job {

struct BandFiles {
  std::vector<std::string> files;
  std::string summary;
  nlohmann::json json;
};

/// `prob` and `var`: nx x ny cells (row-major from the lower-left cell at `origin`, metres,
/// `res` metres each), prob < 0 where nothing of the band is known. Pictures at picture_res
/// metres a pixel (0: the coarsest multiple of res that fits `pixels` along the longer side;
/// a pixel takes its cells' largest probability). band_low, band_high: the band's heights about
/// the sensor's path, metres, as the titles name them.
BandFiles write_band_files(const std::vector<float>& prob, const std::vector<float>& var,
                           std::size_t nx, std::size_t ny, const double origin[2], double res,
                           const std::string& prefix, double picture_res, std::size_t pixels,
                           double band_low, double band_high);

}  // namespace potmap::job
