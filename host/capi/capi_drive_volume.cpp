// C API: a 3D map's volume as an OctoMap and a point cloud (mapping/drive_volume.hpp).
#include <cmath>
#include <string>
#include <vector>

#include "capi_handles.hpp"
#include "capi_structs.hpp"
#include "potmap/mapping/drive_volume.hpp"

namespace potmap::capi {
namespace {

potmap_drive_volume_options default_volume_options() {
  const potmap::DriveVolumeOptions d;
  potmap_drive_volume_options o{};
  o.struct_size = sizeof o;
  o.voxel = d.voxel;
  o.band_low = d.band_low;
  o.band_high = d.band_high;
  return o;
}

potmap::DriveVolumeOptions to_volume_options(const potmap_drive_volume_options* in) {
  const potmap_drive_volume_options o =
      in ? read_struct(in, default_volume_options(), kDriveVolumeOptionsV1, "options")
         : default_volume_options();
  if (!(o.voxel > 0) || !std::isfinite(o.voxel))
    fail(POTMAP_ERROR_INVALID_ARGUMENT,
         "options->voxel is out of range: " + std::to_string(o.voxel));
  if (!std::isfinite(o.band_low) || !std::isfinite(o.band_high) || !(o.band_high > o.band_low))
    fail(POTMAP_ERROR_INVALID_ARGUMENT, "options->band_high " + std::to_string(o.band_high) +
                                            " must be above band_low " +
                                            std::to_string(o.band_low));
  potmap::DriveVolumeOptions r;
  r.voxel = o.voxel;
  r.band_low = o.band_low;
  r.band_high = o.band_high;
  if (o.octomap_path) r.octomap_path = o.octomap_path;
  if (o.cloud_path) r.cloud_path = o.cloud_path;
  return r;
}

}  // namespace
}  // namespace potmap::capi

using namespace potmap::capi;

extern "C" {

potmap_status potmap_drive_volume_options_init(potmap_drive_volume_options* options,
                                               size_t struct_size) {
  return guard("potmap_drive_volume_options_init", POTMAP_ERROR_INTERNAL, [&] {
    init_struct(options, struct_size, default_volume_options(), kDriveVolumeOptionsV1, "options");
  });
}

potmap_status potmap_export_drive_volume(potmap_context* context, const potmap_map* map,
                                         const double* path, size_t positions,
                                         const potmap_drive_volume_options* options,
                                         potmap_drive_volume_summary* summary) {
  return guard("potmap_export_drive_volume", POTMAP_ERROR_IO, [&] {
    potmap_context& c = checked(context);
    const potmap_map& m = checked(map);
    require(path, "path");
    if (summary)
      check_struct_size(summary->struct_size, kDriveVolumeSummaryV1, "summary",
                        POTMAP_ERROR_INVALID_ARGUMENT);
    if (m.map.dim != 3)
      fail(POTMAP_ERROR_DIMENSION_MISMATCH,
           "the map is " + std::to_string(m.map.dim) + "D; a volume needs a 3D map");
    const potmap::DriveVolumeOptions o = to_volume_options(options);
    const std::vector<double> p(path, path + 3 * positions);
    const potmap::DriveVolume v = potmap::export_drive_volume(*c.ctx, m.map, p, o);
    if (!summary) return;
    potmap_drive_volume_summary s{};
    s.struct_size = sizeof s;
    s.blocks = v.blocks;
    s.occupied_voxels = v.occupied;
    s.free_voxels = v.free;
    s.unknown_voxels = v.unknown;
    s.octomap_nodes = v.octomap_nodes;
    s.octomap_leaves = v.octomap_leaves;
    write_struct(summary, s, kDriveVolumeSummaryV1, "summary", POTMAP_ERROR_INVALID_ARGUMENT);
  });
}

}  // extern "C"
