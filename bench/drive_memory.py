#!/usr/bin/env python3
"""Whole drives through `potmap mapping`: memory against keyframes, time per keyframe, scores.

Usage: bench/drive_memory.py [--build build] [--drives riverside-a,hku-1] [--cut 40]
                             [--out docs/drive-memory.json] [--plot docs/drive-memory.png]

Each drive of ../shared/data/drives3d is mapped end to end, as a user runs it (`potmap mapping
DRIVE`, the 3D drive defaults). The command reports, per keyframe, the memory its mapper holds
(the joint BHM's active tiles and retired tiles, the kept held-out samples) and the keyframe's
time (labelling, gathering, update, retiring), and at the end the process's peak resident
memory (VmHWM: everything, the OpenCL runtime and the exports included) and the scores on the
held-out beams. The table prints one row a drive; the JSON keeps the curves; the plot puts
memory against keyframes.
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
DRIVES = os.path.join(HERE, "..", "..", "shared", "data", "drives3d")


def run(build, drive, cut):
    out = tempfile.mkdtemp(prefix="drive-memory-")
    cmd = [os.path.join(build, "tools", "potmap"), "mapping", os.path.join(DRIVES, drive),
           "--range-cut", str(cut), "-q", "-o", out, "--json", "-"]
    print("bench/drive_memory.py:", " ".join(cmd[1:]), file=sys.stderr, flush=True)
    r = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    return json.loads(r.stdout)


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
    a = ap.parse_args()
    rows = []
    for drive in a.drives.split(","):
        j = run(a.build, drive, a.cut)
        ms = j["keyframe_ms"]
        rows.append({"drive": drive, "cut_m": a.cut, "keyframes": j["keyframes"],
                     "path_km": j.get("path_m", 0) / 1000, "auc": j["scores"]["auc"],
                     "nll": j["scores"]["nll"], "ms_per_keyframe": j["ms_per_keyframe"],
                     "max_keyframe_ms": max(ms), "kernels": j["kernels"],
                     "final_memory_mb": j["memory_mb"], "mapper_peak_mb": j["peak_memory_mb"],
                     "peak_rss_mb": j["peak_rss_mb"], "mapping_s": j["mapping_s"],
                     "outputs_s": j["outputs_s"], "memory_mb": j["keyframe_memory_mb"],
                     "keyframe_ms": ms, "device": j["device"]})
    print("| drive | keyframes | AUC | NLL | ms / keyframe | kernels | mapper MB (end / peak) "
          "| peak RSS MB | mapping s | exports s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print("| %s | %d | %.3f | %.3f | %.0f | %d | %.0f / %.0f | %.0f | %.0f | %.0f |" % (
            r["drive"], r["keyframes"], r["auc"], r["nll"], r["ms_per_keyframe"], r["kernels"],
            r["final_memory_mb"], r["mapper_peak_mb"], r["peak_rss_mb"], r["mapping_s"],
            r["outputs_s"]))
    meta = {"command": "bench/drive_memory.py " + " ".join(sys.argv[1:]),
            "machine": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
            "rows": rows}
    with open(a.out + ".tmp", "w") as f:
        json.dump(meta, f, indent=1)
    os.replace(a.out + ".tmp", a.out)
    if a.plot:
        plot(rows, a.plot)


if __name__ == "__main__":
    main()
