#pragma once
// The memory a test bounds when it checks that a long run does not grow: header-only, so that
// the suite and the C API tests (which link only the public library) share it.
#include <unistd.h>

#include <cstddef>
#include <cstdio>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define POTMAP_TEST_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) && !defined(POTMAP_TEST_ASAN)
#define POTMAP_TEST_ASAN 1
#endif
#ifdef POTMAP_TEST_ASAN
#include <sanitizer/allocator_interface.h>
#endif

namespace potmap::test {

/// Resident set size of this process, bytes (/proc/self/statm).
inline std::size_t resident_bytes() {
  std::size_t pages_total = 0, pages_resident = 0;
  if (FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%zu %zu", &pages_total, &pages_resident) != 2) pages_resident = 0;
    std::fclose(f);
  }
  return pages_resident * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
}

/// What a growth bound measures: the resident set in a normal build; under AddressSanitizer the
/// heap bytes allocated and not yet freed, whoever allocated them (the OpenCL driver's too:
/// ASan intercepts every malloc), because its quarantine keeps freed memory resident on purpose
/// and its shadow grows with every address touched, so the resident set there says nothing
/// about leaks. A leak grows both.
inline std::size_t memory_in_use() {
#ifdef POTMAP_TEST_ASAN
  return __sanitizer_get_current_allocated_bytes();
#else
  return resident_bytes();
#endif
}

/// What memory_in_use() measures, for messages.
inline const char* memory_in_use_name() {
#ifdef POTMAP_TEST_ASAN
  return "live heap (ASan)";
#else
  return "resident memory";
#endif
}

}  // namespace potmap::test
