#!/usr/bin/env python3
"""Look-ahead of every method beside OctoMap: each scan scored before it is learned.

Usage: bench/lookahead_methods.py [--build build] [--logs intel,aces,csail,freiburg-079]
                                  [--drives riverside-a,hku-1] [--log-scans 0] [--keyframes 30]
                                  [--cut 40] [--extra-repot "--repot-seeds-yield-fully 0"]
                                  [--out docs/lookahead-methods.json] [--doc docs/transfer.md]

`potmap experiment intra DATASET --lookahead` on each Radish log of ../shared/data/radish (the
first 10 scans are the atoms' source, every later one the target; --log-scans caps the scans,
0: the whole log) and each drive of ../shared/data/drives3d (keyframes 0..K-1, the first 10 the
source, at the drive defaults of bench/drive3d.py and the --cut range), methods OctoMap, joint
BHM, POT and RePOT, seed 0. Before each target scan is learned every method's map as it stands
is scored on that scan's held-out samples (every scan but the first target scan; OctoMap's
unknown cells read p = 0.5): all of them, and apart those with no earlier training sample within
twice the BHM's kernel spacing (1 m on logs, 2 m on drives), which only a prior can speak for.
--extra-repot adds a row of RePOT with those options. Prints the table, writes the JSON with
--out; --doc FILE puts the table between "<!-- bench/lookahead_methods.py table -->" and
"<!-- end of bench/lookahead_methods.py table -->".
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile

from marked_doc import replace_marked, write_json

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "shared", "data")
# bench/drive3d.py's drive defaults of the joint BHM.
BHM_3D = ["--bhm-spacing", "1", "--free-per-metre", "0.5", "--bhm-voxel", "0.5",
          "--bhm-tau", "4.5", "--bhm-margin", "1", "--bhm-em", "2", "--bhm-cg-tol", "1e-4"]


def run(build, dataset, args, methods):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "r.json")
        cmd = [os.path.join(build, "tools", "potmap"), "experiment", "intra", dataset,
               "--methods", methods, "--seeds", "0", "--lookahead", "--json", out] + args
        print("bench/lookahead_methods.py: " + " ".join(cmd[1:]), file=sys.stderr, flush=True)
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit("bench/lookahead_methods.py: potmap failed:\n" + done.stderr)
        with open(out) as f:
            return json.load(f)


def pair(auc, nll):
    return "n/a" if auc is None or nll is None else "%.4f / %.4f" % (auc, nll)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(HERE, "..", "build"))
    ap.add_argument("--logs", default="intel,aces,csail,freiburg-079")
    ap.add_argument("--drives", default="riverside-a,hku-1")
    ap.add_argument("--log-scans", type=int, default=0, help="scans of each log (0: all)")
    ap.add_argument("--keyframes", type=int, default=30, help="keyframes of each drive")
    ap.add_argument("--cut", type=float, default=40.0, help="drives' range cut, metres")
    ap.add_argument("--extra-repot", default="--repot-seeds-yield-fully 0",
                    help="options of an extra RePOT row ('': none)")
    ap.add_argument("--out", default="", help="JSON file to write")
    ap.add_argument("--doc", default="", help="Markdown page whose marked table to replace")
    a = ap.parse_args()
    jobs = []
    for log in filter(None, a.logs.split(",")):
        jobs.append((log, os.path.join(DATA, "radish", log + "-corrected.log.gz"),
                     ["--scans", str(a.log_scans)]))
    for drive in filter(None, a.drives.split(",")):
        jobs.append(("%s, %g m" % (drive, a.cut), os.path.join(DATA, "drives3d", drive),
                     ["--scans", str(a.keyframes), "--max-range", str(a.cut), "--ogm-cells",
                      "0.1", "0.2"] + BHM_3D))
    result = {"command": "bench/lookahead_methods.py " + " ".join(sys.argv[1:]),
              "cpus": os.cpu_count(), "machine": platform.machine(), "rows": []}
    table = ["| place | method | held-out after | look-ahead, all | beyond reach (n) |",
             "|---|---|---|---|---|"]
    print("\n".join(table), flush=True)
    device = ""
    for name, path, args in jobs:
        variants = [("", "ogm,bhm,pot,repot", [])]
        if a.extra_repot:
            variants.append((" (" + a.extra_repot + ")", "repot", a.extra_repot.split()))
        for suffix, methods, extra in variants:
            j = run(a.build, path, args + extra, methods)
            device = j.get("device", device)
            for row in j["table"]:
                la = row.get("lookahead")
                if la is None:
                    continue
                r = {"place": name, "method": row["method"] + suffix, "chosen": row["chosen"],
                     "auc": row["auc"]["mean"], "nll": row["nll"]["mean"],
                     "ahead_auc": la["auc"]["mean"], "ahead_nll": la["nll"]["mean"],
                     "beyond_auc": la["beyond_auc"]["mean"], "beyond_nll": la["beyond_nll"]["mean"],
                     "beyond_n": la["beyond_n"]["mean"], "ms_per_scan": row["ms_per_scan"]["mean"],
                     "reach_m": j["settings"]["lookahead_reach"]}
                result["rows"].append(r)
                method = r["chosen"] if row["method"] == "OGM" else r["method"]
                table.append("| %s | %s | %s | %s | %s (%d) |" % (
                    name, method.replace("OGM", "OctoMap"), pair(r["auc"], r["nll"]),
                    pair(r["ahead_auc"], r["ahead_nll"]), pair(r["beyond_auc"], r["beyond_nll"]),
                    r["beyond_n"] or 0))
                print(table[-1], flush=True)
    result["device"] = device
    if a.doc:
        body = "\n".join(["", "Device: %s, %d CPUs; AUC / NLL, seed 0." % (device, os.cpu_count()),
                          ""] + table + [""])
        replace_marked(a.doc, "bench/lookahead_methods.py", "table", body)
    if a.out:
        write_json(a.out, result)


if __name__ == "__main__":
    main()
