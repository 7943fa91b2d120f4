#!/usr/bin/env bash
# Builds potmap (scripts/setup.sh) and runs its demo; arguments go to `potmap demo`.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
# Only the command the demo runs: the test suite and benchmarks are built by test.sh.
POTMAP_BUILD_TARGET=potmap_cli ./scripts/setup.sh
exec ./build/tools/potmap demo "$@"
