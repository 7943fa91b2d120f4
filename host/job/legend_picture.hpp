#pragma once
// Map pictures a person reads: the probability (viridis) and the logit variance (magma) of a
// grid of cells, never-observed cells grey, each under its title and above its legend (the
// colour bar of its quantity, the grey of never-observed space and a scale bar in metres;
// render/picture_caption.hpp). The height band of a 3D drive and the
// pictures of `potmap map` / `potmap mapping` share them.
#include <cstddef>
#include <string>
#include <vector>

#include "potmap/job/map_pictures.hpp"

namespace potmap::job {

struct LegendPictures {
  std::size_t width = 0, height = 0;  ///< pixels of the map part
  double metres_per_pixel = 0;
  double var_max = 0;  ///< the variance colour bar's top (the known pixels' 99th percentile)
};

/// `prob` and `var`: nx x ny cells of `cell` metres, row-major from the lower-left cell, prob <
/// 0 where the cell is unknown. A pixel takes k x k cells (their largest probability, and the
/// variance there). Writes `prob_path` and `var_path` (PNG) titled as given (capitals: the
/// pixel font has no lower case). Throws potmap::Error when a file cannot be written.
LegendPictures write_legend_pictures(const std::vector<float>& prob, const std::vector<float>& var,
                                     std::size_t nx, std::size_t ny, std::size_t k, double cell,
                                     const std::string& prob_path, const std::string& var_path,
                                     const std::string& prob_title, const std::string& var_title);

}  // namespace potmap::job
