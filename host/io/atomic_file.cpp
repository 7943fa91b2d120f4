#include "io/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <vector>

#include "potmap/error.hpp"

namespace potmap::detail {

namespace {
std::string errno_text() {
  return std::strerror(errno);
}
}  // namespace

void make_parent_folders(const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  if (std::filesystem::is_directory(parent, ec)) return;
  std::filesystem::create_directories(parent, ec);
  // Another process may have made it meanwhile: only a folder still missing is a failure.
  if (ec && !std::filesystem::is_directory(parent))
    throw Error("cannot create the folder " + parent.string() + ": " + ec.message());
}

AtomicFile::AtomicFile(const std::string& path) : path_(path) {
  make_parent_folders(path);
  // open(O_EXCL) with a random name rather than mkstemp: mkstemp makes the file 0600, while the
  // result should get the usual permissions (0666 less the umask), as any other output file.
  std::random_device rd;
  int fd = -1;
  for (int attempt = 0; attempt < 16 && fd < 0; ++attempt) {
    char suffix[32];
    std::snprintf(suffix, sizeof suffix, ".tmp-%ld-%08x", static_cast<long>(::getpid()), rd());
    temp_ = path + suffix;
    fd = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0 && errno != EEXIST) break;
  }
  if (fd < 0) throw Error("cannot create " + path + ": " + errno_text());
  file_ = ::fdopen(fd, "wb");
  if (!file_) {
    const std::string why = errno_text();
    ::close(fd);
    ::unlink(temp_.c_str());
    throw Error("cannot open " + path + ": " + why);
  }
}

AtomicFile::~AtomicFile() {
  discard();
}

void AtomicFile::write(const void* data, std::size_t n) {
  if (n == 0) return;
  if (!file_) throw Error("cannot write " + path_ + ": already committed or discarded");
  if (std::fwrite(data, 1, n, file_) != n)
    throw Error("cannot write " + path_ + ": " + errno_text());
  written_ += n;
  if (written_ - handed_over_ >= kWritebackBytes) start_writeback();
}

void AtomicFile::start_writeback() {
  if (std::fflush(file_) != 0) throw Error("cannot write " + path_ + ": " + errno_text());
#ifdef __linux__
  // Starts writing the pages out and returns: a hint, so its failure is not one (sync() reports
  // any write error).
  ::sync_file_range(::fileno(file_), static_cast<off64_t>(handed_over_),
                    static_cast<off64_t>(written_ - handed_over_), SYNC_FILE_RANGE_WRITE);
#endif
  handed_over_ = written_;
}

void AtomicFile::sync() {
  if (done_) throw Error("cannot write " + path_ + ": already committed or discarded");
  if (synced_) return;
  bool ok = std::fflush(file_) == 0 && !std::ferror(file_);
  std::string why = ok ? "" : errno_text();
  // fsync before rename: otherwise a crash could leave the final name pointing at an empty file.
  // EINVAL: a file (pipe, some FUSE folders) that cannot be synced, which is not a failure.
  if (ok && ::fsync(::fileno(file_)) != 0 && errno != EINVAL) {
    ok = false;
    why = errno_text();
  }
  if (!ok) {
    discard();
    throw Error("cannot write " + path_ + ": " + why);
  }
  synced_ = true;
}

void AtomicFile::commit() {
  if (done_) return;
  sync();
  std::string why;
  const int closed = std::fclose(file_);
  file_ = nullptr;
  if (closed != 0)
    why = errno_text();
  else if (std::rename(temp_.c_str(), path_.c_str()) != 0)
    why = errno_text();
  if (!why.empty()) {
    discard();
    throw Error("cannot write " + path_ + ": " + why);
  }
  done_ = true;
}

void AtomicFile::discard() noexcept {
  if (done_) return;
  if (file_) std::fclose(file_);
  file_ = nullptr;
  ::unlink(temp_.c_str());
  done_ = true;
}

}  // namespace potmap::detail
