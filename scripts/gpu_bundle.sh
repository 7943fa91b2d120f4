#!/usr/bin/env bash
# Packs this checkout's Release build for a GPU machine that has a driver but none of potmap's
# build dependencies (no compiler packages, no network): the programs, every shared library they
# load but glibc's (xz-compressed, about 19 MB), the shared data and a cached 200-atom
# dictionary, all in .dev/ (git-ignored through .git/info/exclude). scripts/gpu_check.sh, run
# from the checkout's root on that machine, unpacks it and runs the checks.
#
# GDAL's hundred-odd libraries would triple the bundle, so the test program travels relinked
# without the GeoTIFF writer (its tests are filtered out there) and libpotmap_gdal stays behind.
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
cp -r "$root/../shared/data" "$dev/shared/"
[[ -n $cache && -f $cache/town2_first10_200.potdict ]] && cp "$cache/town2_first10_200.potdict" "$dev/ps_cache/"
cp "$root/scripts/gpu_check.sh" "$dev/"
du -sh "$dev"
