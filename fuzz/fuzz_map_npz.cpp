// Map reader (.npz) on arbitrary bytes: any outcome but a crash or a sanitizer report is fine.
#include "fuzz_input.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string p = potmap::fuzz::write_input(data, size, ".npz");
  try {
    potmap::read_map(p).validate();
  } catch (const potmap::Error&) {
  }
  return 0;
}
