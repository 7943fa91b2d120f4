#include "map_pictures.hpp"

#include <algorithm>

#include "potmap/error.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/render/kernel_picture.hpp"
#include "progress.hpp"

namespace potmap::cli {

double picture_resolution(const KernelMap& map, double margin, std::size_t long_side) {
  double lo[3], hi[3];
  map.bounds(lo, hi);
  const double extent = std::max(hi[0] - lo[0], hi[1] - lo[1]) + 2 * margin;
  return extent / double(std::max<std::size_t>(long_side, 1));
}

MapPictures write_map_pictures(Context& ctx, const KernelMap& map, const std::string& prefix,
                               double resolution, double margin, double z) {
  if (map.empty()) throw ArgumentError("pictures: the map " + prefix + " has no kernels");
  double lo[3], hi[3];
  map.bounds(lo, hi);
  RasterSpec spec;
  spec.xmin = lo[0] - margin;
  spec.xmax = hi[0] + margin;
  spec.ymin = lo[1] - margin;
  spec.ymax = hi[1] + margin;
  spec.resolution = resolution;
  spec.z = z;
  RasterOptions ro;
  ro.write_npy = false;
  ro.progress = terminal_progress("picture");
  const RasterSummary rs = rasterize(ctx, map, spec, prefix, ro);
  const std::string kp = prefix + "_kernels.png";
  const KernelPictureSummary ks = write_kernel_picture(&ctx, map, spec, kp);
  MapPictures p;
  p.files = rs.files;
  p.files.push_back(kp);
  p.width = rs.width;
  p.height = rs.height;
  p.resolution = resolution;
  p.min_length = ks.min_length;
  p.max_length = ks.max_length;
  return p;
}

}  // namespace potmap::cli
