#include "runtime/binary_cache.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <thread>

#include <unistd.h>

#include "runtime/hash.hpp"

namespace fs = std::filesystem;

namespace potmap::detail {

namespace {
constexpr char kMagic[] = "POTMAP-CL-BINARY-1\n";

void warn_disabled(const std::string& dir, const std::string& why) {
  std::cerr << "potmap: warning: kernel binary cache at '" << dir << "' disabled: " << why << "\n";
}
}  // namespace

BinaryCache::BinaryCache(std::string dir) : dir_(std::move(dir)) {
  if (dir_.empty()) return;
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_)) {
    warn_disabled(dir_, ec ? ec.message() : "not a directory");
    return;
  }
  // Probe writability now so that a read-only folder costs one warning, not one per build.
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
  std::ifstream f(path_for(key), std::ios::binary);
  if (!f) return std::nullopt;
  std::string magic(sizeof kMagic - 1, '\0');
  if (!f.read(magic.data(), magic.size()) || magic != kMagic) return std::nullopt;
  std::uint64_t key_len = 0, bin_len = 0;
  if (!f.read(reinterpret_cast<char*>(&key_len), sizeof key_len) || key_len != key.size())
    return std::nullopt;
  std::string stored(key_len, '\0');
  if (!f.read(stored.data(), key_len) || stored != key) return std::nullopt;
  if (!f.read(reinterpret_cast<char*>(&bin_len), sizeof bin_len) || bin_len == 0 ||
      bin_len > (std::uint64_t(1) << 31))
    return std::nullopt;
  std::vector<unsigned char> bin(bin_len);
  if (!f.read(reinterpret_cast<char*>(bin.data()), bin_len)) return std::nullopt;
  return bin;
}

void BinaryCache::store(const std::string& key, const std::vector<unsigned char>& binary) {
  if (!enabled_ || binary.empty()) return;
  const std::string path = path_for(key);
  // Unique per process and thread, so concurrent writers never share a temporary file.
  const std::string tmp = path + ".tmp." + std::to_string(::getpid()) + "." +
                          std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id()));
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    const std::uint64_t key_len = key.size(), bin_len = binary.size();
    f.write(kMagic, sizeof kMagic - 1);
    f.write(reinterpret_cast<const char*>(&key_len), sizeof key_len);
    f.write(key.data(), key.size());
    f.write(reinterpret_cast<const char*>(&bin_len), sizeof bin_len);
    f.write(reinterpret_cast<const char*>(binary.data()), binary.size());
    if (!f.flush()) {
      std::error_code ec;
      fs::remove(tmp, ec);
      warn_disabled(dir_, "write failed");
      enabled_ = false;
      return;
    }
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    warn_disabled(dir_, "rename failed");
    enabled_ = false;
  }
}

void BinaryCache::forget(const std::string& key) {
  if (!enabled_) return;
  std::error_code ec;
  fs::remove(path_for(key), ec);
}

}  // namespace potmap::detail
