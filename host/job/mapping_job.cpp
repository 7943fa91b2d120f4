#include "potmap/job/mapping_job.hpp"

#include <cstring>
#include <filesystem>

#include "drive_job.hpp"
#include "log_job.hpp"
#include "potmap/data/drive.hpp"
#include "potmap/error.hpp"

namespace fs = std::filesystem;

namespace potmap {

namespace {

// A single process, as the ranks' job sees it.
class OneProcess : public JobRanks {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  std::vector<std::string> gather(const std::string& bytes) override { return {bytes}; }
};

}  // namespace

RankPart rank_part(std::size_t first, std::size_t end, int rank, int size,
                   const std::string& what) {
  const std::size_t n = end > first ? end - first : 0;
  if (size < 1 || rank < 0 || rank >= size)
    throw ArgumentError("mapping: rank " + std::to_string(rank) + " of " + std::to_string(size));
  if (n < std::size_t(size))
    throw ArgumentError("mapping: " + std::to_string(n) + " " + what + " cannot be split over " +
                        std::to_string(size) + " ranks (give at most " + std::to_string(n) +
                        " ranks, or more " + what + ")");
  RankPart p;
  p.begin = first + n * std::size_t(rank) / std::size_t(size);
  p.end = first + n * std::size_t(rank + 1) / std::size_t(size);
  return p;
}

std::string default_mapping_folder(const std::string& recording) {
  fs::path p = fs::path(recording).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  std::string stem = p.filename().string();
  for (const char* ext : {".gz", ".log", ".txt", ".bag", ".db3"})
    if (stem.size() > std::strlen(ext) && stem.substr(stem.size() - std::strlen(ext)) == ext)
      stem.resize(stem.size() - std::strlen(ext));
  // A file inside a recording's folder (a drive's poses, a ROS 2 bag's metadata) names it.
  if (stem.empty() || stem == "poses" || stem == "metadata.yaml" || stem == "odom_poses" ||
      stem == "optimized_poses")
    stem = p.parent_path().filename().string();
  return (fs::path("out") / "mapping" / stem).string();
}

MappingJobResult run_mapping_job(Context& ctx, const std::string& recording,
                                 const MappingJobOptions& options, const MappingJobHooks& hooks) {
  if (options.out.empty())
    throw ArgumentError("mapping: no output folder (MappingJobOptions::out)");
  if (options.range_cut < 0 && options.range_cut != -1)
    throw ArgumentError("mapping: --range-cut must be 0 (none) or positive metres, not " +
                        std::to_string(options.range_cut));
  if (options.picture_pixels == 0)
    throw ArgumentError("mapping: --picture-pixels must be positive");
  MappingJobOptions o = options;
  OneProcess one;
  JobRanks& ranks = hooks.ranks ? *hooks.ranks : one;
  DriveOptions probe;
  probe.bag = options.bag;
  if (is_drive(recording, probe)) {
    if (o.preset != "default") throw ArgumentError("mapping: --preset is for 2D logs");
    if (o.range_cut < 0) o.range_cut = 40;
    if (o.method.empty()) o.method = "bhm";
    return job::run_drive_job(ctx, recording, o, hooks, ranks);
  }
  if (o.range_cut < 0) o.range_cut = 20;
  if (o.method.empty()) o.method = "repot";
  return job::run_log_job(ctx, recording, o, hooks, ranks);
}

}  // namespace potmap
