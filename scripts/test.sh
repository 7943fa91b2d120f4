#!/usr/bin/env bash
# Builds potmap (scripts/setup.sh) and runs the whole test suite with CTest.
# POTMAP_TEST_TIMEOUT: per-test limit in seconds (default 600).
# POTMAP_SUITE_TIMEOUT: limit for the whole run in seconds (default 3600).
# POTMAP_FUZZ_SECONDS: after the tests, every reader's libFuzzer target runs this long with a
#   fixed seed (default 10; 0 skips; skipped too when clang is missing).
# POTMAP_SANITIZE: 1 (default) runs the whole test suite under ASan + UBSan + LSan after that
#   (scripts/sanitize_suite.sh, sharing the fuzz build; the slow tests with small inputs,
#   POTMAP_SANITIZE_SUITE=full for full sizes); 0 skips; skipped without clang.
# POTMAP_SANITIZE_THREADS: 1 (default) then runs the threaded tests under ThreadSanitizer
#   (scripts/sanitize_threads.sh, its own build of the library and three test files); 0 skips.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
./scripts/setup.sh || { echo "test.sh: FAILED: installing or building failed (see above)" >&2; exit 1; }

start=$(date +%s)
status=0
log=build/ctest-output.log
timeout --foreground "${POTMAP_SUITE_TIMEOUT:-3600}" \
  ctest --test-dir build --output-on-failure -j"$(nproc)" \
  --timeout "${POTMAP_TEST_TIMEOUT:-600}" 2>&1 | tee "$log" || status=$?
# ctest's own count, repeated as the last line (the fuzz run prints after it).
total=$(sed -n 's/.*tests failed out of \([0-9]*\).*/\1/p' "$log" | tail -1)
failed=$(sed -n 's/.* \([0-9]*\) tests failed out of.*/\1/p' "$log" | tail -1)
fuzz_status=0
fuzz_secs=${POTMAP_FUZZ_SECONDS:-10}
if ((status == 0 && fuzz_secs > 0)); then
  if command -v clang++ >/dev/null; then
    echo "test.sh: fuzzing every reader for ${fuzz_secs} s each (fuzz/run_fuzzers.sh)"
    ./fuzz/run_fuzzers.sh "$fuzz_secs" || fuzz_status=$?
  else
    echo "test.sh: clang++ not found: fuzzing skipped"
  fi
fi
san_status=0
if ((status == 0 && fuzz_status == 0)) && [[ "${POTMAP_SANITIZE:-1}" != 0 ]]; then
  if command -v clang++ >/dev/null; then
    echo "test.sh: the whole test suite under AddressSanitizer + UBSan + LSan (scripts/sanitize_suite.sh)"
    ./scripts/sanitize_suite.sh || san_status=$?
    if ((san_status == 0)) && [[ "${POTMAP_SANITIZE_THREADS:-1}" != 0 ]]; then
      echo "test.sh: threaded tests under ThreadSanitizer (scripts/sanitize_threads.sh)"
      ./scripts/sanitize_threads.sh || san_status=$?
    fi
  else
    echo "test.sh: clang++ not found: sanitizer run of the test suite skipped"
  fi
fi
elapsed=$(($(date +%s) - start))

echo
if [[ -n "$total" && -n "$failed" ]]; then
  summary="tests: $((total - failed)) passed, ${failed} failed"
else
  summary="tests: 0 passed, 1 failed"  # ctest printed no count: it did not run
  ((status != 0)) || status=1
fi
if ((status == 0 && fuzz_status == 0 && san_status == 0)); then
  echo "test.sh: PASSED (all tests, ${elapsed} s)"
elif ((status == 124)); then
  echo "test.sh: FAILED: the suite ran past ${POTMAP_SUITE_TIMEOUT:-3600} s" >&2
elif ((status != 0)); then
  echo "test.sh: FAILED (ctest exit status ${status}, ${elapsed} s); see the failures above" >&2
elif ((fuzz_status != 0)); then
  echo "test.sh: FAILED: a fuzz target crashed (see above; the crashing input is in build-fuzz)" >&2
  status=$fuzz_status
else
  echo "test.sh: FAILED: tests failed under the sanitizers (see above)" >&2
  status=$san_status
fi
echo "$summary"
exit "$status"
