// Dictionary reader (.potdict) on arbitrary bytes: any outcome but a crash or a sanitizer report
// is fine. The checksum stops most random inputs early, so the seed corpus holds a valid file
// and libFuzzer's CRC-aware mutations (-use_cmp) carry it past; a second pass re-checks what the
// reader accepted.
#include "fuzz_input.hpp"
#include "potmap/error.hpp"
#include "potmap/pot/dictionary_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string p = potmap::fuzz::write_input(data, size, ".potdict");
  try {
    const potmap::Dictionary d = potmap::read_dictionary(p);
    potmap::validate_dictionary(d);
  } catch (const potmap::Error&) {
  }
  return 0;
}
