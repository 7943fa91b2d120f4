#!/usr/bin/env bash
# Builds the C API tests (tests/capi) with clang under AddressSanitizer + UndefinedBehaviorSanitizer
# and runs them. Shares the build folder and flags of fuzz/run_fuzzers.sh (default build-fuzz),
# so the instrumented library is compiled once for both; only the test files are added.
# LeakSanitizer runs too, with scripts/lsan-opencl.supp for what the OpenCL driver (PoCL, its
# LLVM) keeps until exit; potmap's own leaks are not suppressed.
# Usage: scripts/sanitize_capi.sh [BUILD_DIR]   (extra gtest flags in POTMAP_SANITIZE_ARGS)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build-fuzz}
# Must match fuzz/run_fuzzers.sh, or each script would rebuild the library for the other.
CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DPOTMAP_BUILD_FUZZERS=ON -DPOTMAP_BUILD_TESTS=OFF -DPOTMAP_BUILD_BENCH=OFF \
  -DPOTMAP_BUILD_TOOLS=OFF -DBUILD_SHARED_LIBS=OFF -DPOTMAP_BUILD_CAPI_TESTS=ON \
  -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link,address,undefined" >/dev/null
make -C "$build" -j"$(nproc)" potmap_capi_tests >/dev/null
export ASAN_OPTIONS=detect_leaks=1:check_initialization_order=1:strict_string_checks=1
export LSAN_OPTIONS=suppressions=$root/scripts/lsan-opencl.supp:print_suppressions=1
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
export POTMAP_CACHE_DIR=$build/kernel-cache
cd "$root"
# shellcheck disable=SC2086
# The soak test is left out: ASan's quarantine holds freed memory on purpose, so its resident
# memory bound means nothing here (LeakSanitizer checks leaks instead), and it is 4x slower.
"$build/tests/capi/potmap_capi_tests" --gtest_brief=1 --gtest_filter=-CApiSoak.* \
  ${POTMAP_SANITIZE_ARGS:-}
echo "sanitize_capi: C API tests passed under ASan + UBSan + LSan"
