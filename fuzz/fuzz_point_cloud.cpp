#include "fuzz_input.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

// The same bytes as a PCD and as a PLY file: PCL parses them, potmap checks the header and the
// fields, and a frame that reads is labelled so that its points are used.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  potmap::LabelOptions o;
  o.free_per_metre = 0.01;
  for (const char* suffix : {".pcd", ".ply"}) {
    const std::string p = potmap::fuzz::write_input(data, size, suffix);
    try {
      potmap::LabelledSplit out;
      potmap::label_scan(potmap::read_point_cloud(p, 50), 0, o, out);
    } catch (const potmap::Error&) {
    }
  }
  return 0;
}
