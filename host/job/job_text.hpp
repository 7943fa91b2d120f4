#pragma once
// Small helpers of the mapping job's files: lines of its account formatted as printf does,
// text files written whole, wall-clock seconds.
#include <chrono>
#include <string>

namespace potmap::job {

/// Seconds from t0 to now on the steady clock.
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// printf's formatting into a string (the job's lines keep the command's column layout).
std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));

/// Writes `text` to `path` through a temporary file renamed into place (io/atomic_file.hpp);
/// throws potmap::Error naming the file on failure, leaving nothing behind.
void write_text_atomically(const std::string& path, const std::string& text);

}  // namespace potmap::job
