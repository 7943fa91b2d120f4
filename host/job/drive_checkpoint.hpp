#pragma once
// `potmap mapping DRIVE`'s run totals and checkpoints: the DriveMapper's state with the run's
// record and totals as its extra bytes, one file replaced atomically, so that a run killed at
// any keyframe continues with `--resume` and ends with the summary of an uninterrupted one.
#include <nlohmann/json.hpp>

#include <array>
#include <cstddef>
#include <future>
#include <string>
#include <vector>

#include "potmap/data/drive.hpp"
#include "potmap/job/mapping_job.hpp"
#include "potmap/mapping/drive_mapper.hpp"

namespace potmap::job {

/// Sums over the keyframes mapped so far.
struct DriveRun {
  nlohmann::json record;  ///< what a resumed run must match (the drive and every option)
  std::size_t keyframes = 0;
  double label_ms = 0, transfer_ms = 0, update_ms = 0, max_ms = 0;
  double lookahead_ms = 0;  ///< --lookahead's scoring, outside the keyframes' times
  std::size_t peak_bytes = 0;
  std::vector<double> positions;  ///< sensor positions, x y z a keyframe (the band's heights)
  std::vector<double> memory_mb, keyframe_ms;  ///< the mapper's memory and time, a keyframe
  void add(const KeyframeStats& st, const std::array<double, 12>& pose);
};

/// The record of a run: the drive (its poses file's size and its keyframe count) and every
/// option that changes the map.
nlohmann::json drive_run_record(const std::string& recording, const MappingJobOptions& a,
                                const Drive& drive, const DriveMapperOptions& options);

/// Checkpoints written beside the mapping: the mapper's state and the run are copied into bytes
/// at once (the mapper goes on), and the file is written, synced and renamed into place on a
/// thread of its own, one at a time (a state of a city drive's mapper is a few hundred MB: the
/// disk took about as long as a keyframe, every checkpoint).
class DriveCheckpoints {
 public:
  DriveCheckpoints() = default;
  DriveCheckpoints(const DriveCheckpoints&) = delete;
  DriveCheckpoints& operator=(const DriveCheckpoints&) = delete;
  /// Waits for a write still going (an interrupted run keeps its checkpoint whole).
  ~DriveCheckpoints();
  /// Waits for the previous write (rethrowing its error), then starts writing the mapper and
  /// the run to `path`; `next` is the first keyframe not yet mapped.
  void write(const std::string& path, const DriveRun& run, const DriveMapper& mapper,
             std::size_t next);
  /// Waits for the write going, if any; rethrows its error.
  void wait();

 private:
  std::future<void> pending_;
};

/// Restores `mapper` and `run` from `path` (written by the same command and options: throws
/// ArgumentError naming each option that differs) and returns the next keyframe.
std::size_t read_drive_checkpoint(const std::string& path, DriveRun& run, DriveMapper& mapper);

}  // namespace potmap::job
