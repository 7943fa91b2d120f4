#!/usr/bin/env python3
"""Map a real LIDAR log with RePOT from Python and plot the probability and variance.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/repot_radish.py \
        [--log ../shared/data/radish/intel-corrected.log.gz] [--atoms 10] [--scans 30] [--out out/python]

Laid out as notebook cells (`# %%`): atoms from the first scans of the log (a joint BHM of
them, cut into sectors), then the next scans mapped one by one with a RePOT Mapper, the
held-out beams scored, and the overall map rastered and drawn with matplotlib. The settings
are the ones the README's Map quality table uses on the Radish logs.
"""

# %% Setup
import argparse
import os
import time

import numpy as np

import potmap

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
here = os.path.dirname(os.path.abspath(__file__))
ap.add_argument("--log", default=os.path.join(here, "../../../shared/data/radish/intel-corrected.log.gz"))
ap.add_argument("--atoms", type=int, default=10, help="first scans the atoms are cut from (default 10)")
ap.add_argument("--scans", type=int, default=30, help="scans mapped after them (default 30)")
ap.add_argument("--res", type=float, default=0.1, help="picture cell, metres (default 0.1)")
ap.add_argument("--out", default="out/python", help="folder for the figure (default out/python)")
ap.add_argument("--device", default="", help="OpenCL device substring (default: POTMAP_DEVICE, GPU, CPU)")
args = ap.parse_args()

ctx = potmap.Context(device=args.device)
print("device:", ctx.device.summary())

# %% Read the log; cut every scan at 20 m as the experiments do
log = potmap.read_dataset(args.log)
scans = [potmap.experiment.limit_range(s, 20.0) for s in log.scans]
source, target = scans[: args.atoms], scans[args.atoms : args.atoms + args.scans]
print(f"{len(log)} scans in {os.path.basename(args.log)}; atoms from {len(source)}, mapping {len(target)}")

# %% Atoms: a joint BHM of the source scans (no bias: atoms carry none), cut into sectors
train = potmap.label(source, holdout=0.0).train
bhm = potmap.JointBhm(2, bias=False)
bhm.update_by_scan(train)
source_map = bhm.map()
atoms = potmap.build_dictionary(source, source_map, kernels_at_samples=0.5, max_weight_variance=5.0)
print(f"source map: {len(source_map)} kernels; dictionary: {len(atoms)} atoms")

# %% RePOT: every scan transported, then learned into one persistent joint BHM
options = potmap.MapperOptions()
options.pot.wall_clearance = 0.5
options.pot.displacement_variance = 0.25
mapper = potmap.Mapper(ctx, atoms, refine=True, options=options)
held_out, ms = [], []
t0 = time.perf_counter()
for scan in target:
    m = mapper.add_scan(scan)
    held_out.append(m.test)
    ms.append(m.timing.total_ms)
overall = mapper.overall_map()
print(f"mapped {mapper.scans} scans in {time.perf_counter() - t0:.1f} s "
      f"({np.mean(ms):.0f} ms a scan); overall map {len(overall)} kernels")

# %% Score on the held-out beams (never used for transport or learning)
pos = np.concatenate([t.positions for t in held_out])
lab = np.concatenate([t.labels for t in held_out])
s = potmap.score(overall.evaluate(pos, ctx).prob, lab)
print(f"held-out: ACC {s.acc:.3f}  AUC {s.auc:.3f}  NLL {s.nll:.3f}  ({s.n} samples)")

# %% Raster and plot probability and variance
lo = pos.min(axis=0) - 1.0
hi = pos.max(axis=0) + 1.0
bounds = (lo[0], hi[0], lo[1], hi[1])
prob, mean, var = overall.raster(bounds, args.res, ctx)

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

fig, ax = plt.subplots(1, 2, figsize=(12, 5.5))
extent = [bounds[0], bounds[0] + prob.shape[1] * args.res, bounds[2], bounds[2] + prob.shape[0] * args.res]
im = ax[0].imshow(prob, extent=extent, origin="upper", cmap="viridis", vmin=0, vmax=1)
ax[0].set_title("RePOT occupancy probability")
fig.colorbar(im, ax=ax[0], shrink=0.8)
im = ax[1].imshow(var, extent=extent, origin="upper", cmap="magma", vmin=0, vmax=np.percentile(var, 99))
ax[1].set_title("logit variance")
fig.colorbar(im, ax=ax[1], shrink=0.8)
for a in ax:
    a.set_xlabel("x (m)")
    a.set_ylabel("y (m)")
fig.suptitle(f"{os.path.basename(args.log)}: {mapper.scans} scans, AUC {s.auc:.3f}, NLL {s.nll:.3f}")
fig.tight_layout()
os.makedirs(args.out, exist_ok=True)
path = os.path.join(args.out, "repot_radish.png")
fig.savefig(path + ".tmp.png", dpi=110)
os.replace(path + ".tmp.png", path)
print("wrote", path)
