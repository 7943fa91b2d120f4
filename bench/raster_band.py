#!/usr/bin/env python3
"""A 3D map's height band rastered end to end against its kernel, in one run: `potmap raster
--band ZLO,ZHI` (PNG + .npy, and the tiled GeoTIFF) beside the band kernel alone
(MapEvaluator::evaluate_band_max, bench/raster_band_kernel.cpp) on the same cells and heights.
Prints a table and writes JSON.

Usage: bench/raster_band.py --map MAP.potmap [--build build] [--res 0.1] [--band -1,1.5]
                            [--band-step 0] [--bounds X0,X1,Y0,Y1] [--repeat 3] [--out JSON]

The map is a 3D map, e.g. `potmap mapping ../shared/data/drives3d/riverside-a --max-scans 30
-o /tmp/band-map` (map.potmap there); the window defaults to the kernels' extent. The runs
alternate (kernel, PNG + .npy, GeoTIFF, kernel, ...) so that a load that changes while it runs
falls on both sides of the ratio; the ratio is the median end-to-end time over the median
kernel time. CPU time (user + system of every thread; PoCL's CPU device runs in the process) is
reported beside wall time: on a machine that other work loads, its ratio still compares the
work done. Kernel: warm (program built, buffers allocated), in its own process. End to end:
the whole `potmap raster` process, wall time from exec to exit, with the phases its --json
reports.
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


def kernel_once(build, args):
    r = subprocess.run([os.path.join(build, "bench", "raster_band_kernel")] + args + ["1"],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit("kernel failed: %s" % r.stderr)
    j = json.loads(r.stdout)
    return j["seconds"][0], j["cpu_seconds"][0], j


def children_cpu():
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def job_once(cmd, env):
    """Wall time, CPU time (user + system, every thread) and the --json summary."""
    c = children_cpu()
    t = time.perf_counter()
    r = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    dt = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(map(str, cmd)), r.stderr))
    return dt, children_cpu() - c, json.loads(r.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--map", required=True)
    ap.add_argument("--build", default="build")
    ap.add_argument("--res", type=float, default=0.1)
    ap.add_argument("--band", default="-1,1.5")
    ap.add_argument("--band-step", type=float, default=0.0)
    ap.add_argument("--bounds", default=None)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default="raster-band.json")
    ap.add_argument("--keep", default=None, help="copy the last PNG + .npy outputs to this prefix")
    a = ap.parse_args()
    potmap = os.path.join(a.build, "tools", "potmap")
    work = tempfile.mkdtemp(prefix="potmap-raster-band-")
    env = dict(os.environ)
    env.setdefault("POTMAP_CACHE_DIR", os.path.join(work, "cache"))
    bounds = a.bounds or kernel_once(a.build, [a.map, "auto", repr(a.res), a.band,
                                               repr(a.band_step)])[2]["bounds"]
    kargs = [a.map, bounds, repr(a.res), a.band, repr(a.band_step)]
    base = [potmap, "raster", "--map", a.map, "--bounds", bounds, "--res", repr(a.res),
            "--band=" + a.band, "--band-step", repr(a.band_step), "--json"]
    jobs = [("PNG + .npy", base + ["--out", os.path.join(work, "w")]),
            ("GeoTIFF (ZSTD, 512 tiles)", base + ["--out", os.path.join(work, "w.tif")])]
    job_once(base + ["--no-png", "--no-npy", "--out", os.path.join(work, "warm")], env)

    def clean():
        for name in os.listdir(work):
            if name != "cache":
                p = os.path.join(work, name)
                shutil.rmtree(p) if os.path.isdir(p) else os.unlink(p)

    load_start = os.getloadavg()
    kernel, kernel_cpu, runs, info = [], [], {name: [] for name, _ in jobs}, {}
    for i in range(a.repeat):
        k, kc, info = kernel_once(a.build, kargs)
        kernel.append(k)
        kernel_cpu.append(kc)
        for name, cmd in jobs:
            clean()
            runs[name].append(job_once(cmd, env))
            if a.keep and name == "PNG + .npy" and i == a.repeat - 1:
                for f in ("_prob.png", "_var.png", "_prob.npy", "_var.npy"):
                    shutil.copy(os.path.join(work, "w" + f), a.keep + f)
        print("round %d: kernel %.3f s, %s" % (i + 1, k, ", ".join(
            "%s %.3f s" % (n, runs[n][-1][0]) for n, _ in jobs)), flush=True)
    clean()
    load_end = os.getloadavg()
    kmed = statistics.median(kernel)
    kcpu = statistics.median(kernel_cpu)
    cells = info["cells"]
    result = {"device": info["device"], "machine": os.uname().nodename, "cores": os.cpu_count(),
              "map": os.path.abspath(a.map), "kernels": info["kernels"], "bounds": bounds,
              "resolution": a.res, "band": a.band, "levels": info["levels"],
              "level_spacing": info["level_spacing"], "cells": cells,
              "cell_levels": cells * info["levels"], "kernel_seconds": kernel,
              "kernel_median": kmed, "kernel_cpu_seconds": kernel_cpu, "kernel_cpu_median": kcpu, "load_average_start": load_start,
              "load_average_end": load_end, "jobs": []}
    print("\n%-26s %10s %7s %10s %10s %7s %12s %12s %7s  %s" % (
        "job", "cells", "levels", "kernel s", "e2e s", "ratio", "kernel cpu s", "e2e cpu s",
        "ratio", "job / setup / start+exit s (median run)"))
    for name, _ in jobs:
        times = [t for t, _, _ in runs[name]]
        cpus = [c for _, c, _ in runs[name]]
        med, cmed = statistics.median(times), statistics.median(cpus)
        t, _, j = sorted(runs[name], key=lambda r: r[0])[len(times) // 2]
        n = j.get("cells", j["width"] * j["height"])
        if n != cells or j["levels"] != info["levels"]:
            sys.exit("%s: %d cells, %d levels; the kernel %d, %d" % (
                name, n, j["levels"], cells, info["levels"]))
        row = {"job": name, "seconds": times, "median": med, "ratio": med / kmed,
               "cpu_seconds": cpus, "cpu_median": cmed, "cpu_ratio": cmed / kcpu,
               "job_seconds": j["seconds"], "setup_seconds": j["setup_seconds"],
               "start_exit_seconds": t - j["seconds"] - j["setup_seconds"]}
        result["jobs"].append(row)
        print("%-26s %10d %7d %10.3f %10.3f %6.2fx %12.3f %12.3f %6.2fx  %.3f / %.3f / %.3f" % (
            name, cells, info["levels"], kmed, med, row["ratio"], kcpu, cmed, row["cpu_ratio"],
            j["seconds"], j["setup_seconds"], row["start_exit_seconds"]))
    print("device: %s; %d kernels; %d rounds; load average %.2f at the start, %.2f at the end" % (
        info["device"], info["kernels"], a.repeat, load_start[0], load_end[0]))
    shutil.rmtree(work, ignore_errors=True)
    with open(a.out, "w") as f:
        json.dump(result, f, indent=2)
    print("wrote", a.out)


if __name__ == "__main__":
    main()
