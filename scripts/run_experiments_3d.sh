#!/usr/bin/env bash
# The 3D runs whose outputs are committed under docs/results3d (JSON and comparison figures),
# then docs/results-3d.md (scripts/make_results_3d.py). The two ../shared drives, at a 20 m and
# a 40 m cut: intra-domain (atoms from a drive's first 10 keyframes, the next 10 mapped),
# inter-domain (riverside-a <-> hku-1) and sim-to-real (the simulated 3D towns as the source);
# then the single frames. About an hour on 2 cores. Extra arguments go to every drive runner
# (e.g. --device pocl).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
potmap=${POTMAP:-build/tools/potmap}
out=docs/results3d
fig=$out/figures
rm -rf "$fig"  # no stale figures of earlier runs
export POTMAP_CACHE_DIR=${POTMAP_CACHE_DIR:-build/kernel-cache}
drives=(../shared/data/drives3d/riverside-a ../shared/data/drives3d/hku-1)
# Every method on the same held-out beams; OctoMap at 0.1 and 0.2 m both reported (--ogm-cells
# keeps both rows in the JSON); the joint BHM at the drive defaults (the runners apply them to
# drives: learn/drive_mapper.hpp).
common=(--seeds 0 --methods ogm,bhm,pot,repot --ogm-cells 0.1 0.2 "$@")
for cut in 20 40; do
  mkdir -p "$fig/${cut}m"
  "$potmap" experiment intra "${drives[@]}" --scans 20 --source-scans 10 --max-range $cut \
    --figures "$fig/${cut}m" --json $out/intra-${cut}m.json "${common[@]}"
  "$potmap" experiment inter "${drives[@]}" --scans 20 --max-range $cut \
    --json $out/inter-${cut}m.json "${common[@]}"
  "$potmap" experiment sim2real "${drives[@]}" --scans 20 --sim-scans 20 --atom-scans 4 \
    --max-range $cut --json $out/sim2real-${cut}m.json "${common[@]}"
done
# Only the side-by-side pictures stay (the repository keeps a few hundred kB of figures).
find "$fig" -name '*.png' ! -name '*compare_prob.png' -delete
frames=(../shared/data/lidar3d/nuscenes_lidar_top_1532402927647951.bin
        ../shared/data/lidar3d/kitti_000008.bin)
"$potmap" experiment frames "${frames[@]}" --sim-scans 4 --atom-scans 4 --json $out/frames.json
python3 scripts/make_results_3d.py "$out" docs/results-3d.md
