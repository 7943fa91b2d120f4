#pragma once
// Small helpers shared by the subcommands.
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "potmap/job/map_job.hpp"
#include "potmap/job/mapping_job.hpp"

namespace potmap::cli {

/// Seconds from t0 to now on the steady clock.
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// A progress callback printing "potmap: <label> 42.0%  elapsed 3 s  ETA 4 s" on stderr, or an
/// empty function when stderr is not a terminal (logs and pipes get the summary only).
std::function<void(double fraction)> terminal_progress(const std::string& label);

/// A stage's progress: terminal_progress on a terminal, else (unless `quiet`) a line on stderr
/// at every tenth, "potmap: <label> 40%; elapsed 3 s, ETA 4 s", as the keyframes' lines.
std::function<void(double fraction)> stage_progress(const std::string& label, bool quiet);

/// `job`'s reports as `potmap map` and the demo print them: with `verbose` a line per scan on
/// stderr ("potmap map: scan 3/10: ..."), else a progress bar on a terminal; its notes on
/// stderr after `label` ("potmap map").
void print_scans(job::MapJob& job, bool verbose, const std::string& label);

/// A mapping job's hooks printing as `potmap mapping` does: notes on `human`; scans a line each
/// on stderr and keyframes a line every tenth (unless `quiet`), or a bar on a terminal; the
/// outputs' progress as stage_progress("outputs"); an interrupt checked at every report.
MappingJobHooks printing_hooks(std::FILE* human, bool quiet);

/// Writes text to path through a temporary file in the same folder and a rename, the folder
/// made first when it does not exist yet; throws potmap::Error naming the file on failure (and
/// leaves nothing behind).
void write_text_atomically(const std::string& path, const std::string& text);

/// The end of a mapping job on the command line: scores.json on stdout when `json` is "-", and
/// the files listed on `human`.
void list_job_files(const MappingJobResult& r, const std::string& json, std::FILE* human);

}  // namespace potmap::cli
