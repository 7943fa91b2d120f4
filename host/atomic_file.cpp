#include "atomic_file.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "potmap/error.hpp"

namespace fs = std::filesystem;

namespace potmap::detail {

AtomicFile::AtomicFile(const std::string& path) : path_(path) {
  // A random suffix (not a process-wide counter) keeps concurrent writers, in this process or
  // another, from sharing a temporary; "x" makes fopen fail rather than reuse an existing file.
  std::random_device rd;
  for (int attempt = 0; attempt < 16 && !file_; ++attempt) {
    std::ostringstream name;
    name << path << ".tmp-" << ::getpid() << "-" << std::hex << rd();
    temp_ = name.str();
    file_ = std::fopen(temp_.c_str(), "wbx");
    if (!file_ && errno != EEXIST) break;
  }
  if (!file_)
    throw Error("cannot create temporary file '" + temp_ + "' to write '" + path +
                "': " + std::strerror(errno));
}

AtomicFile::~AtomicFile() {
  if (file_) std::fclose(file_);
  if (!committed_) std::remove(temp_.c_str());
}

void AtomicFile::fail(const std::string& what) {
  const std::string reason = std::strerror(errno);
  if (file_) std::fclose(file_);
  file_ = nullptr;
  std::remove(temp_.c_str());
  throw Error("writing '" + path_ + "': " + what + ": " + reason);
}

void AtomicFile::write(const void* data, std::size_t size) {
  if (!file_) throw Error("writing '" + path_ + "': file already closed");
  if (size && std::fwrite(data, 1, size, file_) != size) fail("write failed");
}

void AtomicFile::commit() {
  if (!file_) throw Error("writing '" + path_ + "': file already closed");
  if (std::fflush(file_) != 0) fail("flush failed");
  // fsync so that a crash right after the rename cannot leave an empty destination.
  if (::fsync(::fileno(file_)) != 0 && errno != EINVAL) fail("fsync failed");
  const int rc = std::fclose(file_);
  file_ = nullptr;
  if (rc != 0) fail("close failed");
  if (std::rename(temp_.c_str(), path_.c_str()) != 0) fail("rename from '" + temp_ + "' failed");
  committed_ = true;
}

void write_file_atomically(const std::string& path, const std::string& bytes) {
  AtomicFile f(path);
  f.write(bytes);
  f.commit();
}

std::string read_whole_file(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InputError("'" + path + "' is a directory, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot open '" + path + "': " + std::strerror(errno));
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw InputError("error reading '" + path + "'");
  return s.str();
}

}  // namespace potmap::detail
