#!/usr/bin/env bash
# ThreadSanitizer over the tests that share contexts, mappers, evaluators and dictionaries
# across threads, and over the mapper's own pipeline thread: the library, the C API tests and
# potmap_thread_tests (the suite's threaded tests alone, so that this build compiles four test
# files, not the suite) built with clang -fsanitize=thread in build-tsan, then the tests whose
# names say threads run.
# The OpenCL driver is not instrumented: its own threads synchronise with ours through the
# pthread calls TSan sees; scripts/tsan.supp holds what it reports inside libraries that are
# not potmap's.
# Usage: scripts/sanitize_threads.sh [BUILD_DIR]   (extra gtest flags in POTMAP_SANITIZE_ARGS)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build-tsan}
CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Sanitize \
  -DCMAKE_CXX_FLAGS_SANITIZE="-O1 -gline-tables-only -fno-omit-frame-pointer" \
  -DCMAKE_C_FLAGS_SANITIZE="-O1 -gline-tables-only -fno-omit-frame-pointer" \
  -DPOTMAP_BUILD_TESTS=ON -DPOTMAP_BUILD_CAPI_TESTS=ON -DPOTMAP_BUILD_THREAD_TESTS=ON \
  -DPOTMAP_BUILD_TOOLS=OFF -DPOTMAP_BUILD_EXPERIMENTS=OFF -DPOTMAP_BUILD_BENCH=OFF \
  -DPOTMAP_BUILD_PYTHON=OFF -DBUILD_SHARED_LIBS=OFF \
  -DCMAKE_CXX_FLAGS="-fsanitize=thread" -DCMAKE_C_FLAGS="-fsanitize=thread" >/dev/null
# Before the build: CTest's test discovery runs the instrumented programs.
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$root/scripts/tsan.supp"
cmake --build "$build" -j"$(nproc)" --target potmap_thread_tests potmap_capi_tests >/dev/null
export POTMAP_CACHE_DIR=$build/kernel-cache
cd "$root"
filter=${POTMAP_TSAN_FILTER:-'*Thread*:*Concurren*:*Parallel*:Load.*:PotMapper.AddScanGivesWhatMapScansGives:PotMapper.AsyncMerge*'}
# shellcheck disable=SC2086
"$build/tests/capi/potmap_capi_tests" --gtest_brief=1 --gtest_filter="$filter" ${POTMAP_SANITIZE_ARGS:-}
# shellcheck disable=SC2086
"$build/tests/potmap_thread_tests" --gtest_brief=1 --gtest_filter="$filter" ${POTMAP_SANITIZE_ARGS:-}
echo "sanitize_threads: the threaded tests passed under ThreadSanitizer"
