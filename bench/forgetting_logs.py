#!/usr/bin/env python3
"""What forgetting costs a static map: `potmap mapping` (RePOT, the defaults) on whole real logs
with and without --half-life, held-out scores of the overall map (the final persistent joint BHM
on every scan's held-out beams) and of the instantaneous maps, and the time per scan.

Prints a table, writes JSON.

  bench/forgetting_logs.py --potmap build/tools/potmap --half-life 0,300,1200 \
      --json docs/forgetting-logs.json [LOG ...]

Without LOG arguments the four Radish logs of ../shared/data/radish.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
RADISH = os.path.join(HERE, "..", "..", "shared", "data", "radish")
LOGS = ["intel-corrected.log.gz", "freiburg-079-corrected.log.gz", "csail-corrected.log.gz",
        "aces-corrected.log.gz"]


def run(potmap, log, half_life, out, extra):
    cmd = [potmap, "mapping", log, "-o", out, "-q", "--json", "-",
           "--half-life", str(half_life)] + extra
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), res.stderr[-2000:]))
    return json.loads(res.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("logs", nargs="*")
    ap.add_argument("--potmap", default="build/tools/potmap")
    ap.add_argument("--half-life", default="0,300,1200",
                    help="comma-separated seconds (0: never forget)")
    ap.add_argument("--max-scans", type=int, default=0)
    ap.add_argument("--json", default="forgetting-logs.json")
    a = ap.parse_args()
    logs = a.logs or [os.path.normpath(os.path.join(RADISH, l)) for l in LOGS]
    half_lives = [float(h) for h in a.half_life.split(",")]
    extra = ["--max-scans", str(a.max_scans)] if a.max_scans else []
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for log in logs:
            for h in half_lives:
                j = run(a.potmap, log, h, os.path.join(tmp, "out"), extra)
                rows.append({"log": os.path.basename(log), "half_life_s": h,
                             "scans": j.get("scans"), "overall": j["overall"],
                             "instantaneous": j["instantaneous"],
                             "refine_ms_per_scan": j["ms_per_scan"]["refine"],
                             "total_s": j.get("total_seconds"), "device": j.get("device")})
                r = rows[-1]
                print("%-32s %8g s  overall AUC %.4f NLL %.4f  instantaneous AUC %.4f NLL %.4f"
                      % (r["log"], h, r["overall"]["auc"], r["overall"]["nll"],
                         r["instantaneous"]["auc"], r["instantaneous"]["nll"]), flush=True)
    print()
    print("%-32s %10s %16s %16s %10s" % ("log", "half-life", "overall AUC/NLL", "d AUC vs 0",
                                         "refine ms"))
    base = {}
    for r in rows:
        if r["half_life_s"] == 0:
            base[r["log"]] = r
    for r in rows:
        b = base.get(r["log"])
        d = r["overall"]["auc"] - b["overall"]["auc"] if b else float("nan")
        print("%-32s %10g %8.4f/%.4f %+16.4f %10s" % (r["log"], r["half_life_s"],
                                                      r["overall"]["auc"], r["overall"]["nll"], d,
                                                      "%.2f" % r["refine_ms_per_scan"]))
    with open(a.json, "w") as f:
        json.dump({"runs": rows, "command": " ".join(sys.argv)}, f, indent=2)
    print("wrote", a.json)


if __name__ == "__main__":
    main()
