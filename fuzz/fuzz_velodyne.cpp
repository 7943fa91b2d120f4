#include "fuzz_input.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string p = potmap::fuzz::write_input(data, size, ".bin");
  potmap::LabelOptions o;
  o.free_per_metre = 0.01;
  try {
    potmap::LabelledSplit out;
    potmap::label_scan(potmap::read_kitti_bin(p, 50), 0, o, out);
    potmap::slice_2d(potmap::read_kitti_bin(p), -1, 1);
  } catch (const potmap::Error&) {
  }
  try {
    potmap::read_nuscenes_bin(p);
  } catch (const potmap::Error&) {
  }
  return 0;
}
