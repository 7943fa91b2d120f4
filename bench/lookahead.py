#!/usr/bin/env python3
"""Look-ahead on 3D drives: the map scored where the sensor goes next, before it gets there.

Usage: bench/lookahead.py [--build build] [--drives riverside-a,hku-1] [--keyframes 60]
                          [--cut 40] [--methods bhm,repot] [--out docs/lookahead.json]
                          [--doc docs/transfer.md]

Transfer's promise is a calibrated prior where no sample has been yet. For each drive of
../shared/data/drives3d and each method, `potmap mapping DRIVE --method M --lookahead` maps
keyframes 0..K-1 as a user runs it: before keyframe k is added (and before RePOT transfers from
it), the map as it stands is scored on the held-out samples kept of keyframe k (20 % of its
beams, every 4th sample), all of them and, apart, those beyond every earlier sample's reach (no
kernel whose cut-off holds them had been reached by a sample: JointBhm::reached). BHM is the
joint BHM at the drive defaults; RePOT the same seeded from the built-in 3D dictionary, a
transfer every 4th keyframe. Prints a table a drive and method, writes the JSON with --out;
--doc FILE puts the table between "<!-- bench/lookahead.py table -->" and "<!-- end of
bench/lookahead.py table -->".
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
DRIVES = os.path.join(HERE, "..", "..", "shared", "data", "drives3d")


def run(build, drive, method, keyframes, cut):
    with tempfile.TemporaryDirectory() as out:
        cmd = [os.path.join(build, "tools", "potmap"), "mapping", os.path.join(DRIVES, drive),
               "--method", method, "--lookahead", "--max-scans", str(keyframes),
               "--range-cut", str(cut), "--checkpoint-seconds", "0", "-q", "-o", out,
               "--json", "-"]
        print("bench/lookahead.py: " + " ".join(cmd[1:]), file=sys.stderr, flush=True)
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit("bench/lookahead.py: potmap failed:\n" + done.stderr)
        return json.loads(done.stdout)


def cell(s):
    if s["auc"] is None or s["n"] == 0:
        return "n/a (n %d)" % s["n"]
    return "%.4f / %.4f (n %d)" % (s["auc"], s["nll"], s["n"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(HERE, "..", "build"))
    ap.add_argument("--drives", default="riverside-a,hku-1")
    ap.add_argument("--keyframes", type=int, default=60)
    ap.add_argument("--cut", type=float, default=40.0, help="range cut, metres")
    ap.add_argument("--methods", default="bhm,repot")
    ap.add_argument("--out", default="", help="JSON file to write")
    ap.add_argument("--doc", default="", help="Markdown page whose marked table to replace")
    a = ap.parse_args()
    names = {"bhm": "BHM", "repot": "RePOT"}
    result = {"command": "bench/lookahead.py " + " ".join(sys.argv[1:]), "keyframes": a.keyframes,
              "cut_m": a.cut, "cpus": os.cpu_count(), "machine": platform.machine(), "rows": []}
    table = ["| drive | method | look-ahead AUC / NLL, all | beyond earlier reach | "
             "held-out after (AUC / NLL) |", "|---|---|---|---|---|"]
    print("\n".join(table), flush=True)
    device = ""
    for drive in a.drives.split(","):
        for method in a.methods.split(","):
            j = run(a.build, drive, method, a.keyframes, a.cut)
            device = j.get("device", device)
            row = {"drive": drive, "method": names.get(method, method),
                   "all": j["lookahead"]["all"], "beyond_reach": j["lookahead"]["beyond_reach"],
                   "held_out": j["scores"], "keyframes": j["keyframes"]}
            result["rows"].append(row)
            table.append("| %s | %s | %s | %s | %.4f / %.4f |" % (
                drive, row["method"], cell(row["all"]), cell(row["beyond_reach"]),
                j["scores"]["auc"], j["scores"]["nll"]))
            print(table[-1], flush=True)
    result["device"] = device
    if a.doc:
        body = "\n".join(["", "Device: %s, %d CPUs; keyframes 0-%d, %g m cut." % (
            device, os.cpu_count(), a.keyframes - 1, a.cut), ""] + table + [""])
        replace_marked(a.doc, "bench/lookahead.py", "table", body)
    if a.out:
        write_json(a.out, result)


if __name__ == "__main__":
    main()
