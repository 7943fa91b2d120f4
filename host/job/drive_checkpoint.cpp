#include "drive_checkpoint.hpp"

#include "job_text.hpp"

#include <algorithm>
#include <filesystem>

#include "map_checkpoint.hpp"
#include "potmap/error.hpp"
#include "potmap/pot/fingerprint.hpp"

namespace potmap::job {

void DriveRun::add(const KeyframeStats& st, const std::array<double, 12>& pose) {
  ++keyframes;
  label_ms += st.label_ms;
  transfer_ms += st.transfer_ms;
  lookahead_ms += st.lookahead_ms;
  update_ms += st.update_ms;
  const double ms = st.label_ms + st.transfer_ms + st.update_ms;
  max_ms = std::max(max_ms, ms);
  peak_bytes = std::max(peak_bytes, st.memory_bytes);
  positions.insert(positions.end(), {pose[3], pose[7], pose[11]});
  memory_mb.push_back(double(st.memory_bytes) / 1e6);
  keyframe_ms.push_back(ms);
}

nlohmann::json drive_run_record(const std::string& recording, const MappingJobOptions& a,
                                const Drive& drive, const DriveMapperOptions& options) {
  std::error_code ec;
  const auto poses_bytes = std::filesystem::file_size(drive.poses_file, ec);
  nlohmann::json r = {
      {"drive", std::filesystem::absolute(recording).lexically_normal().string()},
      {"poses", drive.poses_file},
      {"poses_bytes", ec ? 0 : std::uint64_t(poses_bytes)},
      {"keyframes_in_drive", drive.size()},
      {"--first", a.first},
      {"--range-cut", a.range_cut},
      {"--seed", a.seed},
      {"--method", a.method},
      {"--transfer-every", a.transfer_every},
      {"dictionary",
       options.dictionary ? std::to_string(fingerprint(*options.dictionary)) : std::string()}};
  // Only when set: checkpoints of runs that never forget keep their record.
  if (a.half_life > 0) r["--half-life"] = a.half_life;
  if (a.lookahead) r["--lookahead"] = true;
  return r;
}

DriveCheckpoints::~DriveCheckpoints() {
  if (pending_.valid()) pending_.wait();
}

void DriveCheckpoints::wait() {
  if (pending_.valid()) pending_.get();
}

void DriveCheckpoints::write(const std::string& path, const DriveRun& run,
                             const DriveMapper& mapper, std::size_t next) {
  wait();
  const nlohmann::json extra = {{"record", run.record},
                                {"next", next},
                                {"keyframes", run.keyframes},
                                {"label_ms", run.label_ms},
                                {"update_ms", run.update_ms},
                                {"transfer_ms", run.transfer_ms},
                                {"lookahead_ms", run.lookahead_ms},
                                {"max_ms", run.max_ms},
                                {"peak_bytes", run.peak_bytes},
                                {"positions", run.positions},
                                {"memory_mb", run.memory_mb},
                                {"keyframe_ms", run.keyframe_ms}};
  remove_stale_temporaries(path);
  pending_ = std::async(std::launch::async, [path, bytes = mapper.state_bytes(extra.dump())] {
    write_text_atomically(path, bytes);
  });
}

std::size_t read_drive_checkpoint(const std::string& path, DriveRun& run, DriveMapper& mapper) {
  nlohmann::json extra;
  try {
    // The run's record first: a changed option is named, not reported as a fingerprint.
    extra = nlohmann::json::parse(DriveMapper::state_extra(path));
    check_same_run(path, extra.at("record"), run.record);
    DriveMapper restored(mapper.options());
    restored.load_state(path);
    DriveRun r;
    r.record = run.record;
    r.keyframes = extra.at("keyframes");
    r.label_ms = extra.at("label_ms");
    r.update_ms = extra.at("update_ms");
    r.transfer_ms = extra.value("transfer_ms", 0.0);
    r.lookahead_ms = extra.value("lookahead_ms", 0.0);
    r.max_ms = extra.at("max_ms");
    r.peak_bytes = extra.at("peak_bytes");
    r.positions = extra.at("positions").get<std::vector<double>>();
    r.memory_mb = extra.at("memory_mb").get<std::vector<double>>();
    r.keyframe_ms = extra.at("keyframe_ms").get<std::vector<double>>();
    const std::size_t next = extra.at("next");
    run = std::move(r);
    mapper = std::move(restored);
    return next;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path + ": the run's record is damaged: " + e.what());
  }
}

}  // namespace potmap::job
