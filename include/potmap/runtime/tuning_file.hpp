#pragma once
// Per-device tuning files: what `potmap tune` measured on one device, read by a Context in place
// of default_tuning(). One file per platform and device name (so that a driver update finds the
// old file and can say it is stale, rather than silently missing it); the file records the
// platform version, driver version and potmap version it was measured with, and is used only
// when all of them match the running device and library.
//
// Format (text, one `key value` pair a line, '#' starts a comment line):
//   potmap-tuning 1
//   potmap_version 0.1.0
//   platform Portable Computing Language
//   platform_version OpenCL 3.0 PoCL ...
//   device cpu-haswell-...
//   driver 5.0+debian
//   tuning map_eval.vector_width=16,...   (what parse_tuning reads; fields left out keep
//                                          the device's defaults)

#include <optional>
#include <string>

#include "potmap/export.h"
#include "potmap/runtime/tuning.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct DeviceInfo;

/// The folder of tuning files when ContextOptions::tuning_dir is empty: POTMAP_CACHE_DIR if set,
/// else $XDG_CACHE_HOME/potmap, else $HOME/.cache/potmap (the XDG default), else "" (none).
std::string default_tuning_dir();

/// Where the tuning file of `device` lives in `dir`: dir/tuning-<16 hex digits>.txt, the digits
/// a hash of the platform and device names.
std::string tuning_file_path(const std::string& dir, const DeviceInfo& device);

/// Writes `tuning` for `device` to `path` (a temporary file, then renamed into place; the folder
/// is created). Throws potmap::Error naming the file if it cannot be written, ArgumentError if
/// the tuning is invalid.
void write_tuning_file(const std::string& path, const DeviceInfo& device, const Tuning& tuning);

/// What read_tuning_file found.
struct TuningFileRead {
  /// The file's tuning (the fields it names applied over `base`); empty when the file is
  /// missing or ignored.
  std::optional<Tuning> tuning;
  /// Empty when the file was used or is missing; else why it was ignored, naming the line and
  /// value ("line 5: driver '4.0' is not this device's '5.0'"), for a warning.
  std::string problem;
};

/// Reads the tuning file `path` for `device`. A file written for another platform, device,
/// driver or potmap version (stale) or one that does not parse (corrupt) gives no tuning and
/// a problem; a missing file gives neither. Never throws.
TuningFileRead read_tuning_file(const std::string& path, const DeviceInfo& device,
                                const Tuning& base);

}  // namespace potmap
POTMAP_CXX_API_END
