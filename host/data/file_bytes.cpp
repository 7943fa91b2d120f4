#include "data/file_bytes.hpp"

#include <zlib.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include "potmap/error.hpp"

namespace potmap::data {

namespace {
std::string gunzip(const std::string& path, const std::string& in) {
  z_stream zs{};
  // 16 + MAX_WBITS: gzip header; concatenated members are handled by the loop below.
  if (inflateInit2(&zs, 16 + MAX_WBITS) != Z_OK) throw InputError(path + ": cannot start gunzip");
  std::string out;
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  zs.avail_in = static_cast<uInt>(in.size());
  char buf[1 << 16];
  int rc = Z_OK;
  while (true) {
    zs.next_out = reinterpret_cast<Bytef*>(buf);
    zs.avail_out = sizeof buf;
    rc = inflate(&zs, Z_NO_FLUSH);
    out.append(buf, sizeof buf - zs.avail_out);
    if (rc == Z_STREAM_END) {
      if (zs.avail_in == 0) break;
      inflateReset(&zs);
      continue;
    }
    if (rc != Z_OK) {
      const std::size_t off = zs.total_in;
      const std::string msg = zs.msg ? zs.msg : "zlib error " + std::to_string(rc);
      inflateEnd(&zs);
      throw InputError(path + ": byte " + std::to_string(off) + ": corrupt gzip stream (" + msg +
                       ")");
    }
    if (zs.avail_in == 0 && zs.avail_out != 0) {
      const std::size_t off = zs.total_in;
      inflateEnd(&zs);
      throw InputError(path + ": byte " + std::to_string(off) + ": truncated gzip stream");
    }
  }
  inflateEnd(&zs);
  return out;
}
}  // namespace

std::string read_file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path + ": cannot open file");
  std::ostringstream ss;
  ss << f.rdbuf();
  std::string bytes = ss.str();
  if (bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0x1f &&
      static_cast<unsigned char>(bytes[1]) == 0x8b)
    return gunzip(path, bytes);
  return bytes;
}

bool file_exists(const std::string& path, const std::string& where) {
  std::error_code ec;
  const bool found = std::filesystem::exists(path, ec);
  if (ec) throw InputError(where + ": cannot look up " + path + ": " + ec.message());
  return found;
}

}  // namespace potmap::data
