#!/usr/bin/env python3
"""`potmap mapping` on MPI ranks against one process: the merged map's scores on every scan's
held-out beams and the wall time, for a 2D log and a 3D drive, and the arithmetic for a city
(kilometres of drive per rank-hour). Prints a table and writes JSON.

Usage: bench/mapping_ranks.py [--build build] [--ranks 1,2,4] [--log PATH] [--max-scans 0]
                              [--drive PATH] [--max-keyframes 40] [--repeat 1]
                              [--out mapping-ranks.json]

Every row is one whole process (`potmap mapping ... --json -`, or `mpirun -n N --oversubscribe
potmap mapping ...`), timed from exec to exit; with --repeat R the rows run R rounds, one after
another, and each row keeps its median wall time (the scores are the same every round). The
reference is the same command without mpirun.
Scores: the merged map on the held-out beams of every scan (20 % of every scan's beams, never
learned by any rank), as one process scores its own map, so the rows compare directly. The bar
(docs/merging.md): within 0.005 AUC and 0.01 NLL of one process.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "shared", "data")


def run(cmd, env):
    t = time.perf_counter()
    r = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    dt = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit("failed (%d): %s\n%s" % (r.returncode, " ".join(cmd), r.stderr[-4000:]))
    return dt, json.loads(r.stdout)


def scores(j):
    s = j["overall"] if "overall" in j else j["scores"]
    return s["auc"], s["nll"], s.get("points", s.get("n"))


def median(v):
    v = sorted(v)
    n = len(v)
    return v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])


def repeated(name, potmap, args_, ranks, env, work, extra_one, repeat):
    """rows_for() `repeat` times, round by round; each row's median wall time."""
    rounds = [rows_for(name, potmap, args_, ranks, env, work, extra_one) for _ in range(repeat)]
    rows = rounds[0]
    for i, row in enumerate(rows):
        walls = [r[i]["wall_s"] for r in rounds]
        row["wall_s"] = median(walls)
        row["walls_s"] = walls
    for row in rows:
        row["speedup"] = rows[0]["wall_s"] / row["wall_s"]
    return rows


def rows_for(name, potmap, args_, ranks, env, work, extra_one=None):
    """One process, then mpirun -n N for each N: wall time, scores, differences. `extra_one`:
    options of a second one-process row (shown, not the reference)."""
    mpirun = shutil.which("mpirun")
    rows = []
    base = None
    runs = [(0, [])] + ([(0, extra_one)] if extra_one else []) + [(n, []) for n in ranks]
    for i, (n, extra) in enumerate(runs):
        out = os.path.join(work, "%s-%d" % (name, i))
        cmd = [potmap, "mapping"] + args_ + extra + ["--out", out, "--json", "-", "-q"]
        if n:
            if not mpirun:
                sys.exit("mpirun not found (install openmpi-bin)")
            cmd = [mpirun, "-n", str(n), "--allow-run-as-root", "--oversubscribe", "-x",
                   "POTMAP_CACHE_DIR"] + cmd
        wall, j = run(cmd, env)
        auc, nll, points = scores(j)
        row = {"data": name, "ranks": n, "options": " ".join(extra), "wall_s": wall, "auc": auc, "nll": nll,
               "held_out": points, "device": j.get("device", ""), "command": " ".join(cmd)}
        if "ranks" in j:
            row["merge_s"] = j["ranks"]["merge_seconds"]
            row["wait_s"] = j["ranks"]["wait_seconds"]
            row["export_s"] = j["ranks"].get("export_seconds", 0.0)
        if name == "drive":
            row["keyframes"] = j["keyframes"]
            row["path_m"] = j["path_m"]
            row["mapping_s"] = j["mapping_s"]
            row["ms_per_keyframe"] = j["ms_per_keyframe"]
            row["memory_mb"] = j["memory_mb"]
            row["peak_rss_mb"] = j["peak_rss_mb"]
        else:
            row["scans"] = j["scans"]
        if base is None:
            base = row
        row["d_auc"] = auc - base["auc"]
        row["d_nll"] = nll - base["nll"]
        row["speedup"] = base["wall_s"] / wall
        rows.append(row)
        print("  %s %s: %.1f s, AUC %.4f NLL %.4f" % (name, label(row), wall, auc, nll), flush=True)
    return rows


def label(r):
    return ("one process " + r["options"]).strip() if not r["ranks"] else "%d" % r["ranks"]


