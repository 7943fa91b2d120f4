#include "rank_maps.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "potmap/error.hpp"
#include "potmap/mapping/map_files.hpp"

namespace fs = std::filesystem;

namespace potmap::job {

namespace {

// A name no other process uses (the process id), removed when it goes out of scope.
struct TempPotmap {
  std::string path;
  explicit TempPotmap(const std::string& tag)
      : path((fs::temp_directory_path() /
              ("potmap-" + std::to_string(::getpid()) + "-" + tag + ".potmap"))
                 .string()) {}
  ~TempPotmap() {
    std::error_code ec;
    fs::remove(path, ec);
  }
};

}  // namespace

std::string potmap_bytes(const std::function<void(const std::string& path)>& write) {
  TempPotmap tmp("out");
  write(tmp.path);
  std::ifstream in(tmp.path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) throw Error(tmp.path + ": cannot read back the map just written");
  return bytes;
}

ReceivedMap read_potmap_bytes(const std::string& bytes, const std::string& from) {
  TempPotmap tmp("in");
  {
    std::ofstream out(tmp.path, std::ios::binary);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    if (!out.flush()) throw Error(tmp.path + ": cannot write the map " + from + " sent");
  }
  ReceivedMap m;
  try {
    m.joint = read_joint_bhm_information(tmp.path);
    if (!m.joint) m.averaged = read_averaged_map_information(tmp.path);
  } catch (const InputError& e) {
    throw InputError(from + "'s map: " + e.what());
  }
  if (!m.joint && !m.averaged)
    throw InputError(from +
                     "'s map holds neither a joint BHM's information form nor POT's "
                     "averaged sums: it cannot be merged");
  return m;
}

}  // namespace potmap::job
