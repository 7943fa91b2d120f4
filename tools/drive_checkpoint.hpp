#pragma once
// `potmap mapping DRIVE`'s run totals and checkpoints: the DriveMapper's state with the run's
// record and totals as its extra bytes, one file replaced atomically, so that a run killed at
// any keyframe continues with `--resume` and ends with the summary of an uninterrupted one.
#include <nlohmann/json.hpp>

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "drive_mapping.hpp"
#include "potmap/data/drive.hpp"
#include "potmap/learn/drive_mapper.hpp"

namespace potmap::cli {

/// Sums over the keyframes mapped so far.
struct DriveRun {
  nlohmann::json record;  ///< what a resumed run must match (the drive and every option)
  std::size_t keyframes = 0;
  double label_ms = 0, transfer_ms = 0, update_ms = 0, max_ms = 0;
  std::size_t peak_bytes = 0;
  std::vector<double> positions;  ///< sensor positions, x y z a keyframe (the band's heights)
  std::vector<double> memory_mb, keyframe_ms;  ///< the mapper's memory and time, a keyframe
  void add(const KeyframeStats& st, const std::array<double, 12>& pose);
};

/// The record of a run: the drive (its poses file's size and its keyframe count) and every
/// option that changes the map.
nlohmann::json drive_run_record(const DriveMappingArgs& a, const Drive& drive,
                                const DriveMapperOptions& options);

/// Writes the mapper and the run to `path`; `next` is the first keyframe not yet mapped.
void write_drive_checkpoint(const std::string& path, const DriveRun& run, const DriveMapper& mapper,
                            std::size_t next);

/// Restores `mapper` and `run` from `path` (written by the same command and options: throws
/// ArgumentError naming each option that differs) and returns the next keyframe.
std::size_t read_drive_checkpoint(const std::string& path, DriveRun& run, DriveMapper& mapper);

}  // namespace potmap::cli
