// Merging map files of either kind, and a mapper's overall map written with what merging needs
// (include/potmap/mapping/map_files.hpp).
#include <optional>
#include <string>
#include <vector>

#include "io/map_io_native.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/mapping/map_files.hpp"

namespace potmap {

namespace {

[[noreturn]] void cannot_merge(const std::string& path) {
  throw InputError(path +
                   ": written without its information form (a map of ABHM, of POT's summed "
                   "kernels, a .csv or .npz, or a build before merging): it cannot be merged "
                   "exactly");
}

}  // namespace

MapMergeSummary merge_map_files(const std::vector<std::string>& paths, const std::string& out,
                                JointBhmMergeOptions options) {
  if (paths.size() < 2)
    throw ArgumentError("merge: give at least two maps, got " + std::to_string(paths.size()));
  std::vector<JointBhm> joint;
  std::vector<AveragedMap> averaged;
  for (const std::string& p : paths) {
    if (!detail::has_potmap_extension(p)) cannot_merge(p);
    if (std::optional<JointBhm> j = read_joint_bhm_information(p))
      joint.push_back(std::move(*j));
    else if (std::optional<AveragedMap> a = read_averaged_map_information(p))
      averaged.push_back(std::move(*a));
    else
      cannot_merge(p);
    if (!joint.empty() && !averaged.empty())
      throw ArgumentError("merge: " + paths.front() + " and " + p +
                          " are maps of different kinds (a joint BHM map, POT's averaged map): "
                          "maps of one kind merge");
  }
  MapMergeSummary s;
  if (!averaged.empty()) {
    AveragedMap c = std::move(averaged.front());
    for (std::size_t i = 1; i < averaged.size(); ++i) c.add_map(averaged[i]);
    write_averaged_map(c, out);
    s.averaged = true;
    s.kernels = c.size();
    return s;
  }
  std::vector<const JointBhm*> ptrs;
  for (const JointBhm& m : joint) ptrs.push_back(&m);
  options.names = paths;
  const JointBhm c = merge_joint_bhm(ptrs, options);
  write_joint_bhm_map(c, out);
  s.kernels = c.size();
  s.scans = c.data_ids().size();
  return s;
}

void write_mapper_map(const Mapper& mapper, const std::string& path) {
  const RepotMap* repot = mapper.repot();
  if (detail::has_potmap_extension(path) && repot)
    write_joint_bhm_map(repot->learner(), path, &repot->map());
  else if (detail::has_potmap_extension(path) && mapper.averaged())
    write_averaged_map(*mapper.averaged(), path);
  else
    write_map(mapper.overall_map(), path);
}

}  // namespace potmap
