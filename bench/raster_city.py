#!/usr/bin/env python3
"""A whole drive's map rastered end to end: `potmap raster` of the map's whole extent to a tiled
Cloud-Optimized GeoTIFF under `mpirun -n N` for each rank count, cells per second from exec to
exit, and each rank's peak memory (GNU time's maximum resident set size). Prints a table and
writes JSON.

Usage: bench/raster_city.py --map MAP.potmap --bounds X0,X1,Y0,Y1 [--build build] [--res 0.1]
                            [--z 0 | --band ZLO,ZHI] [--ranks 1,2] [--repeat 1] [--out JSON]

The map is a whole drive's, e.g. `potmap mapping ../shared/data/drives3d/riverside-a -o DIR`
(DIR/map.potmap); the window is its extent (the kernels' bounds, e.g. from DIR/map_band.yaml).
Every rank runs under /usr/bin/time -v, so the peak memory is per process; PoCL's CPU device
runs inside the process, so on a CPU the ranks share the machine's cores. Runs of different
rank counts alternate when --repeat is over 1; the table has each one's median.
"""
import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def rank_times(work, n):
    """Peak memory (MB), user and system seconds of each rank, from GNU time's reports."""
    out = []
    for r in range(n):
        with open(os.path.join(work, "time.%d" % r)) as f:
            text = f.read()
        field = lambda name: float(re.search(re.escape(name) + r":\s*([\d.]+)", text).group(1))
        out.append({"peak_mb": field("Maximum resident set size (kbytes)") / 1024.0,
                    "user_s": field("User time (seconds)"),
                    "system_s": field("System time (seconds)")})
    return out


def run_once(a, potmap, work, n, env):
    for name in os.listdir(work):
        p = os.path.join(work, name)
        shutil.rmtree(p) if os.path.isdir(p) else os.unlink(p)
    height = ["--band", a.band] if a.band else ["--z", repr(a.z)]
    raster = [potmap, "raster", "--map", a.map, "--bounds", a.bounds, "--res", repr(a.res),
              "--json", "--out", os.path.join(work, "city.tif")] + height
    # Each rank under its own GNU time, its report named by its rank.
    timed = "exec /usr/bin/time -v -o %s/time.${OMPI_COMM_WORLD_RANK:-0} \"$@\"" % work
    cmd = [shutil.which("mpirun"), "-n", str(n), "--oversubscribe", "--allow-run-as-root",
           "-x", "POTMAP_CACHE_DIR", "sh", "-c", timed, "sh"] + raster
    load = os.getloadavg()
    t = time.perf_counter()
    r = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), r.stderr[-4000:]))
    j = json.loads(r.stdout[r.stdout.index("{"):])
    size = os.path.getsize(os.path.join(work, "city.tif"))
    return {"wall_s": wall, "job": j, "ranks": rank_times(work, n), "load_before": load,
            "load_after": os.getloadavg(), "tif_bytes": size}


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--map", required=True)
    ap.add_argument("--bounds", required=True, help="X0,X1,Y0,Y1 metres: the map's extent")
    ap.add_argument("--build", default="build")
    ap.add_argument("--res", type=float, default=0.1)
    ap.add_argument("--z", type=float, default=0.0)
    ap.add_argument("--band", default=None, help="ZLO,ZHI: the height band instead of --z")
    ap.add_argument("--ranks", default="1,2")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--out", default="raster-city.json")
    ap.add_argument("--work", default=None, help="folder of the outputs (default: a temp dir)")
    ap.add_argument("--device-label", default="", help="the device, for the table")
    a = ap.parse_args()
    if not shutil.which("mpirun"):
        sys.exit("needs mpirun")
    potmap = os.path.join(a.build, "tools", "potmap")
    work = tempfile.mkdtemp(prefix="potmap-raster-city-", dir=a.work)
    env = dict(os.environ)
    env.setdefault("POTMAP_CACHE_DIR", os.path.join(tempfile.gettempdir(), "potmap-city-cache"))
    ranks = [int(r) for r in a.ranks.split(",")]
    runs = {n: [] for n in ranks}
    for i in range(a.repeat):
        for n in ranks:
            runs[n].append(run_once(a, potmap, work, n, env))
            r = runs[n][-1]
            print("round %d, %d rank(s): %.1f s, load %.2f" % (i + 1, n, r["wall_s"],
                                                              r["load_before"][0]), flush=True)
    shutil.rmtree(work, ignore_errors=True)
    result = {"map": os.path.abspath(a.map), "bounds": a.bounds, "resolution": a.res,
              "height": {"band": a.band} if a.band else {"z": a.z}, "device": a.device_label,
              "machine": os.uname().nodename, "cores": os.cpu_count(), "rows": []}
    print("\n%-6s %12s %7s %10s %10s %12s %14s  %s" % (
        "ranks", "cells", "tiles", "wall s", "job s", "Mcells/s", "peak MB/rank", "load"))
    for n in ranks:
        med = sorted(runs[n], key=lambda r: r["wall_s"])[len(runs[n]) // 2]
        j = med["job"]
        cells = j["width"] * j["height"]
        row = {"ranks": n, "cells": cells, "width": j["width"], "height": j["height"],
               "tiles": j["tiles"], "wall_seconds": [r["wall_s"] for r in runs[n]],
               "median_wall_s": med["wall_s"], "job_seconds": j["seconds"],
               "cells_per_s": cells / med["wall_s"],
               "peak_mb": [r["peak_mb"] for r in med["ranks"]], "per_rank": med["ranks"],
               "tif_bytes": med["tif_bytes"], "load_before": med["load_before"],
               "load_after": med["load_after"]}
        result["rows"].append(row)
        print("%-6d %12d %7d %10.1f %10.1f %12.2f %14s  %.2f -> %.2f" % (
            n, cells, j["tiles"], med["wall_s"], j["seconds"], row["cells_per_s"] / 1e6,
            "/".join("%.0f" % m for m in row["peak_mb"]), med["load_before"][0],
            med["load_after"][0]))
    with open(a.out, "w") as f:
        json.dump(result, f, indent=2)
    print("wrote", a.out)


if __name__ == "__main__":
    main()
