#include "fuzz_input.hpp"
#include "potmap/runtime/context.hpp"
#include "potmap/runtime/tuning_file.hpp"

// The reader never throws: every input is used, ignored as stale or ignored as corrupt. The
// device is fixed, so that the seed (run_fuzzers.sh) names it and the fuzzer gets past the keys.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  potmap::DeviceInfo device;
  device.platform = "P";
  device.platform_version = "V";
  device.name = "D";
  device.driver_version = "1";
  const std::string path = potmap::fuzz::write_input(data, size, ".tuning");
  potmap::read_tuning_file(path, device, potmap::Tuning{});
  return 0;
}
