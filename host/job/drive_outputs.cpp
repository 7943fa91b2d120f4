#include "drive_outputs.hpp"

#include <cstdio>

#include "drive_band_picture.hpp"
#include "potmap/error.hpp"
#include "potmap/mapping/drive_volume.hpp"

namespace potmap::job {

DriveOutputs write_drive_outputs(Context& ctx, const KernelMap& map,
                                 const std::vector<double>& positions, const std::string& prefix,
                                 const DriveOutputOptions& o) {
  if (o.picture_res < 0)
    throw ArgumentError("drive outputs: the picture resolution must not be negative");
  DriveVolumeOptions vo;
  vo.voxel = o.voxel;
  vo.band_low = o.band_low;
  vo.band_high = o.band_high;
  vo.known = o.known;
  vo.octomap_path = prefix + ".bt";
  vo.cloud_path = prefix + "_occupied.ply";
  vo.progress = o.progress;
  const DriveVolume v = export_drive_volume(ctx, map, positions, vo);
  const HeightBandRaster& band = v.band;
  const BandFiles bf =
      write_band_files(band.prob, band.var, band.nx, band.ny, band.origin, band.res, prefix,
                       o.picture_res, o.picture_pixels, o.band_low, o.band_high);
  DriveOutputs out;
  out.files = {vo.octomap_path, vo.cloud_path};
  out.files.insert(out.files.end(), bf.files.begin(), bf.files.end());
  char line[512];
  std::snprintf(line, sizeof line,
                "volume         %zu blocks of %g m at %g m: %zu occupied, %zu free, %zu unknown "
                "voxels\nOctoMap        %llu leaves -> %s\npoint cloud    %zu occupied voxels "
                "-> %s\n%s",
                v.blocks, 16 * v.voxel, v.voxel, v.occupied, v.free, v.unknown,
                static_cast<unsigned long long>(v.octomap_leaves), vo.octomap_path.c_str(),
                v.occupied, vo.cloud_path.c_str(), bf.summary.c_str());
  out.summary = line;
  out.json = {{"voxel_m", v.voxel},
              {"blocks", v.blocks},
              {"occupied_voxels", v.occupied},
              {"free_voxels", v.free},
              {"unknown_voxels", v.unknown},
              {"octomap_leaves", v.octomap_leaves},
              {"octomap_nodes", v.octomap_nodes},
              {"band_m", {o.band_low, o.band_high}},
              {"band", bf.json}};
  return out;
}

}  // namespace potmap::job
