#!/usr/bin/env python3
"""Whole drives through `potmap mapping`: the whole job against its keyframes, CPU, memory.

Usage: bench/drive_memory.py [--build build] [--drives riverside-a,hku-1] [--cut 40]
                             [--cores 2] [--out docs/drive-memory.json]
                             [--plot docs/drive-memory.png] [--doc docs/drives-3d.md]

Each drive of ../shared/data/drives3d is mapped end to end, as a user runs it (`potmap mapping
DRIVE`, the 3D drive defaults). The command reports, per keyframe, the memory its mapper holds
(the joint BHM's active tiles and retired tiles, the kept held-out samples) and the keyframe's
time (labelling, gathering, update, retiring), and at the end the process's peak resident
memory (VmHWM: everything, the OpenCL runtime and the exports included) and the scores on the
held-out beams. From outside, the script times the whole job (start to exit: reading, the
device's program builds, every keyframe, the scores and every output file) and takes the CPU
time it used (user + system, all threads), so the table gives the whole job's time as a multiple
of its keyframes' mapping time and the CPU use in per cent of one core. --cores 1,2 runs each
drive pinned to that many cores (taskset): the threads table. The table prints one row a drive
and core count; the JSON keeps the curves; the plot puts memory against keyframes; --doc FILE
puts the table between "<!-- bench/drive_memory.py table -->" and "<!-- end of
bench/drive_memory.py table -->", then carries the figures other pages take from the JSON
(docs/figures.json, scripts/make_doc_figures.py) to every page.
"""
import argparse
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time

from marked_doc import refresh_figures, replace_marked

HERE = os.path.dirname(os.path.abspath(__file__))
DRIVES = os.path.join(HERE, "..", "..", "shared", "data", "drives3d")


def run(build, drive, cut, cores):
    """The command's JSON, with the whole job's wall and CPU seconds measured from outside."""
    out = tempfile.mkdtemp(prefix="drive-memory-")
    cmd = [os.path.join(build, "tools", "potmap"), "mapping", os.path.join(DRIVES, drive),
           "--range-cut", str(cut), "-q", "-o", out, "--json", "-"]
    if cores:
        cmd = ["taskset", "-c", ",".join(str(c) for c in range(cores))] + cmd
    print("bench/drive_memory.py:", " ".join(cmd), file=sys.stderr, flush=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    r = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    shutil.rmtree(out, ignore_errors=True)
    j = json.loads(r.stdout)
    j["job_s"] = wall
    j["cpu_s"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return j


def plot(rows, path):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("bench/drive_memory.py: no matplotlib, no plot", file=sys.stderr)
        return
    fig, ax = plt.subplots(figsize=(7, 3.6), dpi=110)
    for r in rows:
        ax.plot(range(1, len(r["memory_mb"]) + 1), r["memory_mb"],
                label="%s (%.1f km; peak RSS of the whole run %.0f MB)"
                % (r["drive"], r["path_km"], r["peak_rss_mb"]))
    ax.set_xlabel("keyframes mapped")
    ax.set_ylabel("mapper memory (MB)")
    ax.set_ylim(bottom=0)
    ax.set_title("potmap mapping: memory follows the place, not the drive (%g m cut)"
                 % rows[0]["cut_m"], fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    print("bench/drive_memory.py: wrote", path, file=sys.stderr)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(HERE, "..", "build"))
    ap.add_argument("--drives", default="riverside-a,hku-1")
    ap.add_argument("--cut", type=float, default=40)
    ap.add_argument("--out", default="drive-memory.json")
    ap.add_argument("--plot", default="")
    ap.add_argument("--cores", default="", help="comma-separated core counts (taskset)")
    ap.add_argument("--doc", default="")
    a = ap.parse_args()
    rows = []
    cores = [int(c) for c in a.cores.split(",")] if a.cores else [0]
    for drive in a.drives.split(","):
        for c in cores:
            j = run(a.build, drive, a.cut, c)
            ms = j["keyframe_ms"]
            keyframes_s = sum(ms) / 1000
            rows.append({"drive": drive, "cut_m": a.cut, "cores": c or os.cpu_count(),
                         "job_s": j["job_s"], "cpu_s": j["cpu_s"], "keyframes_s": keyframes_s,
                         "job_per_keyframes": j["job_s"] / keyframes_s,
                         "cpu_percent": 100 * j["cpu_s"] / j["job_s"], "keyframes": j["keyframes"],
                         "path_km": j.get("path_m", 0) / 1000, "auc": j["scores"]["auc"],
                         "nll": j["scores"]["nll"], "ms_per_keyframe": j["ms_per_keyframe"],
                         "max_keyframe_ms": max(ms), "kernels": j["kernels"],
                         "final_memory_mb": j["memory_mb"], "mapper_peak_mb": j["peak_memory_mb"],
                         "peak_rss_mb": j["peak_rss_mb"], "mapping_s": j["mapping_s"],
                         "outputs_s": j["outputs_s"], "memory_mb": j["keyframe_memory_mb"],
                         "keyframe_ms": ms, "device": j["device"]})
    table = [
        "| drive | cores | keyframes | AUC | NLL | ms / keyframe | keyframes s | whole job s "
        "| job / keyframes | CPU % | outputs s | kernels | mapper MB (end / peak) | peak RSS MB |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        table.append(
            "| %s | %d | %d | %.3f | %.3f | %.0f | %.1f | %.1f | %.2f | %.0f | %.1f | %d "
            "| %.0f / %.0f | %.0f |" % (
                r["drive"], r["cores"], r["keyframes"], r["auc"], r["nll"], r["ms_per_keyframe"],
                r["keyframes_s"], r["job_s"], r["job_per_keyframes"], r["cpu_percent"],
                r["outputs_s"], r["kernels"], r["final_memory_mb"], r["mapper_peak_mb"],
                r["peak_rss_mb"]))
    device = rows[0]["device"] if rows else ""
    table += ["", "Device: %s; %d CPUs (%s)." % (device, os.cpu_count(),
                                                 platform.processor() or platform.machine())]
    print("\n".join(table))
    meta = {"command": "bench/drive_memory.py " + " ".join(sys.argv[1:]),
            "machine": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
            "rows": rows}
    with open(a.out + ".tmp", "w") as f:
        json.dump(meta, f, indent=1)
    os.replace(a.out + ".tmp", a.out)
    if a.plot:
        plot([r for r in rows if r["cores"] == rows[0]["cores"]], a.plot)
    if a.doc:
        replace_marked(a.doc, "bench/drive_memory.py", "table", "\n" + "\n".join(table) + "\n")
        refresh_figures()


if __name__ == "__main__":
    main()
