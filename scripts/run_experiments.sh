#!/usr/bin/env bash
# The full runs whose outputs are committed under docs/results (JSON and figures), then the
# results page. Run from anywhere after building (scripts/setup.sh); takes about half an hour on
# 2 cores. Extra arguments go to every runner (e.g. --device pocl).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
potmap=${POTMAP:-build/tools/potmap}
out=docs/results
fig=$out/figures
mkdir -p "$fig"
export POTMAP_CACHE_DIR=${POTMAP_CACHE_DIR:-build/kernel-cache}
logs=(../shared/data/radish/intel-corrected.log.gz ../shared/data/radish/aces-corrected.log.gz
      ../shared/data/radish/csail-corrected.log.gz ../shared/data/radish/freiburg-079-corrected.log.gz)
common=(--seeds 0 1 2 --figures "$fig" "$@")

"$potmap" experiment intra "${logs[@]}" --scans 110 --json $out/intra.json "${common[@]}"
"$potmap" experiment inter "${logs[@]}" --scans 100 --json $out/inter.json "${common[@]}"
"$potmap" experiment sim2real "${logs[@]}" --scans 100 --json $out/sim2real.json "${common[@]}"
# The baselines' maps of a target are those of the intra-domain figures: keep the repository small.
rm -f "$fig"/inter-domain-* "$fig"/sim-to-real-*
# Instantaneous maps: one ABHM per scan, so fewer Adam steps (500) than the offline default.
"$potmap" experiment dynamic --scans 40 --abhm-steps 500 --json $out/dynamic.json "${common[@]}"
# The budget stands in for POT's time per scan until POT is measured (issue #6).
"$potmap" experiment per-time sim:town1 sim:town2 sim:town3 --sim-scans 100 --budget-ms 200 \
  --json $out/per-time.json "${common[@]}"
# Small repository: per-time figures of the first town only; no kernel pictures of BHM (one
# width on a regular grid: a single colour).
rm -f "$fig"/per-time-unit-sim-town2-* "$fig"/per-time-unit-sim-town3-* "$fig"/*-BHM_kernels.png \
  "$fig"/*-BHM--budget-_kernels.png
python3 scripts/make_results.py $out docs/results.md
