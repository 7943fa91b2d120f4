#!/usr/bin/env python3
"""The tables of docs/forgetting.md from the JSON that bench/forgetting and
bench/forgetting_logs.py write: prints Markdown.

  bench/forgetting_tables.py > /tmp/tables.md
"""
import json
import os

DOCS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs")

RUNS = [
    ("forgetting-riverside.json",
     "**riverside-a** (MulRan, an Ouster OS1-64 on a car in traffic), keyframes 0-119 (91 s of "
     "the drive), the drive defaults (40 m cut)",
     "build/bench/forgetting ../shared/data/drives3d/riverside-a --max-scans 120 "
     "--half-life 0,5,20 --json docs/forgetting-riverside.json"),
    ("forgetting-town1-moving.json",
     "**town1 with 30 moving vehicles** (simulated: `potmap data simulate --town town1 --moving 30 "
     "--scans 400 --out out/sim`, scans 1 m and 0.1 s apart), the persistent joint BHM",
     "build/bench/forgetting out/sim/scans.log --half-life 0,1,3,10 "
     "--json docs/forgetting-town1-moving.json"),
    ("forgetting-intel.json",
     "**intel** (Radish, the whole log: 910 scans over 44 minutes, people in the corridors), the "
     "persistent joint BHM",
     "build/bench/forgetting ../shared/data/radish/intel-corrected.log.gz --half-life 0,60,300 "
     "--json docs/forgetting-intel.json"),
]


def half(h):
    return "never" if h == 0 else "%g s" % h


def bench_table(name, title, cmd):
    j = json.load(open(os.path.join(DOCS, name)))
    first = j["runs"][0]
    out = ["%s; %d readings of places left, %d at the end:" % (title, first["left_readings"],
                                                               first["left_at_end"]),
           "", "```sh", cmd, "```", "",
           "| half-life | overall AUC / NLL | now AUC / NLL | left, just after: mean p, "
           "p > 0.65 | left, final map | ms a scan |",
           "|---|---|---|---|---|---|"]
    for r in j["runs"]:
        out.append("| %s | %.4f / %.4f | %.4f / %.4f | %.3f, %.1f %% | %.3f, %.1f %% | %.1f |" % (
            half(r["half_life_s"]), r["overall"]["auc"], r["overall"]["nll"], r["now"]["auc"],
            r["now"]["nll"], r["left_mean_prob"], 100 * r["left_occupied_fraction"],
            r["left_at_end_mean_prob"], 100 * r["left_at_end_occupied_fraction"],
            r["ms_per_scan"]))
    return "\n".join(out)


def logs_table():
    j = json.load(open(os.path.join(DOCS, "forgetting-logs.json")))
    by = {}
    for r in j["runs"]:
        by.setdefault(r["log"], {})[r["half_life_s"]] = r
    lives = sorted({r["half_life_s"] for r in j["runs"] if r["half_life_s"] > 0})
    out = ["| log | never | " + " | ".join(half(h) for h in lives) + " |",
           "|---|---|" + "---|" * len(lives)]
    for log, d in by.items():
        b = d[0.0]["overall"]
        cells = ["%.4f / %.4f" % (b["auc"], b["nll"])]
        for h in lives:
            o = d[h]["overall"]
            cells.append("%.4f / %.4f (%+.4f)" % (o["auc"], o["nll"], o["auc"] - b["auc"]))
        out.append("| %s | %s |" % (log.replace("-corrected.log.gz", ""), " | ".join(cells)))
    return "\n".join(out)


def main():
    for run in RUNS:
        print(bench_table(*run))
        print()
    print(logs_table())


if __name__ == "__main__":
    main()
