#!/usr/bin/env bash
# The full runs whose outputs are committed under docs/results (JSON and figures), then the
# results page. Run from anywhere after building (scripts/setup.sh); takes about 30 minutes on
# 2 cores. Extra arguments go to every runner (e.g. --device pocl).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
potmap=${POTMAP:-build/tools/potmap}
out=docs/results
fig=$out/figures
mkdir -p "$fig"
rm -f "$fig"/*.png  # no stale figures of earlier runs
export POTMAP_CACHE_DIR=${POTMAP_CACHE_DIR:-build/kernel-cache}
logs=(../shared/data/radish/intel-corrected.log.gz ../shared/data/radish/aces-corrected.log.gz
      ../shared/data/radish/csail-corrected.log.gz ../shared/data/radish/freiburg-079-corrected.log.gz)
common=(--seeds 0 1 2 --figures "$fig" "$@")

"$potmap" experiment intra "${logs[@]}" --scans 110 --json $out/intra.json "${common[@]}"
# Shorter runs and about 50 atoms per source (10 scans; 4 per town for the three towns), as the
# paper's tables; POT's indexed ranking would take thousands of atoms at about the same time.
"$potmap" experiment inter "${logs[@]}" --scans 60 --json $out/inter.json "${common[@]}"
"$potmap" experiment sim2real "${logs[@]}" --scans 60 --atom-scans 4 --json $out/sim2real.json "${common[@]}"
# The baselines' maps of a target are those of the intra-domain figures: keep the repository small
# (POT/RePOT maps of one inter-domain pair and of every sim-to-real target stay).
find "$fig" -name 'inter-domain-*' ! -name 'inter-domain-intel-aces-*POT*' ! -name '*compare_prob.png' -delete
find "$fig" -name 'sim-to-real-*' ! -name '*POT*' ! -name '*compare_prob.png' -delete
# Instantaneous maps: one ABHM per scan, so fewer Adam steps (500) than the offline default.
"$potmap" experiment dynamic --scans 30 --abhm-steps 500 --json $out/dynamic.json "${common[@]}"
# The budget is POT's mean time per scan over the seeds (atoms from 5 scans of each of the
# other two towns).
"$potmap" experiment per-time sim:town1 sim:town2 sim:town3 --sim-scans 40 --atom-scans 5 \
  --json $out/per-time.json "${common[@]}"
# Small repository: per-time figures of the first town only; no kernel pictures of BHM (one
# width on a regular grid: a single colour).
find "$fig" -name 'per-time-unit-*' ! -name 'per-time-unit-sim-town1-[A-Z]*' \
  ! -name 'per-time-unit-sim-town2-sim-town3-sim-town1-*' -delete
rm -f "$fig"/*-BHM_kernels.png "$fig"/*-BHM--budget-_kernels.png
# POT's variance pictures are noisy and large PNGs: only the intra-domain ones stay.
find "$fig" -name '*POT_var.png' ! -name 'intra-domain-*' -delete
python3 scripts/make_results.py $out docs/results.md
