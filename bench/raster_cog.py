#!/usr/bin/env python3
"""A dense GeoTIFF job against its kernel, in one run: `potmap raster ... OUT.tif` (the tiled,
resumable Cloud-Optimized GeoTIFF) end to end beside the grid kernel alone on the same cells,
the whole Town 1 map at 0.05 m (8692 x 7384 = 64.2 M cells). Prints a table and writes JSON.

Usage: bench/raster_cog.py [--build build] [--repeat 5] [--out docs/raster-cog.json] [--npy]
                           [--level N ...]

The runs alternate (kernel, GeoTIFF, kernel, GeoTIFF, ...), so that a load that changes while
it runs (other builds on a shared machine) falls on both sides of the ratio; the ratio is the
median GeoTIFF time over the median kernel time, and the JSON keeps every time and the load
average before and after, and the job's CPU time (user + system of all its threads, PoCL's
included), which on a loaded machine still compares the work done. Kernel: BM_Town1GridOpenCLFine of potmap_bench, one iteration per
process, warm (program built, buffers allocated). End to end: the whole `potmap raster`
process, wall time from exec to exit, with the phases its --json reports (the GeoTIFF job's:
evaluating the tiles, the writer compressing and storing them beside that, the evaluation
waiting for the writer, the assembly). --npy adds the PNG + .npy job (the band writer) to each
round; --level N (repeatable) adds the GeoTIFF job at ZSTD level N beside the default level.
Each GeoTIFF row gives its file's size.
"""
import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
TOWN1 = os.path.join(HERE, "..", "..", "shared", "data", "carla", "town1_abhm_map.csv")
KERNEL = "BM_Town1GridOpenCLFine"
RES = 0.05
PHASES = ("evaluate", "store", "store_wait", "assemble")


def map_bounds(path):
    lo = [float("inf")] * 2
    hi = [-float("inf")] * 2
    with open(path) as f:
        next(f)
        for line in f:
            x, y = (float(v) for v in line.split(",")[:2])
            lo = [min(lo[0], x), min(lo[1], y)]
            hi = [max(hi[0], x), max(hi[1], y)]
    return lo, hi


