#!/usr/bin/env python3
"""potmap's batched Sinkhorn beside PythonOT's on the same problems: cost and time.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/sinkhorn_vs_pot.py \
        [--problems 64] [--sizes 50,200,500] [--epsilon 0.01] [--device pocl]

For each size, `--problems` random 2D problems (uniform weights, squared Euclidean cost divided
by its maximum) are solved by potmap in one device launch and, when PythonOT (Debian's
python3-pot) is importable, one by one with ot.sinkhorn (log-domain: method 'sinkhorn_log', as
small epsilons need). The table gives the mean transport cost <P, C> of each, their largest
difference and the wall time. Stopping rules differ: potmap stops when ||P 1 - a||_1 < tol,
PythonOT checks the target marginal's 2-norm every 10 iterations.
"""

import argparse
import time

import numpy as np

import potmap

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--problems", type=int, default=64, help="problems per size (default 64)")
ap.add_argument("--sizes", default="50,200,500", help="points a side, comma-separated")
ap.add_argument("--epsilon", type=float, default=0.01, help="on the normalised cost (default 0.01)")
ap.add_argument("--tol", type=float, default=1e-6, help="marginal error to stop at (default 1e-6)")
ap.add_argument("--device", default="", help="OpenCL device substring")
args = ap.parse_args()

try:
    import ot
except ImportError:
    ot = None
    print("PythonOT not found (apt-get install python3-pot): potmap only\n")

ctx = potmap.Context(device=args.device)
rng = np.random.default_rng(0)
rows = []
for n in (int(s) for s in args.sizes.split(",")):
    src = [rng.uniform(-1, 1, (n, 2)) for _ in range(args.problems)]
    dst = [rng.uniform(-1, 1, (n, 2)) + 0.2 for _ in range(args.problems)]
    potmap.sinkhorn(ctx, src[:1], dst[:1], epsilon=args.epsilon)  # builds the kernels once
    t0 = time.perf_counter()
    res = potmap.sinkhorn(ctx, src, dst, epsilon=args.epsilon, normalise_cost=True,
                          tolerance=args.tol, max_iterations=5000)
    t_potmap = time.perf_counter() - t0
    row = {"n": n, "potmap_cost": np.mean([r.cost for r in res]), "potmap_s": t_potmap,
           "converged": sum(r.converged for r in res)}
    if ot is not None:
        costs = []
        t0 = time.perf_counter()
        for x, y in zip(src, dst):
            c = ot.dist(x, y)
            c /= c.max()
            a = np.full(n, 1.0 / n)
            p = ot.sinkhorn(a, a, c, args.epsilon, method="sinkhorn_log", numItermax=5000,
                            stopThr=args.tol)
            costs.append(float((p * c).sum()))
        row["pot_s"] = time.perf_counter() - t0
        row["pot_cost"] = np.mean(costs)
        row["max_diff"] = max(abs(r.cost - c) for r, c in zip(res, costs))
    rows.append(row)

print(f"device: {ctx.device.summary()}; {args.problems} problems a size, epsilon {args.epsilon}\n")
head = "| n | potmap cost | potmap s | converged |"
if ot is not None:
    head += " PythonOT cost | PythonOT s | max cost diff | speed-up |"
print(head)
print("|" + "---|" * (head.count("|") - 1))
for r in rows:
    line = f"| {r['n']} | {r['potmap_cost']:.6f} | {r['potmap_s']:.3f} | {r['converged']}/{args.problems} |"
    if ot is not None:
        line += (f" {r['pot_cost']:.6f} | {r['pot_s']:.3f} | {r['max_diff']:.2e} |"
                 f" {r['pot_s'] / r['potmap_s']:.1f}x |")
    print(line)
