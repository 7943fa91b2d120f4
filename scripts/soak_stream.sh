#!/usr/bin/env bash
# The hour-long C API soak: streams 36,000 scans (an hour of a 10 Hz sensor) through one mapper
# (CApiSoak.AStreamOfScansKeepsResidentMemoryFlat, which CI runs with 600) and writes the
# resident-memory samples to docs/soak-stream.json. Arguments: the build folder (default build)
# and the number of scans (default 36000). Takes about as long as the scans times the ms a scan
# the test prints (tens of minutes on PoCL with 2 cores).
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
build=${1:-build}
scans=${2:-36000}
out=docs/soak-stream.json
status=0
POTMAP_SOAK_STREAM_SCANS=$scans POTMAP_SOAK_JSON="$PWD/$out.partial" \
  POTMAP_CACHE_DIR=${POTMAP_CACHE_DIR:-$PWD/$build/kernel-cache} \
  "$build/tests/capi/potmap_capi_tests" \
  --gtest_filter=CApiSoak.AStreamOfScansKeepsResidentMemoryFlat || status=$?
# The samples are the result whether or not the bound held.
mv "$out.partial" "$out"
echo "wrote $out (test status $status)"
exit "$status"
