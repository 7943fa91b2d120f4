#include "potmap/runtime/tuning_file.hpp"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "io/atomic_file.hpp"
#include "potmap/error.hpp"
#include "potmap/runtime/context.hpp"
#include "potmap/version.hpp"
#include "runtime/hash.hpp"

namespace fs = std::filesystem;

namespace potmap {

namespace {

constexpr const char* kHeader = "potmap-tuning 1";

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return (v && *v) ? std::string(v) : std::string();
}

// The keys a file must carry, each with the running value it must equal; a mismatch makes the
// file stale (measured on something else), not corrupt.
struct Expected {
  const char* key;
  std::string value;
};

std::vector<Expected> expected_of(const DeviceInfo& d) {
  return {{"potmap_version", POTMAP_VERSION_STRING},
          {"platform", d.platform},
          {"platform_version", d.platform_version},
          {"device", d.name},
          {"driver", d.driver_version}};
}

}  // namespace

std::string default_tuning_dir() {
  if (std::string dir = env("POTMAP_CACHE_DIR"); !dir.empty()) return dir;
  if (std::string xdg = env("XDG_CACHE_HOME"); !xdg.empty())
    return (fs::path(xdg) / "potmap").string();
  if (std::string home = env("HOME"); !home.empty())
    return (fs::path(home) / ".cache" / "potmap").string();
  return "";
}

std::string tuning_file_path(const std::string& dir, const DeviceInfo& device) {
  char name[40];
  std::snprintf(
      name, sizeof name, "tuning-%016llx.txt",
      static_cast<unsigned long long>(detail::fnv1a64(device.platform + '\n' + device.name)));
  return (fs::path(dir) / name).string();
}

void write_tuning_file(const std::string& path, const DeviceInfo& device, const Tuning& tuning) {
  validate_tuning(tuning);
  std::ostringstream text;
  text << kHeader << "\n# written by `potmap tune`; remove this file to go back to the defaults\n";
  for (const Expected& e : expected_of(device)) text << e.key << ' ' << e.value << '\n';
  text << "tuning " << to_string(tuning) << '\n';
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty()) {
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) throw Error("tuning file '" + path + "': cannot create its folder: " + ec.message());
  }
  detail::AtomicFile out(path);
  const std::string s = text.str();
  out.write(s.data(), s.size());
  out.commit();
}

TuningFileRead read_tuning_file(const std::string& path, const DeviceInfo& device,
                                const Tuning& base) {
  TuningFileRead result;
  std::error_code ec;
  if (path.empty() || !fs::exists(path, ec)) return result;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    result.problem = "cannot be opened";
    return result;
  }
  std::vector<Expected> expected = expected_of(device);
  std::vector<bool> seen(expected.size(), false);
  std::string line, spec;
  bool have_tuning = false;
  std::size_t number = 0;
  try {
    while (std::getline(in, line)) {
      ++number;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      const std::string where = "line " + std::to_string(number) + ": ";
      if (number == 1) {
        if (line != kHeader)
          throw Error(where + "'" + line.substr(0, 40) + "' is not the header '" + kHeader + "'");
        continue;
      }
      if (line.empty() || line[0] == '#') continue;
      const std::size_t sp = line.find(' ');
      const std::string key = line.substr(0, sp);
      const std::string value = sp == std::string::npos ? "" : line.substr(sp + 1);
      if (key == "tuning") {
        spec = value;
        have_tuning = true;
        continue;
      }
      bool known = false;
      for (std::size_t i = 0; i < expected.size(); ++i) {
        if (key != expected[i].key) continue;
        known = seen[i] = true;
        if (value != expected[i].value) {
          result.problem = "stale: " + where + key + " '" + value + "' is not this " +
                           (i == 0 ? "library's" : "device's") + " '" + expected[i].value +
                           "' (run `potmap tune` again)";
          return result;
        }
      }
      if (!known) throw Error(where + "unknown key '" + key + "'");
    }
    if (number == 0) throw Error("empty file");
    for (std::size_t i = 0; i < expected.size(); ++i)
      if (!seen[i]) throw Error(std::string("no '") + expected[i].key + "' line");
    if (!have_tuning) throw Error("no 'tuning' line");
    result.tuning = parse_tuning(spec, base);
  } catch (const Error& e) {
    result.problem = std::string("corrupt: ") + e.what();
    result.tuning.reset();
  }
  return result;
}

}  // namespace potmap
