#!/usr/bin/env bash
# Packs this checkout's Release build for a GPU machine that has a driver but none of potmap's
# build dependencies (no compiler packages, no network): the programs, every shared library they
# load but glibc's (xz-compressed, about 19 MB), the shared data and a cached 200-atom
# dictionary, all in .dev/ (git-ignored through .git/info/exclude). scripts/gpu_check.sh, run
# from the checkout's root on that machine, unpacks it and runs the checks.
#
# GDAL's hundred-odd libraries would triple the bundle, so the test program travels relinked
# without the GeoTIFF writer (its tests are filtered out there) and libpotmap_gdal stays behind.
# The device takes 64 MiB: the shared data travels but for hku-2 and riverside-a past its first
# 60 keyframes (a drive folder cut there is still a drive; the tests that count its 281
# keyframes are filtered out there too).
#
# Usage: scripts/gpu_bundle.sh [build] [POT dictionary cache folder, as bench/pot_scale's --cache]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
cache=${2:-}
dev=$root/.dev
grep -qx '/.dev/' "$root/.git/info/exclude" 2>/dev/null || echo '/.dev/' >>"$root/.git/info/exclude"
rm -rf "$dev" && mkdir -p "$dev/stage/bin" "$dev/stage/lib" "$dev/shared" "$dev/ps_cache"

# The suite without GDAL: the library's loader of the GDAL module in place of the writer.
link=$build/tests/CMakeFiles/potmap_tests.dir/link.txt
loader=$(find "$build/CMakeFiles/potmap.dir" -name 'geotiff_module.cpp.o' | head -1)
[[ -f $link && -n $loader ]] || { echo "gpu_bundle: no Release build with tests in $build" >&2; exit 1; }
(cd "$build/tests" && eval "$(sed -e "s#[^ ]*/geotiff_writer\.cpp\.o#$loader#" \
  -e 's#[^ ]*/libgdal\.so##' -e "s#-o potmap_tests#-o $dev/stage/bin/potmap_tests_nogdal#" \
  "$link" | tr -d '\n') -ldl")
cp "$build/tools/potmap" "$build/bench/potmap_bench" "$build/bench/pot_scale" \
  "$build/bench/mapper_latency" "$build/tests/capi/potmap_capi_tests" "$dev/stage/bin/"
for b in "$dev"/stage/bin/*; do ldd "$b" | awk '$3 ~ /^\// {print $1, $3}'; done | sort -u |
  grep -v -E '^(libc\.so|libm\.so|libpthread|libdl\.so|librt\.so|ld-linux)' |
  while read -r name path; do cp -L "$path" "$dev/stage/lib/$name"; done
tar -C "$dev/stage" -cf - bin lib | xz -T0 -6 >"$dev/bundle.tar.xz"
rm -rf "$dev/stage"
mkdir -p "$dev/shared/data/drives3d/riverside-a/Scans"
for d in "$root"/../shared/data/*; do
  [[ $(basename "$d") == drives3d ]] || cp -r "$d" "$dev/shared/data/"
done
cp -r "$root/../shared/data/drives3d/hku-1" "$dev/shared/data/drives3d/"
river=$root/../shared/data/drives3d/riverside-a
ls "$river/Scans" | sort | head -60 | while read -r f; do cp "$river/Scans/$f" "$dev/shared/data/drives3d/riverside-a/Scans/"; done
for f in odom_poses.txt times.txt; do
  [[ -f $river/$f ]] && head -60 "$river/$f" >"$dev/shared/data/drives3d/riverside-a/$f"
done
[[ -n $cache && -f $cache/town2_first10_200.potdict ]] && cp "$cache/town2_first10_200.potdict" "$dev/ps_cache/"
cp "$root/scripts/gpu_check.sh" "$dev/"
du -sh "$dev"
