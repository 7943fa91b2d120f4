#!/usr/bin/env bash
# The test suite under AddressSanitizer + UndefinedBehaviorSanitizer + LeakSanitizer: the
# library with the GoogleTest suite (potmap_tests) and the C API tests, built with clang in the
# fuzzers' build folder (scripts/sanitizer_build.sh: the instrumented library is compiled once
# for both), every test in its own process, run by CTest in parallel.
#
# Which tests: by default (CI) every test that took under POTMAP_SANITIZE_MAX_SECONDS (default
# 2) in the Release run whose CTest timings are in BUILD/Testing (build/, which scripts/test.sh
# has just run): instrumented, the library runs 7 to 30 times slower (the fuzzers' coverage
# hooks and UBSan's checks keep Eigen from inlining), so the few end-to-end runs of whole logs
# would take 2 to 5 minutes each there (docs/sanitizers.md). POTMAP_SANITIZE_SUITE=full runs
# all of them (about an hour on 2 cores). Always left out, with the reason:
#   *Cli.*, OctomapExport.*, raster_mpi_ranks, full_disk_check  run the potmap command, which
#                     this build does not make (its code is the library's, which the other
#                     tests reach); the command's readers are fuzzed in this same build.
#   python_*          the interpreter is not instrumented (ASan must be first in the process).
#   install_consumer  packaging, not memory safety.
#   capi.CApiSoak.*, MapperMemory.*  resident-memory bounds mean nothing under ASan's
#                     quarantine, which holds freed memory on purpose; LeakSanitizer checks
#                     leaks instead.
# LeakSanitizer suppressions: scripts/lsan-opencl.supp (the OpenCL driver only, never potmap).
# Usage: scripts/sanitize_suite.sh [BUILD_DIR [RELEASE_BUILD_DIR]]
#        (extra ctest flags in POTMAP_SANITIZE_ARGS)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build-fuzz}
release=${2:-$root/build}
max_s=${POTMAP_SANITIZE_MAX_SECONDS:-2}
# shellcheck source=scripts/sanitizer_build.sh
source "$root/scripts/sanitizer_build.sh"
sanitizer_configure "$root" "$build"
cmake --build "$build" -j"$(nproc)" --target potmap_tests potmap_capi_tests >/dev/null

exclude='^(python_|install_consumer$|raster_mpi_ranks$|full_disk_check$|abi_exports$|capi\.CApiSoak\.|MapperMemory\.|OctomapExport\.|[A-Za-z0-9]*Cli\.)'
costs=$release/Testing/Temporary/CTestCostData.txt
if [[ "${POTMAP_SANITIZE_SUITE:-}" != full ]]; then
  if [[ ! -f "$costs" ]]; then
    echo "sanitize_suite: no Release timings in $costs: run the Release suite first" \
      "(scripts/test.sh), or POTMAP_SANITIZE_SUITE=full" >&2
    exit 1
  fi
  # CTestCostData: "name runs seconds" lines, then "---" and the failed tests.
  slow=$(awk -v max="$max_s" '/^---/{exit} NF==3 && $3+0 >= max {print $1}' "$costs" |
    sed 's/[][().*+?^$|\\]/\\&/g' | paste -sd'|' -)
  if [[ -n "$slow" ]]; then
    echo "sanitize_suite: left out, ${max_s} s or more in the Release run:" \
      "$(echo "$slow" | tr '|' ' ' | sed 's/\\//g')"
    exclude="$exclude|^($slow)\$"
  fi
fi

export ASAN_OPTIONS=detect_leaks=1:check_initialization_order=1:strict_string_checks=1
export LSAN_OPTIONS=suppressions=$root/scripts/lsan-opencl.supp:print_suppressions=0
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
# shellcheck disable=SC2086
ctest --test-dir "$build" -j"$(nproc)" --output-on-failure --timeout 900 -E "$exclude" \
  ${POTMAP_SANITIZE_ARGS:-}
echo "sanitize_suite: the tests passed under ASan + UBSan + LSan"
