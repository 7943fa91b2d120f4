#pragma once
// Map pictures a person reads: the probability (viridis) and the logit variance (magma) of a
// grid of cells, never-observed cells grey, each under its title and above its legend (the
// colour bar of its quantity, the grey of never-observed space and a scale bar in metres;
// experiments/picture_caption.hpp). The height band of a 3D drive and the
// pictures of `potmap map` / `potmap mapping` share them.
#include <cstddef>
#include <string>
#include <vector>

#include "potmap/map/kernel_map.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/render/kernel_picture.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::cli {

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

/// The kernels picture (render/kernel_picture.hpp: a dot at each kernel's centre, coloured by
/// its length scale on a log axis, over the map's probability in grey) under its title and above
/// its legend: the length-scale colour bar in metres, the grey bar of P(occupied), the dot of a
/// kernel and a scale bar. Writes `path` (PNG); throws as write_kernel_picture does.
KernelPictureSummary write_kernel_legend_picture(Context& ctx, const KernelMap& map,
                                                 const RasterSpec& spec, const std::string& path);

}  // namespace potmap::cli