def child_cpu():
    """User + system seconds of the children waited for so far (every thread of each)."""
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def kernel_once(build):
    """One kernel time (s), its cell count and device label."""
    fd, out = tempfile.mkstemp(suffix=".json")
    os.close(fd)
    subprocess.run([os.path.join(build, "bench", "potmap_bench"),
                    "--benchmark_filter=^%s/" % KERNEL, "--benchmark_out=" + out,
                    "--benchmark_out_format=json"],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(out) as f:
        data = json.load(f)
    os.unlink(out)
    row = [b for b in data["benchmarks"] if b.get("run_type") == "iteration"][0]
    return row["real_time"] / 1000.0, row["cells"], row.get("label", "")


def job_once(cmd, env):
    t, c = time.perf_counter(), child_cpu()
    r = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    dt = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), r.stderr))
    j = json.loads(r.stdout)
    j["cpu_seconds"] = child_cpu() - c
    if str(j.get("output", "")).endswith(".tif"):
        j["file_bytes"] = os.path.getsize(j["output"])
    return dt, j


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", default="raster-cog.json")
    ap.add_argument("--npy", action="store_true", help="also time the PNG + .npy job")
    ap.add_argument("--work", default=None, help="folder of the outputs (default: a temp dir)")
    ap.add_argument("--level", type=int, action="append", default=[],
                    help="also time the GeoTIFF job at this ZSTD level (repeatable)")
    a = ap.parse_args()
    if not os.path.exists(TOWN1):
        sys.exit("needs ../shared/data/carla/town1_abhm_map.csv")
    potmap = os.path.join(a.build, "tools", "potmap")
    lo, hi = map_bounds(TOWN1)
    bounds = "%r,%r,%r,%r" % (lo[0], hi[0], lo[1], hi[1])
    work = tempfile.mkdtemp(prefix="potmap-raster-cog-", dir=a.work)
    env = dict(os.environ)
    env.setdefault("POTMAP_CACHE_DIR", os.path.join(work, "cache"))
    base = [potmap, "raster", "--map", TOWN1, "--bounds", bounds, "--res", str(RES), "--json"]
    jobs = [("GeoTIFF (ZSTD, 512 tiles)", base + ["--out", os.path.join(work, "w.tif")])]
    for level in a.level:
        jobs.append(("GeoTIFF (ZSTD %d, 512 tiles)" % level,
                     base + ["--out", os.path.join(work, "w%d.tif" % level),
                             "--compress-level", str(level)]))
    if a.npy:
        jobs.append(("PNG + .npy", base + ["--out", os.path.join(work, "w")]))
    job_once(base[:-2] + ["1", "--json", "--no-png", "--out", os.path.join(work, "warm")], env)

    def clean():
        for name in os.listdir(work):
            if name != "cache":
                p = os.path.join(work, name)
                shutil.rmtree(p) if os.path.isdir(p) else os.unlink(p)

    load_start = os.getloadavg()
    kernel, runs, cells, label = [], {name: [] for name, _ in jobs}, 0, ""
    for i in range(a.repeat):
        k, cells, label = kernel_once(a.build)
        kernel.append(k)
        for name, cmd in jobs:
            clean()
            runs[name].append(job_once(cmd, env))
        print("round %d: kernel %.3f s, %s" % (i + 1, k, ", ".join(
            "%s %.3f s" % (n, runs[n][-1][0]) for n, _ in jobs)), flush=True)
    clean()
    load_end = os.getloadavg()
    kmed = statistics.median(kernel)
    result = {"device": label, "machine": os.uname().nodename, "cores": os.cpu_count(),
              "cells": cells, "resolution": RES, "kernel_benchmark": KERNEL,
              "kernel_seconds": kernel, "kernel_median": kmed,
              "load_average_start": load_start, "load_average_end": load_end, "jobs": []}
    print("\n%-26s %10s %10s %10s %8s  %s" % ("job", "cells", "kernel s", "e2e s", "ratio",
                                              "job / setup / start+exit s (median run)"))
    for name, _ in jobs:
        times = [t for t, _ in runs[name]]
        med = statistics.median(times)
        t, j = sorted(runs[name], key=lambda r: r[0])[len(times) // 2]
        n = j.get("cells", j["width"] * j["height"])
        if n != cells:
            sys.exit("%s: %d cells, the kernel benchmark %d" % (name, n, cells))
        row = {"job": name, "seconds": times, "median": med, "ratio": med / kmed,
               "job_seconds": j["seconds"], "setup_seconds": j["setup_seconds"],
               "start_exit_seconds": t - j["seconds"] - j["setup_seconds"],
               "cpu_seconds": j["cpu_seconds"]}
        if "file_bytes" in j:
            row["file_bytes"] = j["file_bytes"]
        phases = {k: j[k + "_seconds"] for k in PHASES if k + "_seconds" in j}
        if phases:
            row["phases_seconds"] = phases
        result["jobs"].append(row)
        print("%-26s %10d %10.3f %10.3f %7.2fx  %.3f / %.3f / %.3f" % (
            name, cells, kmed, med, row["ratio"], j["seconds"], j["setup_seconds"],
            row["start_exit_seconds"]))
        if phases:
            print("%-26s %s" % ("", ", ".join("%s %.3f s" % (k, v) for k, v in phases.items())))
        print("%-26s CPU (user + system, all threads) %.2f s%s" % (
            "", j["cpu_seconds"],
            ", file %.1f MB" % (j["file_bytes"] / 1e6) if "file_bytes" in j else ""))
    print("device: %s; %d rounds; load average %.2f at the start, %.2f at the end" % (
        label, a.repeat, load_start[0], load_end[0]))
    shutil.rmtree(work, ignore_errors=True)
    with open(a.out, "w") as f:
        json.dump(result, f, indent=2)
    print("wrote", a.out)


if __name__ == "__main__":
    main()
