#include "runtime/binary_cache.hpp"

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <iterator>
#include <thread>

#include <fcntl.h>
#include <unistd.h>

#include "runtime/hash.hpp"

namespace fs = std::filesystem;

namespace potmap::detail {

namespace {
// Version 2 added the checksum. Entries of other versions are stale, not damaged.
constexpr std::string_view kMagicStem = "POTMAP-CL-BINARY-";
constexpr std::string_view kMagic = "POTMAP-CL-BINARY-2\n";
// No driver's program binary comes near this; a length above it is a damaged header.
constexpr std::uint64_t kMaxBinary = std::uint64_t(1) << 31;

void warn_disabled(const std::string& dir, const std::string& why) {
  std::cerr << "potmap: warning: kernel binary cache at '" << dir << "' disabled: " << why << "\n";
}

void warn_entry(const std::string& path, const std::string& why) {
  std::cerr << "potmap: warning: kernel binary cache entry '" << path << "' " << why
            << "; rebuilding from source\n";
}

std::uint64_t checksum(const std::vector<unsigned char>& b) {
  return fnv1a64(std::string_view(reinterpret_cast<const char*>(b.data()), b.size()));
}

void put_u64(std::string& out, std::uint64_t v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

bool get_u64(const std::string& in, std::size_t& at, std::uint64_t& v) {
  if (in.size() - at < sizeof v) return false;
  std::copy_n(in.data() + at, sizeof v, reinterpret_cast<char*>(&v));
  at += sizeof v;
  return true;
}
}  // namespace

BinaryCache::BinaryCache(std::string dir) : dir_(std::move(dir)) {
  if (dir_.empty()) return;
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_, ec)) {
    warn_disabled(dir_, ec ? ec.message() : "not a directory");
    return;
  }
  // Probe listing and writing now, so that a folder without permissions (chmod 000 and the like)
  // costs one warning here, not one per build.
  fs::directory_iterator list(dir_, ec);
  if (ec) {
    warn_disabled(dir_, "not readable: " + ec.message());
    return;
  }
  const std::string probe = (fs::path(dir_) / ".potmap-write-probe").string();
  {
    std::ofstream f(probe, std::ios::binary);
    if (!f || !(f << "x") || !f.flush()) {
      warn_disabled(dir_, "not writable");
      return;
    }
  }
  fs::remove(probe, ec);
  enabled_ = true;
}

std::string BinaryCache::path_for(const std::string& key) const {
  char name[32];
  std::snprintf(name, sizeof name, "%016llx.clbin", static_cast<unsigned long long>(fnv1a64(key)));
  return (fs::path(dir_) / name).string();
}

std::optional<std::vector<unsigned char>> BinaryCache::load(const std::string& key) const {
  if (!enabled_) return std::nullopt;
  const std::string path = path_for(key);
  std::ifstream f(path, std::ios::binary);
  if (!f) return std::nullopt;  // no entry: the usual miss
  const std::string in((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const auto damaged = [&](const std::string& why) -> std::optional<std::vector<unsigned char>> {
    warn_entry(path, why);
    std::error_code ec;
    fs::remove(path, ec);
    return std::nullopt;
  };
  if (f.bad()) return damaged("cannot be read");
  if (in.compare(0, kMagic.size(), kMagic) != 0) {
    if (in.size() >= kMagic.size() && in.compare(0, kMagicStem.size(), kMagicStem) == 0 &&
        in[kMagicStem.size()] != kMagic[kMagicStem.size()])
      return std::nullopt;  // another version of the format: stale, replaced by the rebuild
    return damaged("is not a potmap cache entry (magic)");
  }
  std::size_t at = kMagic.size();
  std::uint64_t key_len = 0, bin_len = 0, sum = 0;
  if (!get_u64(in, at, key_len) || key_len > in.size() - at)
    return damaged("is truncated (in the key)");
  if (in.compare(at, key_len, key) != 0) return std::nullopt;  // a hash collision: a miss
  at += key_len;
  if (!get_u64(in, at, bin_len) || !get_u64(in, at, sum))
    return damaged("is truncated (in the header)");
  if (bin_len == 0 || bin_len > kMaxBinary)
    return damaged("has a binary length of " + std::to_string(bin_len));
  if (in.size() - at != bin_len)
    return damaged("holds " + std::to_string(in.size() - at) + " bytes of binary, not " +
                   std::to_string(bin_len) + " (truncated or overwritten)");
  std::vector<unsigned char> bin(in.begin() + at, in.end());
  if (checksum(bin) != sum) return damaged("fails its checksum");
  return bin;
}

void BinaryCache::store(const std::string& key, const std::vector<unsigned char>& binary) {
  if (!enabled_ || binary.empty()) return;
  const std::string path = path_for(key);
  // Unique per process and thread, so concurrent writers never share a temporary file.
  const std::string tmp = path + ".tmp." + std::to_string(::getpid()) + "." +
                          std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id()));
  std::string out;
  out.reserve(kMagic.size() + key.size() + binary.size() + 24);
  out.append(kMagic);
  put_u64(out, key.size());
  out.append(key);
  put_u64(out, binary.size());
  put_u64(out, checksum(binary));
  out.append(reinterpret_cast<const char*>(binary.data()), binary.size());
  // fsync before the rename: a crash must not leave the entry's name on missing blocks (the
  // checksum would catch it, but at the cost of a warning and a rebuild).
  std::string why;
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) {
    why = std::strerror(errno);
  } else {
    std::size_t done = 0;
    while (done < out.size() && why.empty()) {
      const ssize_t n = ::write(fd, out.data() + done, out.size() - done);
      if (n > 0)
        done += static_cast<std::size_t>(n);
      else if (n < 0 && errno != EINTR)
        why = std::strerror(errno);
    }
    if (why.empty() && ::fsync(fd) != 0 && errno != EINVAL) why = std::strerror(errno);
    if (::close(fd) != 0 && why.empty()) why = std::strerror(errno);
  }
  std::error_code ec;
  if (!why.empty()) {
    fs::remove(tmp, ec);
    warn_disabled(dir_, "cannot write " + tmp + ": " + why);
    enabled_ = false;
    return;
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    warn_disabled(dir_, "cannot rename " + tmp + ": " + ec.message());
    enabled_ = false;
  }
}

void BinaryCache::reject(const std::string& key, const std::string& why) {
  if (!enabled_) return;
  const std::string path = path_for(key);
  warn_entry(path, "was rejected by the driver (" + why + ")");
  std::error_code ec;
  fs::remove(path, ec);
}

}  // namespace potmap::detail
