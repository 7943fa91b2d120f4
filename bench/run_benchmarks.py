#!/usr/bin/env python3
"""Runs potmap's benchmarks, prints a table and writes the raw and summarised JSON.

Usage: bench/run_benchmarks.py [--build build] [--filter REGEX] [--out bench-results.json]
                               [--min-time 0.3]

Every row names the device that ran it (the benchmark's label); rows of the CPU reference are
paired with the OpenCL rows of the same map size to give the speed-up per query.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile


def run(binary, flt, min_time):
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as tmp:
        path = tmp.name
    cmd = [binary, "--benchmark_filter=" + flt, "--benchmark_out=" + path,
           "--benchmark_out_format=json", "--benchmark_min_time=%s" % min_time]
    print("running:", " ".join(cmd), file=sys.stderr)
    subprocess.run(cmd, check=True, stdout=sys.stderr)
    with open(path) as f:
        data = json.load(f)
    os.unlink(path)
    return data


def si(x):
    for unit, div in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if abs(x) >= div:
            return "%.2f %s" % (x / div, unit)
    return "%.2f" % x


def pot_table(rows):
    """Per-scan latency of POT/RePOT split by stage, with the map's scores, and the reference's
    time over the OpenCL one for the same atoms, rotations and refine setting."""
    pot = [r for r in rows if r["name"].startswith(("BM_PotOpenCL", "BM_PotReference"))]
    if not pot:
        return
    ref = {r["name"].split("/", 1)[1].split("/iterations")[0]: r["extra"].get("total_ms")
           for r in pot if r["name"].startswith("BM_PotReference")}
    cols = ("total_ms", "total_ms_median", "total_ms_p90", "ranking_ms", "transport_ms",
            "placement_ms", "refine_ms", "prepare_ms")
    w = max(len(r["name"]) for r in pot)
    print()
    print("%-*s %8s %8s %8s %8s %9s %9s %8s %8s %6s %6s %6s %8s" % (
        w, "POT per scan (ms)", "mean", "median", "p90", "ranking", "transport", "placement",
        "refine", "prepare", "ACC", "AUC", "NLL", "ref/ocl"))
    for r in pot:
        e = r["extra"]
        key = r["name"].split("/", 1)[1].split("/iterations")[0]
        ratio = ref.get(key)
        r["reference_over_opencl"] = (ratio / e["total_ms"]) if (
            ratio and r["name"].startswith("BM_PotOpenCL") and e.get("total_ms")) else None
        print("%-*s %8s %8s %8s %8s %9s %9s %8s %8s %6.3f %6.3f %6.3f %8s" % ((w, r["name"]) + tuple(
            ("%.1f" % e[c]) if c in e else "-" for c in cols) + (
            e.get("acc", 0), e.get("auc", 0), e.get("nll", 0),
            ("%.0fx" % r["reference_over_opencl"]) if r["reference_over_opencl"] else "-")))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build", help="CMake build folder (default: build)")
    ap.add_argument("--filter", default=".", help="benchmark name regex (default: all)")
    ap.add_argument("--out", default="bench-results.json", help="summary JSON path")
    ap.add_argument("--min-time", default="0.3", help="seconds per benchmark (default 0.3)")
    args = ap.parse_args()
    binary = os.path.join(args.build, "bench", "potmap_bench")
    if not os.path.exists(binary):
        sys.exit("no benchmark binary at %s: build with -DPOTMAP_BUILD_BENCH=ON" % binary)
    data = run(binary, args.filter, args.min_time)

    rows = []
    for b in data["benchmarks"]:
        if b.get("run_type") == "aggregate":
            continue
        rows.append({
            "name": b["name"].replace("/real_time", ""),
            "device": b.get("label", ""),
            "ms": b["real_time"] if b.get("time_unit") == "ms" else b["real_time"] / 1e6,
            "queries_per_s": b.get("queries_per_s"),
            "kernel_evals_per_s": b.get("kernel_evals_per_s"),
            "extra": {k: v for k, v in b.items()
                      if k.endswith("_per_s") or k.endswith("_ms") or k.endswith("_ms_median")
                      or k.endswith("_ms_p90")
                      or k in ("iterations_used", "converged", "acc", "auc", "nll", "kernels")},
        })
    # Speed-up of OpenCL over the reference per query: a reference row BM_<F>Reference[/size]
    # pairs with every OpenCL row BM_<F...>OpenCL[/size] whose family starts with F.
    pat = re.compile(r"BM_(\w+?)(OpenCL|Reference)(?:/(\d+))?")
    ref = {}
    for r in rows:
        m = pat.match(r["name"])
        if m and m.group(2) == "Reference" and r["queries_per_s"]:
            ref[(m.group(1), m.group(3))] = r["queries_per_s"]
    for r in rows:
        m = pat.match(r["name"])
        r["speedup_vs_reference"] = None
        if not (m and m.group(2) == "OpenCL" and r["queries_per_s"]):
            continue
        for (fam, size), qps in ref.items():
            if m.group(1).startswith(fam) and size == m.group(3):
                r["speedup_vs_reference"] = r["queries_per_s"] / qps
    w = max(len(r["name"]) for r in rows) if rows else 10
    print("%-*s %10s %14s %16s %9s  %s" % (w, "benchmark", "ms", "queries/s", "kernel evals/s", "vs ref", "device"))
    for r in rows:
        print("%-*s %10.2f %14s %16s %9s  %s" % (
            w, r["name"], r["ms"],
            si(r["queries_per_s"]) if r["queries_per_s"] else "-",
            si(r["kernel_evals_per_s"]) if r["kernel_evals_per_s"] else "-",
            ("%.1fx" % r["speedup_vs_reference"]) if r["speedup_vs_reference"] else "-",
            r["device"]))
    pot_table(rows)
    summary = {"context": data.get("context", {}), "rows": rows}
    tmp = args.out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(summary, f, indent=1)
    os.replace(tmp, args.out)
    print("wrote", args.out, file=sys.stderr)


if __name__ == "__main__":
    main()
