#include <cstdio>

#include "fuzz_input.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

// The input is a poses file beside one valid frame, potmap-fuzz-frame.pcd (the seed corpus names
// it), so that the fuzzer reaches the poses past the frame lookup.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool frame_written = [] {
    if (std::FILE* f = std::fopen("/tmp/potmap-fuzz-frame.pcd", "wb")) {
      std::fputs(
          "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n"
          "POINTS 2\nDATA ascii\n1 2 3\n4 5 6\n",
          f);
      std::fclose(f);
    }
    return true;
  }();
  (void)frame_written;
  const std::string p = potmap::fuzz::write_input(data, size, ".poses.txt");
  try {
    potmap::read_point_cloud_sequence(p);
  } catch (const potmap::Error&) {
  }
  return 0;
}
