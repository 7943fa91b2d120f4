#!/usr/bin/env bash
# Builds potmap (scripts/setup.sh) and runs its demo; arguments go to `potmap demo`.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
./scripts/setup.sh
exec ./build/tools/potmap demo "$@"
