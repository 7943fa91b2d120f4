#!/usr/bin/env python3
"""2D POT on whole real logs: how the scan's map is built and calibrated, setting by setting.

Usage: bench/pot_calibration.py [--build build] [--logs intel,aces,csail,freiburg-079]
                                [--seeds 0] [--out docs/pot-calibration.json]
                                [--doc docs/pot-measurements.md]

For each Radish log of ../shared/data/radish, `potmap experiment intra LOG --methods pot` maps
the whole log (the first 10 scans are the atoms' source, every later scan the target) once per
row below, every row on the same held-out beams (20 % of each scan's), and BHM once beside them.
The rows add one setting at a time, from the scan's map as each class's Nadaraya-Watson
partition with free anchors 0.5 m clear of hits to the library's defaults (the anchors' weights solved
together, `PotOptions::anchor_sweeps`; a 0.25 m `anchor_clearance`; the transported logits times 1.5,
`PotOptions::logit_gain`), then two neighbours of the defaults. The defaults were chosen on
Intel; the other logs are the check. Prints AUC / NLL per log, writes the JSON with --out; --doc
FILE puts the table between "<!-- bench/pot_calibration.py table -->" and "<!-- end of
bench/pot_calibration.py table -->".
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile

from marked_doc import replace_marked

HERE = os.path.dirname(os.path.abspath(__file__))
LOGS = os.path.join(HERE, "..", "..", "shared", "data", "radish")

ROWS = [
    ("partition, anchor clearance 0.5 m, gain 1",
     ["--pot-anchor-sweeps", "0", "--pot-anchor-clearance", "0.5", "--pot-logit-gain", "1"]),
    ("solved, anchor clearance 0.5 m, gain 1", ["--pot-anchor-clearance", "0.5", "--pot-logit-gain", "1"]),
    ("solved, anchor clearance 0.25 m, gain 1", ["--pot-logit-gain", "1"]),
    ("**defaults**: solved, anchor clearance 0.25 m, gain 1.5", []),
    ("defaults, gain 2", ["--pot-logit-gain", "2"]),
    ("defaults, 20 sweeps", ["--pot-anchor-sweeps", "20"]),
]


def run(build, log, methods, seeds, extra):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "r.json")
        cmd = [os.path.join(build, "tools", "potmap"), "experiment", "intra",
               os.path.join(LOGS, log + "-corrected.log.gz"), "--methods", methods,
               "--seeds"] + [str(s) for s in seeds] + ["--json", out] + extra
        print("bench/pot_calibration.py: " + " ".join(cmd[1:]), file=sys.stderr, flush=True)
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit("bench/pot_calibration.py: potmap failed:\n" + done.stderr)
        with open(out) as f:
            runs = json.load(f)["runs"]
    # Mean over seeds.
    n = len(runs)
    return {k: sum(r[k] for r in runs) / n for k in ("auc", "nll", "ms_per_scan")}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(HERE, "..", "build"))
    ap.add_argument("--logs", default="intel,aces,csail,freiburg-079")
    ap.add_argument("--seeds", default="0", help="comma-separated seeds of the beam split")
    ap.add_argument("--out", default="", help="JSON file to write")
    ap.add_argument("--doc", default="", help="Markdown page whose marked table to replace")
    a = ap.parse_args()
    logs = a.logs.split(",")
    seeds = [int(s) for s in a.seeds.split(",")]
    shown = []  # the command as run, less the build folder
    for arg in sys.argv[1:]:
        if shown and shown[-1] == "--build":
            shown.pop()
        elif not arg.startswith("--build="):
            shown.append(arg)
    result = {"command": " ".join(["bench/pot_calibration.py"] + shown),
              "machine": {"cpu": platform.processor() or platform.machine(),
                          "hardware_threads": os.cpu_count()},
              "seeds": seeds, "logs": logs, "rows": []}
    for name, extra in [("BHM (learned, no transfer)", None)] + ROWS:
        row = {"setting": name, "options": extra or [], "logs": {}}
        for log in logs:
            row["logs"][log] = run(a.build, log, "bhm" if extra is None else "pot", seeds,
                                   extra or [])
        result["rows"].append(row)
    head = "| setting | " + " | ".join(logs) + " |"
    lines = ["", "AUC / NLL, whole logs, seed%s %s:" % ("s" if len(seeds) > 1 else "", a.seeds),
             "", head,
             "|---" * (len(logs) + 1) + "|"]
    for row in result["rows"]:
        cells = ["%.3f / %.3f" % (row["logs"][l]["auc"], row["logs"][l]["nll"]) for l in logs]
        lines.append("| " + row["setting"] + " | " + " | ".join(cells) + " |")
    table = "\n".join(lines) + "\n\n"
    print(table)
    if a.out:
        with open(a.out + ".tmp", "w") as f:
            json.dump(result, f, indent=1)
        os.replace(a.out + ".tmp", a.out)
    if a.doc:
        replace_marked(a.doc, "bench/pot_calibration.py", "table", table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
