#!/usr/bin/env python3
"""3D drives: the continuous maps against OctoMap, keyframe by keyframe, in one run.

Usage: bench/drive3d.py [--build build] [--drives riverside-a,hku-1] [--cuts 20,40]
                        [--keyframes 30] [--source 10] [--methods ogm,bhm,pot,repot]
                        [--mapping bhm,repot] [--wavemap] [--out docs/drive3d-speed.json]
                        [--doc docs/drives-3d.md] [-- EXTRA potmap experiment options]

For every drive of ../shared/data/drives3d and every cut (a horizontal range, metres, applied
to every method alike), `potmap experiment intra` maps keyframes [source, keyframes) of the
drive (the first `source` keyframes are POT's atoms) with OctoMap at 0.1 and 0.2 m and the
joint BHM at the 3D drive defaults below, every method scored on the same held-out beams
(20 % of each keyframe's). The table gives AUC / NLL and milliseconds per keyframe (the whole
fit: BHM's gathering of samples per voxel, its updates and the map's export; OctoMap's ray
casting of the training beams), and each method's time as a ratio to OctoMap 0.2 m's in the
same run, so the ratio holds on a machine shared with other jobs. The JSON holds every run.

Then, right after each experiment, `potmap mapping DRIVE --method M` (--mapping: bhm, repot)
maps the same keyframes at the same cut as a user runs it (RePOT with the built-in 3D
dictionary, a transfer every 4th keyframe; its build is not timed): the rows "mapping BHM" and
"mapping RePOT", whose time is the mapper's per keyframe (gathering, transfer, update) against
that experiment's OctoMap 0.2 m. Their scores are on every 4th held-out sample (the mapper
keeps a quarter), the experiment's on all of them.

--doc FILE puts the table into FILE between the lines "<!-- bench/drive3d.py table -->" and
"<!-- end of bench/drive3d.py table -->", so the page shows the figures of the JSON it writes;
then the figures other pages take from that JSON (docs/figures.json, scripts/make_doc_figures.py)
are carried to every page.

--wavemap adds a second peer, wavemap (github.com/ethz-asl/wavemap), beside OctoMap: the method
"wavemap" of `potmap experiment`, at the cells of --wavemap-cells (default 0.1 and 0.2 m), on
the same keyframes, cut and training beams, scored on the same held-out samples, and a column
"map MB" (each method's own count of its map: OctoMap's memoryUsage(), wavemap's
getMemoryUsage(), the joint BHM learner's memory_bytes()). Its table goes between
"<!-- bench/drive3d.py wavemap table -->" and "<!-- end of bench/drive3d.py wavemap table -->".
It needs a potmap built with wavemap, which CI never does. With wavemap's sources in WAVEMAP
(github.com/ethz-asl/wavemap, outside this repository) and PREFIX a folder to install it in:

  apt-get install libgoogle-glog-dev libeigen3-dev libboost-dev
  cmake -S WAVEMAP/library/cpp -B WAVEMAP/build -DCMAKE_BUILD_TYPE=Release \
        -DCMAKE_INSTALL_PREFIX=PREFIX
  cmake --build WAVEMAP/build -j2 && cmake --install WAVEMAP/build
  cmake -S . -B build-wavemap -DCMAKE_BUILD_TYPE=Release -DPOTMAP_WAVEMAP_DIR=PREFIX
  cmake --build build-wavemap --target potmap_cli
  bench/drive3d.py --build build-wavemap --wavemap --methods ogm,bhm --mapping '' \
        --out docs/drive3d-wavemap.json --doc docs/drives-3d.md
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile

from marked_doc import refresh_figures, replace_marked

HERE = os.path.dirname(os.path.abspath(__file__))
DRIVES = os.path.join(HERE, "..", "..", "shared", "data", "drives3d")

# The 3D drive defaults of the joint BHM (include/potmap/experiments/experiment_frames.hpp,
# drive_bhm_setup): kernels 1 m apart, 0.5 free samples a metre gathered per 0.5 m voxel,
# feature cut-off 4.5, one ring of solve margin, two EM rounds, CG tolerance 1e-4.
BHM_3D = ["--bhm-spacing", "1", "--free-per-metre", "0.5", "--bhm-voxel", "0.5",
          "--bhm-tau", "4.5", "--bhm-margin", "1", "--bhm-em", "2", "--bhm-cg-tol", "1e-4"]


def run(build, drive, cut, keyframes, source, methods, extra):
    out = tempfile.mktemp(suffix=".json")
    cmd = [os.path.join(build, "tools", "potmap"), "experiment", "intra",
           os.path.join(DRIVES, drive), "--scans", str(keyframes), "--source-scans",
           str(source), "--methods", methods, "--ogm-cells", "0.1", "0.2", "--seeds", "0",
           "--max-range", str(cut), "--json", out] + BHM_3D + extra
    print("bench/drive3d.py:", " ".join(cmd[1:]), file=sys.stderr, flush=True)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    with open(out) as f:
        data = json.load(f)
    os.unlink(out)
    return data


def run_mapping(build, drive, cut, keyframes, source, method):
    out = tempfile.mkdtemp()
    cmd = [os.path.join(build, "tools", "potmap"), "mapping", os.path.join(DRIVES, drive),
           "--method", method, "--range-cut", str(cut), "--first", str(source), "--max-scans",
           str(keyframes - source), "--checkpoint-every", "0", "--checkpoint-seconds", "0", "-q", "-o", out, "--json", "-"]
    print("bench/drive3d.py:", " ".join(cmd[1:]), file=sys.stderr, flush=True)
    done = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True)
    subprocess.run(["rm", "-rf", out], check=True)
    return json.loads(done.stdout)


def put_table(doc, table, device, name="table"):
    """Replaces the marked table of `doc`."""
    body = "\n".join(["", "Device: %s, %d CPUs." % (device, os.cpu_count()), ""] + table + [""])
    replace_marked(doc, "bench/drive3d.py", name, body)


def make_table(rows, memory):
    """The Markdown table; `memory` adds each map's own count of its memory."""
    head = "| drive | cut | method | AUC | NLL | ms / keyframe | x OctoMap 0.2 m |"
    table = [head + (" map MB |" if memory else ""), "|---" * (8 if memory else 7) + "|"]
    for r in rows:
        line = "| %s | %g m | %s | %.3f | %.3f | %.0f | %.2f |" % (
            r["drive"], r["cut_m"], r["method"], r["auc"], r["nll"], r["ms_per_keyframe"],
            r["ratio_to_octomap_0.2"])
        if memory:
            mb = r.get("map_mb")
            line += " %s |" % ("%.1f" % mb if mb is not None else "")
        table.append(line)
    return table


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(HERE, "..", "build"))
    ap.add_argument("--drives", default="riverside-a,hku-1")
    ap.add_argument("--cuts", default="20,40")
    ap.add_argument("--keyframes", type=int, default=30)
    ap.add_argument("--source", type=int, default=10)
    ap.add_argument("--methods", default="ogm,bhm,pot,repot")
    ap.add_argument("--mapping", default="bhm,repot",
                    help="potmap mapping methods run after each experiment ('' for none)")
    ap.add_argument("--wavemap", action="store_true",
                    help="add wavemap beside OctoMap (a build with -DPOTMAP_WAVEMAP_DIR)")
    ap.add_argument("--out", default="drive3d-speed.json")
    ap.add_argument("--doc", default="", help="page whose marked table this run replaces")
    ap.add_argument("extra", nargs="*", help="more potmap experiment intra options (after --)")
    a = ap.parse_args()
    methods = a.methods + (",wavemap" if a.wavemap and "wavemap" not in a.methods else "")
    rows, device = [], ""
    for drive in a.drives.split(","):
        for cut in a.cuts.split(","):
            data = run(a.build, drive, cut, a.keyframes, a.source, methods, a.extra)
            device = data.get("device", "")
            runs = data["runs"]
            base = next(r for r in runs if r["method"] == "OGM 0.2 m")["ms_per_scan"]
            for r in runs:
                rows.append({"drive": drive, "cut_m": float(cut), "method": r["method"],
                             "auc": r["auc"], "nll": r["nll"], "acc": r["acc"],
                             "ms_per_keyframe": r["ms_per_scan"],
                             "ratio_to_octomap_0.2": r["ms_per_scan"] / base,
                             "keyframes": r["scans"], "n_test": r["n_test"],
                             "map_mb": r.get("info", {}).get("memory_mb")})
            for m in [x for x in a.mapping.split(",") if x]:
                j = run_mapping(a.build, drive, cut, a.keyframes, a.source, m)
                rows.append({"drive": drive, "cut_m": float(cut), "method": "mapping " + j["method"],
                             "auc": j["scores"]["auc"], "nll": j["scores"]["nll"],
                             "acc": j["scores"]["acc"], "ms_per_keyframe": j["ms_per_keyframe"],
                             "ratio_to_octomap_0.2": j["ms_per_keyframe"] / base,
                             "keyframes": j["keyframes"], "n_test": j["scores"]["n"],
                             "transfer_ms_per_keyframe": j.get("transfer_ms_per_keyframe", 0)})
    table = make_table(rows, a.wavemap)
    print("\n".join(table))
    if a.doc:
        put_table(a.doc, table, device, "wavemap table" if a.wavemap else "table")
    meta = {"command": "bench/drive3d.py " + " ".join(sys.argv[1:]), "device": device,
            "machine": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(), "keyframes": a.keyframes, "source": a.source,
            "bhm_options": BHM_3D, "rows": rows}
    with open(a.out + ".tmp", "w") as f:
        json.dump(meta, f, indent=1)
    os.replace(a.out + ".tmp", a.out)
    print("bench/drive3d.py: wrote", a.out, file=sys.stderr)
    if a.doc:
        refresh_figures()  # the figures other pages take from docs/drive3d-speed.json


if __name__ == "__main__":
    main()
