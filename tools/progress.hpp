#pragma once
// Small helpers shared by the subcommands.
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

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

/// Writes text to path through a temporary file in the same folder and a rename, the folder
/// made first when it does not exist yet; throws potmap::Error naming the file on failure (and
/// leaves nothing behind).
void write_text_atomically(const std::string& path, const std::string& text);

/// The end of a mapping command: `summary` gets the list of `files` (with DIR/scores.json, which
/// it is written to, atomically), is printed on stdout when `json` is "-", and the files are
/// listed on `human`.
void write_scores_and_list(const std::string& dir, nlohmann::json summary,
                           std::vector<std::string> files, const std::string& json,
                           std::FILE* human);

}  // namespace potmap::cli