def city(one, kept, merged):
    """Kilometres of drive a rank maps in an hour at the one process's keyframe rate; the
    memory a rank's part takes with every tile kept, and rank 0's merge, per km."""
    km = one["path_m"] / 1000
    spacing = one["path_m"] / max(one["keyframes"] - 1, 1)
    per_hour = 3600e3 / one["ms_per_keyframe"]
    km_hour = spacing * per_hour / 1000
    c = {"keyframe_spacing_m": spacing, "keyframes_per_rank_hour": per_hour,
         "km_per_rank_hour": km_hour, "rank_hours_for_1000_km": 1000 / km_hour}
    if kept:
        c["kept_tiles_mb_per_km"] = kept["memory_mb"] / km
    if merged:
        c["merge_s_per_km"] = (merged["merge_s"] + merged["export_s"]) / km
    return c


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--build", default="build")
    p.add_argument("--ranks", default="1,2,4")
    p.add_argument("--log", default=os.path.join(DATA, "radish", "intel-corrected.log.gz"))
    p.add_argument("--max-scans", type=int, default=0)
    p.add_argument("--drive", default=os.path.join(DATA, "drives3d", "riverside-a"))
    p.add_argument("--max-keyframes", type=int, default=40)
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--out", default="")
    a = p.parse_args()
    potmap = os.path.join(a.build, "tools", "potmap")
    ranks = [int(x) for x in a.ranks.split(",") if x]
    env = dict(os.environ)
    env.setdefault("POTMAP_CACHE_DIR", os.path.join(os.path.abspath(a.build), "kernel-cache"))
    res = {"load_average_start": os.getloadavg(), "cpus": os.cpu_count(), "repeat": a.repeat,
           "rows": []}
    with tempfile.TemporaryDirectory() as work:
        if a.log:
            log_args = [a.log] + (["--max-scans", str(a.max_scans)] if a.max_scans else [])
            res["rows"] += repeated("log", potmap, log_args, ranks, env, work, None, a.repeat)
        if a.drive:
            drive_args = [a.drive, "--max-scans", str(a.max_keyframes)]
            res["rows"] += repeated("drive", potmap, drive_args, ranks, env, work,
                                    ["--keep-tiles"], a.repeat)
    res["load_average_end"] = os.getloadavg()
    drive = [r for r in res["rows"] if r["data"] == "drive"]
    one = [r for r in drive if r["ranks"] == 0 and not r["options"]]
    kept = [r for r in drive if r["ranks"] == 0 and r["options"]]
    merged = [r for r in drive if r["ranks"] >= 2]
    if one:
        res["city"] = city(one[0], kept[0] if kept else None, merged[0] if merged else None)

    print("\n%s, %d CPUs, load average %.2f at the start, %.2f at the end" % (
        res["rows"][0]["device"] if res["rows"] else "", res["cpus"],
        res["load_average_start"][0], res["load_average_end"][0]))
    print("| data | ranks | wall | AUC / NLL | minus one process | merge + variances |")
    print("|---|---|---|---|---|---|")
    for r in res["rows"]:
        name = "%s (%s)" % (os.path.basename(a.log.rstrip("/")) if r["data"] == "log" else
                             os.path.basename(a.drive.rstrip("/")),
                             "%d scans" % r["scans"] if r["data"] == "log" else
                             "%d keyframes" % r["keyframes"])
        print("| %s | %s | %.1f s | %.4f / %.4f | %+.4f / %+.4f | %s |" % (
            name, label(r), r["wall_s"], r["auc"],
            r["nll"], r["d_auc"], r["d_nll"],
            "%.2f + %.2f s" % (r["merge_s"], r["export_s"]) if "merge_s" in r else "-"))
    if "city" in res:
        c = res["city"]
        print("\ncity: %.1f m between keyframes, %.0f keyframes a rank-hour: %.1f km of drive a "
              "rank-hour, %.0f rank-hours for 1000 km" % (
                  c["keyframe_spacing_m"], c["keyframes_per_rank_hour"], c["km_per_rank_hour"],
                  c["rank_hours_for_1000_km"]))
        if "kept_tiles_mb_per_km" in c and "merge_s_per_km" in c:
            print("      every tile kept: %.0f MB a km of drive; rank 0's merge: %.0f s a km" % (
                c["kept_tiles_mb_per_km"], c["merge_s_per_km"]))
    if a.out:
        with open(a.out, "w") as f:
            json.dump(res, f, indent=1)
        print("wrote", a.out)


if __name__ == "__main__":
    main()
