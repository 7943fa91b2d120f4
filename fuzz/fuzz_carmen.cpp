#include "fuzz_input.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string p = potmap::fuzz::write_input(data, size, ".log");
  try {
    const potmap::Dataset ds = potmap::read_carmen(p);
    potmap::LabelOptions o;
    o.free_per_metre = 0.01;  // bound the work per input; the reader is what is fuzzed
    if (ds.scans.size() < 50) potmap::label_scans(ds.scans, o);
  } catch (const potmap::Error&) {
  }
  return 0;
}
