# Sourced by fuzz/run_fuzzers.sh and scripts/sanitize_suite.sh: configures the one clang build
# with AddressSanitizer + UndefinedBehaviorSanitizer (and libFuzzer's coverage hooks in the
# readers the fuzzers reach: CMakeLists.txt, POTMAP_FUZZED_SOURCES), so that
# the instrumented library is compiled once for the fuzzers and for the test suite. The two
# scripts build different targets of it; both must configure it alike, or each would rebuild
# the library for the other.
# Usage: sanitizer_configure ROOT BUILD_DIR
# Line tables only (-gline-tables-only, as sanitize_threads.sh): the reports' stack traces keep
# their functions, files and lines, inlined frames included, with less debug information to
# build (in two fresh-clone CI runs the suite's build took 387 s with full debug information and
# 377 s with line tables: within the machine's noise, so not a way to shorten CI by itself).
sanitizer_configure() {
  CC=clang CXX=clang++ cmake -S "$1" -B "$2" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" \
    -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" \
    -DPOTMAP_BUILD_FUZZERS=ON -DPOTMAP_BUILD_TESTS=ON -DPOTMAP_BUILD_CAPI_TESTS=ON \
    -DPOTMAP_BUILD_TOOLS=ON -DPOTMAP_BUILD_BENCH=OFF -DPOTMAP_BUILD_PYTHON=OFF \
    -DBUILD_SHARED_LIBS=OFF -DPOTMAP_TEST_TIMEOUT=1800 \
    -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined" >/dev/null
}
