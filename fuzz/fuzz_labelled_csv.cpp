// Labelled-point CSV reader on arbitrary bytes.
#include "fuzz_input.hpp"
#include "potmap/data/labelled_points.hpp"
#include "potmap/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string p = potmap::fuzz::write_input(data, size, ".csv");
  try {
    potmap::read_labelled_csv(p);
  } catch (const potmap::Error&) {
  }
  return 0;
}
