#include "progress.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "interrupt.hpp"
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

void print_scans(job::MapJob& job, bool verbose, const std::string& label) {
  std::function<void(double)> bar = verbose ? nullptr : terminal_progress(label);
  job.after_scan = [verbose, label, bar](std::size_t, std::size_t done, std::size_t total,
                                         const std::string& line) {
    if (verbose)
      std::fprintf(stderr, "%s: %s\n", label.c_str(), line.c_str());
    else if (bar)
      bar(double(done) / double(total));
  };
  job.note = [label](const std::string& line) {
    std::fprintf(stderr, "%s: %s\n", label.c_str(), line.c_str());
  };
}

namespace {

// A mapping job's progress as `potmap mapping` prints it, stage by stage.
struct PrintedProgress {
  bool quiet = false;
  std::string stage;
  std::function<void(double)> bar;
  std::size_t next_line = 0;
  void operator()(const JobProgress& p) {
    stop_if_interrupted();
    if (p.stage == "export") return;  // the map so far, between keyframes: its note suffices
    if (p.stage != stage) {
      stage = p.stage;
      bar = p.unit == "share" ? stage_progress(p.stage, quiet) : terminal_progress(p.stage);
      next_line = 0;
    }
    if (bar) return bar(p.fraction());
    if (quiet || p.detail.empty() || p.done < next_line) return;
    // A keyframe's line every tenth of the drive; a scan's every scan (2D logs are short).
    next_line = p.unit == "keyframe" ? p.done + std::max<std::size_t>(1, p.total / 10) : 0;
    const double f = p.fraction(), el = p.elapsed_s;
    std::fprintf(stderr, "potmap: %s (%zu of %zu, %.0f%%); elapsed %.0f s, ETA %.0f s\n",
                 p.detail.c_str(), p.done, p.total, 100 * f, el, f > 0 ? el * (1 - f) / f : 0.0);
  }
};

}  // namespace

MappingJobHooks printing_hooks(std::FILE* human, bool quiet) {
  MappingJobHooks h;
  h.note = [human](const std::string& line) { std::fprintf(human, "%s\n", line.c_str()); };
  auto printed = std::make_shared<PrintedProgress>();
  printed->quiet = quiet;
  h.progress = [printed](const JobProgress& p) { (*printed)(p); };
  return h;
}

void list_job_files(const MappingJobResult& r, const std::string& json, std::FILE* human) {
  if (json == "-") std::printf("%s\n", r.scores_json.c_str());
  std::fprintf(human, "files:\n");
  for (const auto& f : r.files) std::fprintf(human, "               %s\n", f.c_str());
}

}  // namespace potmap::cli
