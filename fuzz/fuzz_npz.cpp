#include "fuzz_input.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string p = potmap::fuzz::write_input(data, size, ".npz");
  try {
    const potmap::LabelledPoints lp = potmap::read_npz_labelled(p);
    potmap::scans_from_labelled(lp);
  } catch (const potmap::Error&) {
  }
  return 0;
}
