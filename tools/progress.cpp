#include "progress.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "potmap/error.hpp"

namespace potmap::cli {

std::function<void(double)> terminal_progress(const std::string& label) {
  if (!::isatty(::fileno(stderr))) return {};
  const auto start = std::chrono::steady_clock::now();
  return [start, label](double f) {
    const double el = seconds_since(start);
    const double eta = f > 0 ? el * (1 - f) / f : 0;
    std::fprintf(stderr, "\rpotmap: %s %5.1f%%  elapsed %.0f s  ETA %.0f s   ", label.c_str(),
                 100 * f, el, eta);
    if (f >= 1) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  };
}

std::function<void(double)> stage_progress(const std::string& label, bool quiet) {
  if (auto bar = terminal_progress(label)) return bar;
  if (quiet) return {};
  const auto start = std::chrono::steady_clock::now();
  auto next = std::make_shared<double>(0.1);
  return [start, label, next](double f) {
    if (f < *next && f < 1) return;
    while (*next <= f) *next += 0.1;
    const double el = seconds_since(start);
    std::fprintf(stderr, "potmap: %s %.0f%%; elapsed %.0f s, ETA %.0f s\n", label.c_str(), 100 * f,
                 el, f > 0 ? el * (1 - f) / f : 0.0);
  };
}

void write_text_atomically(const std::string& path, const std::string& text) {
  // The library's AtomicFile is private to it; this is the same sequence for the command's own
  // JSON: every write checked, fsync before the rename, the temporary file removed on failure.
  const std::string tmp = path + ".tmp-" + std::to_string(::getpid());
  // The folder too, when the file is the first written into it (as AtomicFile does).
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code made;
  if (!parent.empty()) std::filesystem::create_directories(parent, made);
  const auto fail = [&](const char* what) {
    const std::string why = std::strerror(errno);
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw Error("cannot write " + path + ": " + what + ": " + why);
  };
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) fail("cannot create the temporary file");
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      ::close(fd);
      fail("write");
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0 && errno != EINVAL) {
    ::close(fd);
    fail("fsync");
  }
  if (::close(fd) != 0) fail("close");
  if (std::rename(tmp.c_str(), path.c_str()) != 0) fail("rename");
}

void write_scores_and_list(const std::string& dir, nlohmann::json summary,
                           std::vector<std::string> files, const std::string& json,
                           std::FILE* human) {
  const std::string scores = (std::filesystem::path(dir) / "scores.json").string();
  files.push_back(scores);
  summary["files"] = files;
  write_text_atomically(scores, summary.dump(1) + "\n");
  if (json == "-") std::printf("%s\n", summary.dump(1).c_str());
  std::fprintf(human, "files:\n");
  for (const auto& f : files) std::fprintf(human, "               %s\n", f.c_str());
}

}  // namespace potmap::cli
