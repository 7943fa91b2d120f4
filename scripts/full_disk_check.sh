#!/usr/bin/env bash
# A real full disk under `potmap raster`, beside the unit tests' file size limit
# (tests/write_faults_test.cpp): in a user and mount namespace of its own (unshare -Urm: no root
# needed where unprivileged user namespaces are allowed) a 1 MiB tmpfs is mounted, a small raster
# is written to it, the rest of the tmpfs is filled, and a larger raster is written over the
# first. The command must fail with "No space left on device" naming the file, leave the four
# previous files byte for byte and no temporary file. Argument: the build folder (default build).
# Exit status 77 (ctest's skip) where user namespaces are not allowed.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
build=$(realpath "${1:-build}")
if ! unshare -Urm true 2>/dev/null; then
  echo "skipped: no user namespaces here (unshare -Urm), so no tmpfs without root"
  exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
{
  echo "x,y,gamma,w_mean,w_var"
  for i in 0 1 2 3 4 5; do for j in 0 1 2 3 4 5; do
    echo "$i,$j,4,$(((i * 7 + j * 3) % 5 - 2)),0.1"
  done; done
} >"$work/map.csv"
mkdir "$work/disk"

POTMAP_CACHE_DIR=${POTMAP_CACHE_DIR:-$build/kernel-cache} unshare -Urm bash -euo pipefail -c '
  build=$1 work=$2
  mount -t tmpfs -o size=1m potmap-full "$work/disk"
  potmap="$build/tools/potmap"
  "$potmap" raster --map "$work/map.csv" --bounds -1,3,-1,3 --res 0.1 --out "$work/disk/r" >/dev/null
  (cd "$work/disk" && sha256sum r_* >"$work/before.sha" && ls -a >"$work/before.ls")
  # Fill what is left but 64 KiB: the new files are larger than that.
  dd if=/dev/zero of="$work/disk/filler" bs=4k count=$(( ($(stat -f -c %a "$work/disk") - 16) )) \
    status=none || true
  ls -a "$work/disk" >"$work/before.ls"
  set +e
  "$potmap" raster --map "$work/map.csv" --bounds -1,6,-1,6 --res 0.01 --out "$work/disk/r" \
    >/dev/null 2>"$work/err"
  status=$?
  set -e
  cat "$work/err"
  [ "$status" = 1 ] || { echo "FAIL: exit status $status, expected 1"; exit 1; }
  grep -q "No space left on device" "$work/err" || { echo "FAIL: no ENOSPC in the message"; exit 1; }
  grep -q "$work/disk/r_" "$work/err" || { echo "FAIL: the message names no file"; exit 1; }
  (cd "$work/disk" && sha256sum -c --quiet "$work/before.sha") || { echo "FAIL: previous files changed"; exit 1; }
  ls -a "$work/disk" | diff "$work/before.ls" - || { echo "FAIL: files left behind"; exit 1; }
  echo "full disk: previous raster intact, no temporary file, error names the file"
' bash "$build" "$work"
