#pragma once
// The mapping job: a recording of any kind mapped into a folder with every output and its
// scores. `potmap mapping`, Python's potmap.map_recording() and C++ users run this one job, so
// they write the same files with the same scores.
//
// A 2D log (CARMEN, a ROS bag of laser scans) is mapped by RePOT (or POT) with the built-in
// dictionary into OUT/map.potmap, the pictures OUT/map_{prob,var,kernels}.png, a ROS map
// OUT/map.yaml + map.pgm and OUT/scores.json. A 3D drive (SLAM keyframes, a KITTI sequence, a
// ROS bag of point clouds) is mapped a keyframe at a time by the joint BHM (or RePOT) into
// OUT/map.potmap, an OctoMap OUT/map.bt, the occupied voxels OUT/map_occupied.ply, a height
// band's pictures OUT/map_band_{prob,var}.png and ROS map OUT/map_band.yaml + .pgm, and
// OUT/scores.json, with checkpoints (OUT/map.ckpt) that a killed run resumes from. Every file is
// written whole or not at all (a temporary file renamed into place). The scores are those of
// every scan's or keyframe's held-out beams (20 %, never mapped) on the final map.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "potmap/data/bag_options.hpp"
#include "potmap/export.h"
#include "potmap/job/job_ranks.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// How a recording is mapped. The defaults are `potmap mapping`'s (docs/commands.md).
struct MappingJobOptions {
  /// The output folder, created with its parents. Required: an empty one throws ArgumentError.
  std::string out;
  /// "" (default: by the recording, "repot" for a 2D log, "bhm" for a 3D drive), "repot" or
  /// "pot" for 2D logs, "bhm" or "repot" (the BHM seeded by transport) for 3D drives.
  std::string method;
  /// A .potdict file of atoms (default "": the built-in dictionary of the recording's
  /// dimension, built once and cached, docs/commands.md). Unused by a drive's "bhm".
  std::string dictionary;
  /// Returns farther than this become no-returns, metres (horizontally in 3D). Default -1: 20
  /// for 2D logs (the towns' range the default dictionary's atoms are cut at), 40 for 3D drives
  /// (a car's road and the buildings beside it); 0: none.
  double range_cut = -1;
  std::size_t first = 0;      ///< scans or keyframes skipped
  std::size_t max_scans = 0;  ///< at most this many mapped (0: all)
  std::uint64_t seed = 0;     ///< labelling, hold-out and subsampling
  /// Forgetting: the persistent joint BHM's half-life, seconds of the scans' time (default 0:
  /// never). 2D: RePOT only.
  double half_life = 0;
  /// Pixels along the pictures' longer side (default 1200: a wall's two sides apart on a
  /// building-sized log, a screen's width).
  std::size_t picture_pixels = 1200;

  // 2D logs
  /// "default" (the library's MapperOptions, which map the real logs best) or "paper" (the
  /// authors' rules, MapperOptions::paper()).
  std::string preset = "default";
  /// "" (default: the preset's), "indexed" or "exhaustive" (PotRanking).
  std::string ranking;
  int rotations = 8;              ///< rotations tried per atom (default 8: every 45 degrees)
  bool seeds_yield_fully = true;  ///< RepotMapOptions::seeds_yield_fully
  double ros_resolution = 0.05;   ///< the ROS map's metres a pixel (default: ROS's usual 5 cm)

