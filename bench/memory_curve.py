#!/usr/bin/env python3
"""Memory over long drives: runs build/bench/memory_curve for POT and RePOT
over every scan of freiburg-079 (4,791 scans) and over ten loops of the intel log, prints a
table (map and resident memory after warm-up and at the end, growth over the second half) and
writes the curves as JSON and a PNG.

Usage: bench/memory_curve.py [--build build] [--data ../shared/data/radish]
                             [--out docs/memory-curve] [--intel-loops 10] [--ranking indexed]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile


def run(build, log, method, loops, ranking, every):
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as f:
        path = f.name
    cmd = [os.path.join(build, "bench", "memory_curve"), "--log", log, "--method", method,
           "--loops", str(loops), "--ranking", ranking, "--every", str(every), "--out", path]
    print("+", " ".join(cmd), file=sys.stderr, flush=True)
    subprocess.run(cmd, check=True)
    with open(path) as f:
        row = json.load(f)
    os.unlink(path)
    return row


def summary(row):
    """Warm-up is the first loop (one loop: the first half); growth is over what follows."""
    c = row["curve"]
    n = c[-1]["scans"]
    warm_at = row["scans_per_loop"] if row["loops"] > 1 else n // 2
    warm = min(c, key=lambda p: abs(p["scans"] - warm_at))
    end = c[-1]
    mb = 1 / 1048576
    return {
        "name": f'{os.path.basename(row["log"]).split("-corrected")[0]} x{row["loops"]} {row["method"]}',
        "scans": n,
        "warm_scans": warm["scans"],
        "map_mb_warm": warm["map_bytes"] * mb,
        "map_mb_end": end["map_bytes"] * mb,
        "rss_mb_warm": warm["rss_bytes"] * mb,
        "rss_mb_end": end["rss_bytes"] * mb,
        "rss_max_mb": max(p["rss_bytes"] for p in c) * mb,
        "kernels_end": end["kernels"],
        "ms_per_scan": 1e3 * end["seconds"] / n,
    }


def plot(rows, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.5))
    for row in rows:
        s = summary(row)
        x = [p["scans"] for p in row["curve"]]
        axes[0].plot(x, [p["map_bytes"] / 1048576 for p in row["curve"]], label=s["name"])
        axes[1].plot(x, [p["kernels"] for p in row["curve"]], label=s["name"])
        axes[2].plot(x, [p["rss_bytes"] / 1048576 for p in row["curve"]], label=s["name"])
    axes[0].set_title("overall map (MB)")
    axes[1].set_title("overall map (kernels)")
    axes[2].set_title("process resident memory (MB)")
    for ax in axes:
        ax.set_xlabel("scans mapped")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f'potmap Mapper over long drives ({rows[0]["device"]})', fontsize=9)
    fig.tight_layout()
    fig.savefig(png, dpi=100)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--build", default="build")
    p.add_argument("--data", default="../shared/data/radish")
    p.add_argument("--out", default="docs/memory-curve")
    p.add_argument("--intel-loops", type=int, default=10)
    p.add_argument("--ranking", default="indexed")
    p.add_argument("--replot", action="store_true",
                   help="read OUT.json of an earlier run instead of running")
    a = p.parse_args()
    rows = []
    if a.replot:
        with open(a.out + ".json") as f:
            rows = json.load(f)["runs"]
    for log, loops in () if a.replot else (("freiburg-079", 1), ("intel", a.intel_loops)):
        for method in ("pot", "repot"):
            rows.append(run(a.build, f"{a.data}/{log}-corrected.log.gz", method, loops,
                            a.ranking, 25))
    print(f'device: {rows[0]["device"]}; ranking {rows[0]["ranking"]}; warm-up: the first loop '
          "(one loop: the first half)")
    print("| run | scans | map MB warm -> end | RSS MB warm -> end (max) | kernels | ms/scan |")
    print("|---|---|---|---|---|---|")
    for row in rows:
        s = summary(row)
        print(f'| {s["name"]} | {s["scans"]} | {s["map_mb_warm"]:.2f} -> {s["map_mb_end"]:.2f} '
              f'| {s["rss_mb_warm"]:.1f} -> {s["rss_mb_end"]:.1f} ({s["rss_max_mb"]:.1f}) '
              f'| {s["kernels_end"]} | {s["ms_per_scan"]:.1f} |')
    os.makedirs(os.path.dirname(a.out) or ".", exist_ok=True)
    with open(a.out + ".json", "w") as f:
        json.dump({"summary": [summary(r) for r in rows], "runs": rows}, f, indent=1)
    plot(rows, a.out + ".png")
    print(f"wrote {a.out}.json and {a.out}.png")


if __name__ == "__main__":
    main()
