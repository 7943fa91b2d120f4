#!/usr/bin/env python3
"""Raster jobs at scale: end to end against the kernel, cells per second against tile size and
MPI ranks, and an estimate for a whole town. Prints tables and writes JSON.

Usage: bench/raster_scale.py [--build build] [--res 0.25,0.05] [--ranks 1,2]
                             [--tiles 256,512,1024] [--repeat 3] [--out raster-scale.json]
                             [--no-scale]

All rows come from this run on this machine, so the ratios hold wherever it runs:
  * kernel: BM_Town1GridOpenCL (0.25 m) and BM_Town1GridOpenCLFine (0.05 m) of potmap_bench,
    the grid of the whole Town 1 map, warm (programs built, buffers allocated); measured before
    and after the end-to-end runs of its resolution, the median of both sets taken, so a load
    that changes during the run shows in the spread rather than in the ratio;
  * end to end: `potmap raster` on the same window, PNG + .npy (the band writer) and the tiled
    GeoTIFF job, wall time of the whole process, split into what its --json reports (reading
    the map | opening the device, which run at once; the job) and the rest (process start and
    exit);
  * scale: the tiled job for every tile size and rank count (mpirun -n N), cells per second.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
TOWN1 = os.path.join(HERE, "..", "..", "shared", "data", "carla", "town1_abhm_map.csv")


def map_bounds(path):
    lo = [float("inf")] * 2
    hi = [-float("inf")] * 2
    with open(path) as f:
        next(f)
        for line in f:
            x, y = line.split(",")[:2]
            x, y = float(x), float(y)
            lo = [min(lo[0], x), min(lo[1], y)]
            hi = [max(hi[0], x), max(hi[1], y)]
    return lo, hi


KERNEL_BENCH = {0.25: "BM_Town1GridOpenCL", 0.05: "BM_Town1GridOpenCLFine"}


def kernel_runs(build, res, repeat):
    """Grid times (ms) of the kernel benchmark at res, its cell count and device label."""
    name = KERNEL_BENCH[res]
    out = tempfile.mktemp(suffix=".json")
    subprocess.run([os.path.join(build, "bench", "potmap_bench"),
                    "--benchmark_filter=^%s/" % name, "--benchmark_repetitions=%d" % repeat,
                    "--benchmark_out=" + out, "--benchmark_out_format=json"],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(out) as f:
        data = json.load(f)
    os.unlink(out)
    rows = [b for b in data["benchmarks"] if b.get("run_type") == "iteration"]
    return [r["real_time"] for r in rows], rows[0]["cells"], rows[0].get("label", "")


def median(v):
    v = sorted(v)
    n = len(v)
    return v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])


def wall(cmd, env):
    t = time.perf_counter()
    r = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    dt = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), r.stderr))
    return dt, r.stdout


def best(cmd, env, repeat, cleanup):
    """Median wall time of `repeat` runs, all the times, and the median run's stdout (so that
    the phases its --json reports belong to the run whose time is shown)."""
    runs = []
    for _ in range(repeat):
        cleanup()
        runs.append(wall(cmd, env))
    runs.sort(key=lambda r: r[0])
    dt, out = runs[len(runs) // 2]
    return dt, [r[0] for r in runs], out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--res", default="0.25,0.05", help="resolutions, metres: 0.25 and/or 0.05")
    ap.add_argument("--ranks", default="1,2")
    ap.add_argument("--tiles", default="256,512,1024")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-scale", action="store_true", help="skip the tile size and rank table")
    ap.add_argument("--out", default="raster-scale.json")
    a = ap.parse_args()
    potmap = os.path.join(a.build, "tools", "potmap")
    if not os.path.exists(TOWN1):
        sys.exit("needs ../shared/data/carla/town1_abhm_map.csv")
    resolutions = [float(r) for r in a.res.split(",")]
    for r in resolutions:
        if r not in KERNEL_BENCH:
            sys.exit("--res: %g has no kernel benchmark (0.25 or 0.05)" % r)
    lo, hi = map_bounds(TOWN1)
    bounds = "%r,%r,%r,%r" % (lo[0], hi[0], lo[1], hi[1])
    work = tempfile.mkdtemp(prefix="potmap-raster-scale-")
    env = dict(os.environ)
    env.setdefault("POTMAP_CACHE_DIR", os.path.join(work, "cache"))
    wall([potmap, "raster", "--map", TOWN1, "--bounds", bounds, "--res", "1", "--out",
          os.path.join(work, "warm"), "--no-png"], env)  # builds the programs once

    def clean():
        for name in os.listdir(work):
            if name != "cache":
                p = os.path.join(work, name)
                shutil.rmtree(p) if os.path.isdir(p) else os.unlink(p)

    results = {"machine": os.uname().nodename, "cores": os.cpu_count(),
               "load_average_start": os.getloadavg(), "rows": [], "kernel": [], "scale": []}
    print("%-6s %-20s %10s %9s %9s %7s   %s" % ("res", "job", "cells", "kernel s", "e2e s",
                                               "ratio", "read|device/job/start+exit s"))
    for res in resolutions:
        before, kcells, label = kernel_runs(a.build, res, a.repeat)
        results["device"] = label
        jobs = []
        for name, extra in (("PNG + .npy (bands)", ["--out", os.path.join(work, "w")]),
                            ("GeoTIFF, 512 tiles", ["--out", os.path.join(work, "w.tif")])):
            med, times, out = best([potmap, "raster", "--map", TOWN1, "--bounds", bounds, "--res",
                                    str(res), "--json"] + extra, env, a.repeat, clean)
            jobs.append((name, med, times, json.loads(out)))
        after, _, _ = kernel_runs(a.build, res, a.repeat)
        kernel_s = median(before + after) / 1000.0
        results["kernel"].append({"res": res, "benchmark": KERNEL_BENCH[res], "cells": kcells,
                                  "ms_before": before, "ms_after": after,
                                  "seconds": kernel_s})
        for name, med, times, j in jobs:
            cells = j.get("cells", j["width"] * j["height"])
            if cells != kcells:
                sys.exit("%s at %g m: %d cells, the kernel benchmark %d" % (name, res, cells,
                                                                            kcells))
            # Reading the map and opening the device run at once: setup_seconds is both.
            setup = j.get("setup_seconds", j["read_seconds"] + j["device_seconds"])
            rest = med - setup - j["seconds"]
            row = {"res": res, "job": name, "cells": cells, "seconds": med, "all": times,
                   "kernel_seconds": kernel_s, "ratio": med / kernel_s,
                   "read_seconds": j["read_seconds"], "device_seconds": j["device_seconds"],
                   "setup_seconds": setup, "job_seconds": j["seconds"],
                   "start_exit_seconds": rest}
            results["rows"].append(row)
            print("%-6g %-20s %10d %9.3f %9.3f %7.2f   %.3f|%.3f/%.3f/%.3f" % (
                res, name, cells, kernel_s, med, row["ratio"], j["read_seconds"],
                j["device_seconds"], j["seconds"], rest))
        print("       (kernel %s: %s ms before, %s ms after)" % (
            KERNEL_BENCH[res], " ".join("%.0f" % t for t in before),
            " ".join("%.0f" % t for t in after)))
    print("device: %s; load average at the start %.2f, at the end %.2f" % (
        results.get("device", ""), results["load_average_start"][0], os.getloadavg()[0]))
    results["load_average_end"] = os.getloadavg()
    if a.no_scale:
        shutil.rmtree(work, ignore_errors=True)
        with open(a.out, "w") as f:
            json.dump(results, f, indent=2)
        print("wrote", a.out)
        return

    ranks = [int(r) for r in a.ranks.split(",")]
    tiles = [int(t) for t in a.tiles.split(",")]
    mpirun = shutil.which("mpirun")
    print("\n%-6s %-6s %10s %10s %12s" % ("tile", "ranks", "cells", "seconds", "Mcells/s"))
    for t in tiles:
        for n in ranks:
            cmd = [potmap, "raster", "--map", TOWN1, "--bounds", bounds, "--res", "0.25",
                   "--tile", str(t), "--json", "--out", os.path.join(work, "s.tif")]
            if n > 1:
                if not mpirun:
                    continue
                cmd = [mpirun, "-n", str(n), "--allow-run-as-root", "--oversubscribe", "-x",
                       "POTMAP_CACHE_DIR"] + cmd
            med, times, out = best(cmd, env, a.repeat, clean)
            j = json.loads(out)
            cells = j["width"] * j["height"]
            row = {"tile": t, "ranks": n, "cells": cells, "tiles": j["tiles"], "seconds": med,
                   "all": times, "cells_per_s": cells / med}
            results["scale"].append(row)
            print("%-6d %-6d %10d %10.3f %12.2f" % (t, n, cells, med, cells / med / 1e6))

    fastest = max(results["scale"], key=lambda r: r["cells_per_s"])
    city = 1e10  # 10 km x 10 km at 0.1 m
    per_rank = fastest["cells_per_s"] / fastest["ranks"]
    results["estimate"] = {
        "cells": city, "best": fastest, "cells_per_s_per_rank": per_rank,
        "hours_one_rank": city / per_rank / 3600.0,
        "note": "Town 1 kernel density; one rank = one device of this kind"}
    minutes = city / per_rank / 60.0
    print("\n10 km x 10 km at 0.1 m (1e10 cells), at this run's best %.2f M cells/s per rank "
          "(tile %d, %d ranks): %.0f min on one rank, %.1f min on 16, %.1f min on 64 (ranks "
          "with a device each)" % (per_rank / 1e6, fastest["tile"], fastest["ranks"], minutes,
                                   minutes / 16, minutes / 64))
    shutil.rmtree(work, ignore_errors=True)
    with open(a.out, "w") as f:
        json.dump(results, f, indent=2)
    print("wrote", a.out)


if __name__ == "__main__":
    main()
