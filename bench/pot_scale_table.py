#!/usr/bin/env python3
"""Prints the Markdown table of a bench/pot_scale JSON (docs/pot-scale.md's sweep).

Usage: bench/pot_scale_table.py [docs/pot-scale.json]

One row per (atoms, method, ranking, scans): ms per scan and by stage, the ratio to BHM's time
per scan on the same scans in the same run, held-out AUC / NLL, and the fraction of sectors
where the indexed ranking chose the exhaustive ranking's atom (same scans only).
"""
import json
import sys


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else "docs/pot-scale.json"
    with open(path) as f:
        run = json.load(f)
    print(f"Device: {run['device']}; target {run['target']}, dictionary "
          f"{run['dictionary']['atoms']} atoms ({run['dictionary']['bytes_per_atom']:.0f} bytes "
          f"an atom, read in {run['dictionary']['load_ms']:.0f} ms).\n")
    print("| atoms | method | ranking | scans | ms/scan | ranking | transport | placement | "
          "merge | x BHM | AUC | NLL | same atom |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in run["rows"]:
        merge = r.get("refine_ms", 0) if r["method"] == "RePOT" else r.get("combine_ms", 0)
        agree = f"{r['agreement']:.2f}" if r["ranking"] == "indexed" and r["agreement"] >= 0 else ""
        print(f"| {r['atoms']} | {r['method']} | {r['ranking']} | {r['scans']} | "
              f"{r['ms_per_scan']:.1f} | {r['ranking_ms']:.1f} | {r['transport_ms']:.1f} | "
              f"{r['placement_ms']:.1f} | {merge:.1f} | {r['over_bhm']:.2f} | {r['auc']:.3f} | "
              f"{r['nll']:.3f} | {agree} |")


if __name__ == "__main__":
    main()