  // 3D drives
  std::string poses = "odom";  ///< "odom", "optimized" or "auto" (DriveOptions::poses)
  /// The pictures' and ROS map's height band, metres about the sensor's height (default -1.0
  /// to +0.5: from about 0.8 m above the road to a van's roof for a LIDAR on a car's roof).
  double band_low = -1.0, band_high = 0.5;
  /// Voxel edge of the OctoMap, the point cloud and the band, metres (default 0.4,
  /// DriveVolumeOptions).
  double voxel = 0.4;
  double picture_res = 0;  ///< band pictures' metres a pixel (0: from picture_pixels)
  /// A checkpoint after every N keyframes (0: not by count) and when this many seconds have
  /// passed since the last (default 30; 0: not by time); with both 0 none. A city drive's state
  /// is a few hundred MB: by count alone a fast run would copy it every second.
  std::size_t checkpoint_every = 0;
  double checkpoint_seconds = 30;
  /// Keyframes between exports of the map so far while the drive goes on (0: only at the end).
  std::size_t export_every = 0;
  std::size_t transfer_every = 4;  ///< RePOT: keyframes between transfers
  std::string sums = "auto";       ///< the joint BHM's sums: "auto", "host" or "device"
  bool resume = false;             ///< continue from OUT/map.ckpt when it is there
  bool keep_checkpoint = false;    ///< keep OUT/map.ckpt after the run
  /// Never retire far tiles, so that map.potmap carries the information form (`potmap merge`).
  bool keep_tiles = false;
  /// Score each keyframe's kept held-out samples on the map before the keyframe is added
  /// (DriveMapperOptions::lookahead; 2D logs: each scan's on RePOT's persistent map, MapJob::
  /// lookahead, in one process only): scores.json's "lookahead", on all of them and on those
  /// beyond every earlier sample's reach. Default false.
  bool lookahead = false;
  BagOptions bag;  ///< ROS bags: topic, fixed frame, poses, keyframe spacing
};

/// Where a job stands, after each scan or keyframe and each batch of output blocks.
struct JobProgress {
  std::string stage;                ///< "mapping" or "outputs"
  std::string unit;                 ///< "scan", "keyframe" or "share" (of the outputs' volume)
  std::size_t done = 0, total = 0;  ///< units done and in all (this run's: a resumed run's rest)
  double elapsed_s = 0;             ///< since the stage began
  std::string detail;               ///< the unit just done, one line ("keyframe 12: ...")
  double fraction() const { return total ? double(done) / double(total) : 1.0; }
};

/// What a job reports while it runs, and the processes it shares the work with.
struct MappingJobHooks {
  /// A line of the run's account (what is mapped, the device, a resumed checkpoint, the
  /// summary), without a newline; none when empty.
  std::function<void(const std::string& line)> note;
  /// Progress; an exception thrown from it stops the job there and propagates, every file
  /// whole (a checkpoint already written stays for `resume`).
  std::function<void(const JobProgress&)> progress;
  /// The ranks sharing the job (null: this process alone).
  JobRanks* ranks = nullptr;
  /// The built-in dictionary of dimension `dim` (2 or 3) for a job that needs one and was
  /// given none, `where` receiving its file. Default (empty): the cached file
  /// (pot/default_dictionary_file.hpp), an ArgumentError when it is not built yet. `potmap
  /// mapping` and Python build it when missing (experiments/default_dictionary.hpp).
  std::function<Dictionary(int dim, std::string* where)> default_dictionary;
};

/// What a job made.
struct MappingJobResult {
  /// False on MPI ranks other than 0: they sent their part to rank 0, which wrote the files.
  bool wrote = true;
  bool drive = false;              ///< a 3D drive (else a 2D log)
  std::vector<std::string> files;  ///< every file written, OUT/scores.json last
  Scores scores;                   ///< every held-out beam on the final map
  /// options.lookahead: the kept held-out samples on the map before their keyframe, all and
  /// those beyond every earlier sample's reach (n 0 without).
  Scores lookahead, lookahead_beyond;
  std::string scores_json;  ///< OUT/scores.json's text
};

/// Maps `recording` (any dataset potmap reads) on `ctx`'s device into options.out. Throws
/// ArgumentError for bad options (naming the option and value), InputError for unreadable input
/// (naming the file), potmap::Error when a file cannot be written; what propagates from
/// hooks.progress.
MappingJobResult run_mapping_job(Context& ctx, const std::string& recording,
                                 const MappingJobOptions& options,
                                 const MappingJobHooks& hooks = {});

/// The folder `potmap mapping` writes to when given none: out/mapping/<recording's name>.
std::string default_mapping_folder(const std::string& recording);

}  // namespace potmap
POTMAP_CXX_API_END
