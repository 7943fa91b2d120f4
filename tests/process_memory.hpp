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
#elif defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
#include <malloc.h>
#define POTMAP_TEST_MALLINFO2 1
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

/// What a growth bound measures: the heap bytes allocated and not yet freed, whoever allocated
/// them (the OpenCL driver's too), where the allocator says: under AddressSanitizer its own
/// count (its quarantine keeps freed memory resident on purpose and its shadow grows with every
/// address touched), with glibc mallinfo2() (in use in every arena, and the blocks it mapped
/// alone). The resident set elsewhere: there freed memory stays resident in the arenas of the
/// driver's threads, and 150 mapper cycles moved it by -3.9 to +3.8 MB with no leak. A leak
/// grows all three.
inline std::size_t memory_in_use() {
#if defined(POTMAP_TEST_ASAN)
  return __sanitizer_get_current_allocated_bytes();
#elif defined(POTMAP_TEST_MALLINFO2)
  const struct mallinfo2 m = mallinfo2();
  return m.uordblks + m.hblkhd;
#else
  return resident_bytes();
#endif
}

/// What memory_in_use() measures, for messages.
inline const char* memory_in_use_name() {
#if defined(POTMAP_TEST_ASAN)
  return "live heap (ASan)";
#elif defined(POTMAP_TEST_MALLINFO2)
  return "live heap (mallinfo2)";
#else
  return "resident memory";
#endif
}

}  // namespace potmap::test
