#include "fuzz_input.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

// The input is split at its first NUL byte: calib.txt before it, poses.txt after it.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  size_t cut = 0;
  while (cut < size && data[cut] != 0) ++cut;
  const std::string calib = potmap::fuzz::write_input(data, cut, ".calib");
  const std::string poses = potmap::fuzz::write_input(data + (cut < size ? cut + 1 : size),
                                                      cut < size ? size - cut - 1 : 0, ".poses");
  try {
    potmap::read_kitti_poses(poses, calib);
  } catch (const potmap::Error&) {
  }
  return 0;
}
