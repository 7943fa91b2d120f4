#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "potmap/data/drive.hpp"
#include "potmap/error.hpp"

// A drive folder of one keyframe: the input is split at its first NUL byte, odom_poses.txt
// before it, times.txt after it; the folder is indexed and its keyframe read when it has one.
namespace {

void write(const std::string& path, const uint8_t* data, size_t size) {
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return;
  std::fwrite(data, 1, size, f);
  std::fclose(f);
}

std::string make_folder() {
  const std::string dir = "/tmp/potmap-fuzz-drive-" + std::to_string(long(getpid()));
  std::filesystem::create_directories(dir + "/Scans");
  const std::string pcd =
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n"
      "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6\n";
  write(dir + "/Scans/000000.pcd", reinterpret_cast<const uint8_t*>(pcd.data()), pcd.size());
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = make_folder();
  size_t cut = 0;
  while (cut < size && data[cut] != 0) ++cut;
  write(dir + "/odom_poses.txt", data, cut);
  write(dir + "/times.txt", data + (cut < size ? cut + 1 : size), cut < size ? size - cut - 1 : 0);
  try {
    const potmap::Drive d = potmap::open_drive(dir);
    if (d.size() == 1) potmap::read_keyframe(d, 0);
  } catch (const potmap::Error&) {
  }
  return 0;
}
