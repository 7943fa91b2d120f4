#include "io/file_util.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "io/atomic_file.hpp"
#include "potmap/error.hpp"

namespace potmap::detail {

void write_file_atomically(const std::string& path, const std::string& bytes) {
  AtomicFile f(path);
  f.write(bytes.data(), bytes.size());
  f.commit();
}

std::string read_whole_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path + ": is a directory, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open: " + std::strerror(errno));
  // One read of the size the file has (raster tiles, maps and dictionaries are megabytes);
  // whatever a growing or special file gives beyond it is appended.
  std::string bytes;
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && size > 0) {
    bytes.resize(size);
    in.read(bytes.data(), std::streamsize(size));
    bytes.resize(std::size_t(in.gcount()));
    if (in.bad()) throw InputError(path + ": read error");
    // The usual case: the whole file in that one read, nothing after it (no second copy).
    if (std::size_t(in.gcount()) < size || in.peek() == std::char_traits<char>::eof()) return bytes;
  }
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw InputError(path + ": read error");
  return bytes + s.str();
}

}  // namespace potmap::detail
