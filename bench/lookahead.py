#!/usr/bin/env python3
"""Look-ahead on 3D drives: the map scored where the sensor goes next, before it gets there.

Usage: PYTHONPATH=build/python bench/lookahead.py [--drives riverside-a,hku-1] [--keyframes 16]
                                                 [--cut 40] [--stride 5] [--voxel 2]
                                                 [--out docs/lookahead.json]
                                                 [--doc docs/transfer.md]

Transfer's promise is a calibrated prior where no sample has been yet. For each drive, BHM
(the joint BHM at the drive defaults) and RePOT (the same seeded from the built-in 3D
dictionary) map keyframes 0..K-1; before keyframe k is added, each map so far is scored on all
of keyframe k's beams (labelled as the mapper labels them: cut at --cut metres, 0.5 free samples
a metre, none held out; every --stride-th sample) and, apart, on the part of them beyond every
earlier sample's reach (samples whose --voxel metre cell, or an x-y neighbour of it, held no
earlier training sample). Prints a table a drive and method, writes the JSON with --out; --doc
FILE puts the table between "<!-- bench/lookahead.py table -->" and "<!-- end of
bench/lookahead.py table -->".
"""
import argparse
import json
import os
import sys

import numpy as np

import potmap
from marked_doc import replace_marked

HERE = os.path.dirname(os.path.abspath(__file__))
DRIVES = os.path.join(HERE, "..", "..", "shared", "data", "drives3d")


def cells(points, voxel):
    return [tuple(k) for k in np.floor(points / voxel).astype(np.int64)]


def look_ahead(ctx, path, keyframes, cut, stride, voxel, dictionary):
    drive = potmap.open_drive(path)
    mappers = {"BHM": potmap.DriveMapper(range_cut=cut),
               "RePOT": potmap.DriveMapper(range_cut=cut, dictionary=dictionary)}
    got = {k: {"p": [], "y": [], "beyond": []} for k in mappers}
    reached = set()
    for i in range(min(keyframes, len(drive))):
        kf = drive.keyframe(i)
        lab = potmap.label_scan(potmap.experiment.limit_range(kf, cut), index=i,
                                free_per_metre=0.5, holdout=0.0, seed=7)
        every = np.asarray(lab.train.positions)
        pts, y = every[::stride], np.asarray(lab.train.labels)[::stride]
        beyond = np.array([c not in reached for c in cells(pts, voxel)], bool)
        if i > 0:
            for name, m in mappers.items():
                prob = np.asarray(m.map(ctx).evaluate(pts, ctx).prob)
                got[name]["p"].append(prob)
                got[name]["y"].append(y)
                got[name]["beyond"].append(beyond)
        for m in mappers.values():
            m.add(kf, i, ctx)
        for (x, yy, z) in cells(every, voxel):
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    reached.add((x + dx, yy + dy, z))
        print("potmap: %s keyframe %d: %d beams' samples, %d beyond earlier reach"
              % (os.path.basename(path), i, len(y), int(beyond.sum())), file=sys.stderr)
    rows = []
    for name in mappers:
        p = np.concatenate(got[name]["p"]).astype(np.float32)
        y = np.concatenate(got[name]["y"])
        b = np.concatenate(got[name]["beyond"])
        row = {"method": name, "all": scores(p, y), "beyond_reach": scores(p[b], y[b])}
        rows.append(row)
    return rows


def scores(p, y):
    if len(y) < 2 or y.min() == y.max():
        return {"auc": None, "nll": None, "n": int(len(y))}
    s = potmap.score(p, y)
    return {"auc": s.auc, "nll": s.nll, "n": s.n}


def cell(s):
    return "n/a (n %d)" % s["n"] if s["auc"] is None else "%.4f / %.4f (n %d)" % (
        s["auc"], s["nll"], s["n"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--drives", default="riverside-a,hku-1")
    ap.add_argument("--keyframes", type=int, default=16)
    ap.add_argument("--cut", type=float, default=40.0, help="range cut, metres")
    ap.add_argument("--stride", type=int, default=5, help="every N-th labelled sample")
    ap.add_argument("--voxel", type=float, default=2.0, help="reach cells, metres")
    ap.add_argument("--out", default="", help="JSON file to write")
    ap.add_argument("--doc", default="", help="Markdown page whose marked table to replace")
    a = ap.parse_args()
    ctx = potmap.Context()
    dictionary = potmap.default_dictionary(dim=3)
    result = {"keyframes": a.keyframes, "cut_m": a.cut, "stride": a.stride, "voxel_m": a.voxel,
              "device": ctx.device.summary(), "drives": {}}
    table = ["| drive | method | look-ahead AUC / NLL, all beams | beyond earlier reach |",
             "|---|---|---|---|"]
    print("\n".join(table), flush=True)
    for name in a.drives.split(","):
        rows = look_ahead(ctx, os.path.join(DRIVES, name), a.keyframes, a.cut, a.stride,
                          a.voxel, dictionary)
        result["drives"][name] = rows
        for r in rows:
            table.append("| %s | %s | %s | %s |" % (name, r["method"], cell(r["all"]),
                                                   cell(r["beyond_reach"])))
            print(table[-1], flush=True)
    if a.doc:
        body = "\n".join(["", "Device: %s, %d CPUs; keyframes 0-%d, %g m cut, every %d-th "
                          "sample, reach cells of %g m." % (ctx.device.summary(), os.cpu_count(),
                                                             a.keyframes - 1, a.cut, a.stride,
                                                             a.voxel), ""] + table + [""])
        replace_marked(a.doc, "bench/lookahead.py", "table", body)
    if a.out:
        tmp = a.out + ".tmp"
        with open(tmp, "w") as f:
            json.dump(result, f, indent=1)
        os.replace(tmp, a.out)


if __name__ == "__main__":
    main()
