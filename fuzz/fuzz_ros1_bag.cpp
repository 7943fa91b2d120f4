#include "fuzz_input.hpp"
#include "potmap/data/bag.hpp"
#include "potmap/error.hpp"

// The bytes as a ROS 1 bag: librosbag_storage parses the records and chunks, potmap decodes the
// messages, finds their poses and turns them into scans.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string p = potmap::fuzz::write_input(data, size, ".bag");
  try {
    potmap::summarise_bag(p);
    potmap::read_bag(p);
  } catch (const potmap::Error&) {
  }
  return 0;
}
