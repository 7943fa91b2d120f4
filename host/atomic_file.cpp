#include "atomic_file.hpp"

#include <stdlib.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include "potmap/error.hpp"

namespace potmap::detail {

namespace {
std::string errno_text() {
  return std::strerror(errno);
}
}  // namespace

AtomicFile::AtomicFile(const std::string& path) : path_(path) {
  std::string templ = path + ".tmp-XXXXXX";
  std::vector<char> buf(templ.begin(), templ.end());
  buf.push_back('\0');
  const int fd = ::mkstemp(buf.data());
  if (fd < 0) throw Error("cannot create " + path + ": " + errno_text());
  temp_ = buf.data();
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
  if (std::fwrite(data, 1, n, file_) != n)
    throw Error("cannot write " + path_ + ": " + errno_text());
}

void AtomicFile::commit() {
  if (done_) return;
  bool ok = std::fflush(file_) == 0 && !std::ferror(file_);
  std::string why = ok ? "" : errno_text();
  // fsync before rename: otherwise a crash could leave the final name pointing at an empty file.
  if (ok && ::fsync(::fileno(file_)) != 0 && errno != EINVAL) {
    ok = false;
    why = errno_text();
  }
  if (std::fclose(file_) != 0 && ok) {
    ok = false;
    why = errno_text();
  }
  file_ = nullptr;
  if (ok && std::rename(temp_.c_str(), path_.c_str()) != 0) {
    ok = false;
    why = errno_text();
  }
  if (!ok) {
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
