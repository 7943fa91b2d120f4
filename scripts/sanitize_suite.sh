#!/usr/bin/env bash
# The whole test suite under AddressSanitizer + UndefinedBehaviorSanitizer + LeakSanitizer: the
# library, the potmap command, the GoogleTest suite (potmap_tests) and the C API tests, built
# with clang in the fuzzers' build folder (scripts/sanitizer_build.sh: the instrumented library
# is compiled once for both), every test in its own process, run by CTest in parallel.
#
# Sizes: instrumented, the library runs 3 to 30 times slower (UBSan's checks keep Eigen from
# inlining; the fuzzers' coverage hooks count every branch), so the run sets
# POTMAP_TEST_INPUTS=small: the tests that map whole logs, thousands of atoms or whole frames
# take fewer scans, atoms or points, with their bars measured at that size (tests/test_support.hpp,
# docs/sanitizers.md). POTMAP_SANITIZE_SUITE=full runs the full sizes (about an hour on 2 cores).
# Memory bounds: under ASan the long-run tests bound the live heap instead of the resident set
# (tests/process_memory.hpp: ASan's quarantine keeps freed memory resident on purpose).
# Left out, with the reason:
#   python_*          the interpreter is not instrumented (ASan must be first in the process);
#                     the module is the library's code, which every other test here reaches.
#   install_consumer, abi_exports  packaging and the shared library's symbols, not memory
#                     safety (this build links the static library).
# The tests under mpirun (raster_mpi_ranks, raster_mpi_band, mapping_mpi_ranks) run on their own
# afterwards without LeakSanitizer (ASan and UBSan still check every access): Open MPI's runtime
# and its plug-ins keep allocations to exit, and the plug-ins are unloaded by then, so
# LeakSanitizer cannot name (or suppress) them.
# LeakSanitizer suppressions: scripts/lsan-opencl.supp (the OpenCL driver only, never potmap).
# Usage: scripts/sanitize_suite.sh [BUILD_DIR]   (extra ctest flags in POTMAP_SANITIZE_ARGS)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build-fuzz}
# shellcheck source=scripts/sanitizer_build.sh
source "$root/scripts/sanitizer_build.sh"
sanitizer_configure "$root" "$build"
cmake --build "$build" -j"$(nproc)" --target potmap_tests potmap_capi_tests potmap_cli >/dev/null

mpi_tests='^(raster_mpi_ranks|raster_mpi_band|mapping_mpi_ranks)$'
exclude='^(python_|install_consumer$|abi_exports$|raster_mpi_ranks$|raster_mpi_band$|mapping_mpi_ranks$)'
# The built-in default dictionary (the MappingCli tests' fixture, default_dictionary_cache) from
# the Release build's cache when that has it: the same bytes (its build uses no device and is
# deterministic), and building it here would cost 200 s of one core instrumented, for code
# (the towns' simulation, experiment::build_atoms) that the ExperimentCli and DemoCli runs
# exercise here anyway. The fixture then reads the cached file under ASan.
release_dicts=$root/build/user-cache/potmap/dictionaries
if [[ -d "$release_dicts" && ! -d "$build/user-cache/potmap/dictionaries" ]]; then
  mkdir -p "$build/user-cache/potmap"
  cp -r "$release_dicts" "$build/user-cache/potmap/"
fi
if [[ "${POTMAP_SANITIZE_SUITE:-}" != full ]]; then
  export POTMAP_TEST_INPUTS=small
fi

# intercept_tls_get_addr=0: clang 14's LeakSanitizer, tracking the dynamic TLS blocks of modules
# loaded at run time, read a block of nonsense size under Debian 12's glibc and crashed at exit
# ("Tracer caught signal 11", DTLS 0x1679-0x80000277b) in the tests that build programs from
# source; without the tracking it scans the static TLS only (docs/sanitizers.md).
export ASAN_OPTIONS=detect_leaks=1:check_initialization_order=1:strict_string_checks=1:intercept_tls_get_addr=0
export LSAN_OPTIONS=suppressions=$root/scripts/lsan-opencl.supp:print_suppressions=0
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
# shellcheck disable=SC2086
ctest --test-dir "$build" -j"$(nproc)" --output-on-failure --timeout 900 -E "$exclude" \
  ${POTMAP_SANITIZE_ARGS:-}
if ! ctest --test-dir "$build" -N -R "$mpi_tests" | grep -q 'Total Tests: 0'; then
  ASAN_OPTIONS=detect_leaks=0:check_initialization_order=1:strict_string_checks=1:intercept_tls_get_addr=0 \
    ctest --test-dir "$build" --output-on-failure --timeout 900 -R "$mpi_tests"
fi
echo "sanitize_suite: the tests passed under ASan + UBSan + LSan (inputs: ${POTMAP_TEST_INPUTS:-full})"
