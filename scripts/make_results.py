#!/usr/bin/env python3
"""Writes docs/results.md from the JSON files of `potmap experiment ... --json` runs.

Usage: scripts/make_results.py [RESULTS_DIR] [OUT_MD]
  RESULTS_DIR  folder of *.json written by the runners (default docs/results)
  OUT_MD       page to write (default docs/results.md)

Only the standard library: every number on the page comes from the JSON; the paper's Table VI
is copied from SPEC.md section 5 and marked as the paper's.
"""
import json
import os
import sys

ORDER = ["intra-domain", "inter-domain", "sim-to-real", "dynamic", "per-time-unit"]
TITLES = {
    "intra-domain": "Intra-domain (paper Table III, diagonal): first 10 scans source, rest target",
    "inter-domain": "Inter-domain (paper Table III, off-diagonal): source A, target B",
    "sim-to-real": "Sim-to-real: simulated towns as source, real logs as target",
    "dynamic": "Instantaneous maps in a dynamic scene (paper Table V)",
    "per-time-unit": "Per time unit (paper Table VI)",
}
# F1 and chamfer (m): occupied cells against an OGM at 0.1 m of the same training beams (absent
# from JSON written before the structural score: shown as "–").
METRICS = [("acc", "ACC", 3), ("auc", "AUC", 3), ("nll", "NLL", 3), ("f1", "F1", 3),
           ("chamfer_m", "chamfer m", 2), ("ms_per_scan", "ms/scan", 1)]

# SPEC.md section 5: the paper's results on Carla towns (targets Town1/2/3).
PAPER_TABLE_VI = {
    "ACC": {"RePOT": [0.95, 0.93, 0.95], "POT": [0.85, 0.83, 0.84], "ABHM": [0.77, 0.59, 0.86],
            "BHM": [0.66, 0.61, 0.71], "OGM": [0.78, 0.78, 0.77]},
    "AUC": {"RePOT": [0.99, 0.98, 0.98], "POT": [0.92, 0.92, 0.93], "ABHM": [0.95, 0.96, 0.96],
            "BHM": [0.94, 0.92, 0.91], "OGM": [0.89, 0.91, 0.90]},
    "NLL": {"RePOT": [0.71, 1.41, 1.12], "POT": [1.64, 1.69, 1.79], "ABHM": [0.58, 0.71, 0.41],
            "BHM": [0.63, 0.69, 0.61], "OGM": [2.00, 1.34, 1.13]},
}


def seed_rule(st):
    """How RePOT's seeds yield to data, from the run's settings."""
    if not st.get("repot_seeds_yield"):
        return "; seeds stay the priors under the data"
    if st.get("repot_seeds_yield_fully"):
        return ("; a seed yields, its mean too, when its kernel comes within the solve's margin "
                "of a scan's samples: near the data the map is BHM's")
    return "; a seed yields when a sample reaches its kernel, its mean starting the bound"


def fmt(stat, digits):
    if stat is None or stat.get("mean") is None:
        return "–"
    m, sd = stat["mean"], stat.get("sd")
    if sd is None or stat.get("n", 0) < 2:
        return f"{m:.{digits}f}"
    return f"{m:.{digits}f} ± {sd:.{digits}f}"


def case_name(row):
    s, t = row["source"], row["target"]
    return t if not s or s == t else f"{s} → {t}"


def table_md(doc):
    rows = doc["table"]
    cases, methods = [], []
    for r in rows:
        c = case_name(r)
        if c not in cases:
            cases.append(c)
        if r["method"] not in methods:
            methods.append(r["method"])
    cell = {(case_name(r), r["method"]): r for r in rows}
    out = []
    out.append("| metric | method | " + " | ".join(cases) + " |")
    out.append("|---|---|" + "---|" * len(cases))
    for key, name, digits in METRICS:
        if not any(key in r for r in rows):
            continue  # a metric this file predates (F1, chamfer)
        for i, m in enumerate(methods):
            vals = [fmt(cell[(c, m)].get(key), digits) if (c, m) in cell else "–" for c in cases]
            out.append(f"| {name if i == 0 else ''} | {m} | " + " | ".join(vals) + " |")
    notes = sorted({f"{case_name(r)}: {r['method']} = {r['chosen']}" for r in rows
                    if r["chosen"] != r["method"]})
    if notes:
        out.append("")
        out.append("Chosen members (best mean AUC of the group, as the paper reports the best "
                   "OGM cell size; selected on the held-out samples, which favours OGM): "
                   + "; ".join(notes) + ".")
    return "\n".join(out)


def figures_md(doc, md_dir):
    out = []
    for r in doc["table"]:
        figs = [f for f in r.get("figures", []) if os.path.exists(f)]
        if not figs:
            continue
        links = " ".join(f"![{os.path.basename(f)}]({os.path.relpath(f, md_dir)})" for f in figs)
        out.append(f"- {case_name(r)}, {r['method']} ({r['chosen']}): {links}")
    return "\n".join(out)


def compare_md(doc, md_dir):
    """The side-by-side figures of each case, with their panel order as a caption line."""
    out = []
    for c in doc.get("compare_figures", []):
        f = c.get("file", "")
        if not os.path.exists(f):
            continue
        case = case_name({"source": c.get("source", ""), "target": c.get("target", "")})
        out.append(f"![{os.path.basename(f)}]({os.path.relpath(f, md_dir)})")
        out.append("")
        out.append(f"*{case}, left to right: " + ", ".join(c.get("panels", [])) + "*")
        out.append("")
    return "\n".join(out)


def pot_stages(doc):
    parts = []
    for g in ("POT", "RePOT"):
        runs = [r for r in doc["runs"] if r["group"] == g]
        if not runs:
            continue
        def mean(k):
            v = [r["info"].get(k, 0.0) for r in runs]
            return sum(v) / len(v)
        parts.append(f"{g} {mean('atoms'):.0f} atoms (built in {mean('atoms_s'):.1f} s), "
                     f"{mean('kernels_per_scan'):.0f} kernels per scan, mean stage times per "
                     f"scan: prepare {mean('prepare_ms'):.1f} ms (overlapped), ranking "
                     f"{mean('ranking_ms'):.1f}, transport {mean('transport_ms'):.1f}, placement "
                     f"{mean('placement_ms'):.1f}, refine {mean('refine_ms'):.1f} ms")
    return "; ".join(parts)


def paper_md():
    out = ["| metric | method | Town1 | Town2 | Town3 |", "|---|---|---|---|---|"]
    for metric, rows in PAPER_TABLE_VI.items():
        for i, (m, v) in enumerate(rows.items()):
            out.append(f"| {metric if i == 0 else ''} | {m} (paper) | "
                       + " | ".join(f"{x:.2f}" for x in v) + " |")
    return "\n".join(out)


def main():
    res_dir = sys.argv[1] if len(sys.argv) > 1 else "docs/results"
    out_md = sys.argv[2] if len(sys.argv) > 2 else "docs/results.md"
    docs = []
    for name in sorted(os.listdir(res_dir)):
        if name.endswith(".json"):
            with open(os.path.join(res_dir, name)) as f:
                d = json.load(f)
            d["_file"] = name
            docs.append(d)
    docs.sort(key=lambda d: (ORDER.index(d["experiment"]) if d["experiment"] in ORDER else 99,
                             d["_file"]))
    md_dir = os.path.dirname(os.path.abspath(out_md))
    lines = [
        "# Results",
        "",
        f"Generated by `scripts/make_results.py` from the JSON in `{res_dir}`; do not edit by hand.",
        "Every method is scored on the same held-out samples: 20 % of the beams of every scan,",
        "drawn with the run's seed, never used for learning. ± is the standard deviation over",
        "seeds (instantaneous maps: over scans and seeds). Times are wall-clock per target scan",
        "of learning only (querying the held-out samples is not included). NLL clips p to",
        "[1e-6, 1 - 1e-6]. The 2 cores were shared with other jobs while these ran, so times",
        "are noisy: compare orders of magnitude, not digits.",
        "",
        "Baselines (OGM, BHM, ABHM) learn on the target's own training beams and do not use the",
        "source, so their numbers are the same for every source of one target. POT and RePOT",
        "build a dictionary of atoms from the source (a map learned on each source place, atoms",
        "cut from scans spread over it; see each run's settings), then transfer the target's",
        "scans in order from their training samples only. POT accumulates the instantaneous maps",
        "into an overall map (Table III style: their support-weighted average, or summed kernels",
        "with merging, as each run's settings say); RePOT keeps one persistent joint BHM",
        "of the target whose kernels' priors are seeded from the transported kernels where no",
        "sample has reached them yet, then updated with each scan's training samples. The",
        "dynamic runner scores each scan's instantaneous map (Table V). Their time per scan is",
        "the transfer (ranking, transport, placement, RePOT's seeding and update, POT's overall map), with",
        "the next scan's host preparation and the last scan's merge into the overall map (RePOT's",
        "update, POT's average) overlapped as `potmap map` does; building the atoms is offline and",
        "not included.",
        "Every scan is cut at the settings' max_range (20 m: the towns' range and POT's sector",
        "radius) for every method: returns of the 80 m lasers of the real logs beyond it become",
        "free beams to 20 m.",
        "",
    ]
    for d in docs:
        lines.append(f"## {TITLES.get(d['experiment'], d['experiment'])}")
        lines.append("")
        lines.append(f"- command: `{d['command']}`")
        lines.append(f"- machine: {d['machine']['cpu']}, {d['machine']['hardware_threads']} "
                     "hardware threads")
        lines.append(f"- device: {d['device']}")
        lines.append(f"- JSON: `{os.path.join(res_dir, d['_file'])}`")
        st = d.get("settings", {})
        if "pot_atom_map" in st and any(r["group"] in ("POT", "RePOT") for r in d["runs"]):
            combine = st.get("pot_combine", "sum")
            lines.append(f"- POT/RePOT: atoms from a {st['pot_atom_map'].upper()} source map, "
                         f"{st['pot_atom_scans']} source scans per place cut into "
                         f"{st['pot_sectors']} sectors, {st['pot_rotations']} rotations; scans cut "
                         f"at {st.get('max_range', 0):g} m")
            if st.get("pot_ranking") == "indexed":
                lines.append(f"- ranking: indexed ({st['pot_index_neighbours']} nearest atoms of "
                             "the index and the last scan's at estimated rotations, the best "
                             f"{st['pot_fine_candidates']} a sector solved again at the caps)")
            elif "pot_ranking" in st:
                lines.append("- ranking: exhaustive (every atom at every rotation)")
            if "pot_placement" in st:
                place = ("kernels on the target's samples thinned to "
                         f"{st['pot_anchor_spacing']:g} m, each carrying the atom's logit pulled "
                         "back through the plan"
                         + (f" times {st['pot_logit_gain']:g}, weights solved together "
                            f"({st['pot_anchor_sweeps']} sweeps), free anchors "
                            f"{st['pot_anchor_clearance']:g} m clear of hits"
                            if st.get("pot_anchor_sweeps") else "")
                         if st["pot_placement"] == "target_samples" else
                         "kernels at the barycentric images of the atoms' kernels")
                overall = (f"overall map the support-weighted average of the scans' maps on a "
                           f"{st['pot_average_spacing']:g} m grid (ridge "
                           f"{st['pot_average_ridge']:g}, support at least "
                           f"{st['pot_average_min_support']:g})"
                           if combine == "average" else
                           f"overall map of summed kernels, merge radius {st['pot_merge_radius']}")
                lines.append(f"- POT: atom kernels at the atoms' samples thinned to "
                             f"{st['pot_kernels_at_samples']:g} m; {place}; wall clearance "
                             f"{st['pot_wall_clearance']:g} m, displacement variance "
                             f"{st['pot_displacement_variance']:g} per m^2; {overall}")
                lines.append(
                    "- RePOT: "
                    + ("one persistent joint BHM seeded by the transported kernels ("
                       f"{st['repot_seed_placement']}, displacement variance "
                       f"{st['repot_seed_displacement_variance']:g} per m^2, seed variance at "
                       f"least {st['repot_seed_min_variance']:g}"
                       + seed_rule(st) + ")"
                       if st.get("repot_persistent") else "per-scan refinement, merged"))
            elif "pot_kernels_at_samples" in st:
                lines.append(
                    f"- POT: atom kernels at the atoms' samples thinned to "
                    f"{st['pot_kernels_at_samples']:g} m, wall clearance "
                    f"{st['pot_wall_clearance']:g} m, displacement variance "
                    f"{st['pot_displacement_variance']:g} per m^2; RePOT: "
                    + ("one persistent joint BHM seeded by the transported kernels (seed variance "
                       f"at least {st['repot_seed_min_variance']:g}"
                       + seed_rule(st) + ")"
                       if st.get("repot_persistent") else "per-scan refinement, merged"))
            if "bhm_joint" in st:
                lines.append(
                    "- BHM: " + ("joint posterior (sparse precision, CG per scan)"
                                 if st["bhm_joint"] else "diagonal posterior")
                    + f", kernels {st['bhm_spacing']:g} m apart, width "
                    + (f"{st['bhm_gamma']:g} 1/m^2" if st.get("bhm_gamma") else "from the spacing")
                    + ", prior variance "
                    + (f"{st['bhm_prior_var']:g}" if st.get("bhm_prior_var") else "the model's default")
                    + ", bias weight")
            lines.append("- " + pot_stages(d))
        lines.append("")
        lines.append(table_md(d))
        lines.append("")
        st_struct = st.get("structure")
        if st_struct:
            lines.append(f"F1 and chamfer: each map's occupied cells (p > 0.501) on a "
                         f"{st_struct.get('cell_m', 0.1):g} m raster of the case's window against "
                         f"those of an OctoMap grid at that cell size built from the same training "
                         f"beams (p >= 0.5 occupied, unknown free); F1 of precision and recall "
                         f"within {st_struct.get('tolerance_m', 0.2):g} m, chamfer the mean "
                         "nearest-occupied-cell distance both ways. The reference is a map of the "
                         "same data, not ground truth: the OGM scores well against a finer "
                         "version of itself by construction.")
            lines.append("")
        figs = figures_md(d, md_dir)
        if not figs and d["experiment"] in ("inter-domain", "sim-to-real"):
            lines.append("Figures of these runs are not kept: the baselines' maps of a target "
                         "are those of the intra-domain figures (same learners, same target log).")
            lines.append("")
        if figs:
            lines.append("Figures (first seed; probability, variance, kernels coloured by log "
                         "width):")
            lines.append("")
            lines.append(figs)
            lines.append("")
        comp = compare_md(d, md_dir)
        if comp:
            lines.append("Side by side (first seed; probability at one scale, the OGM reference "
                         "first, then each row's chosen member in method order):")
            lines.append("")
            lines.append(comp)
        if d["experiment"] == "per-time-unit":
            budget = d["settings"].get("budget_ms")
            seen = set()
            notes = []
            for r in d["runs"]:
                key = (r["target"], r["method"])
                if "budget" not in r["method"] or key in seen:
                    continue
                seen.add(key)
                row = next(t for t in d["table"] if t["target"] == r["target"]
                           and t["method"] == r["method"])
                ms = row["ms_per_scan"]["mean"]
                info = r["info"]
                notes.append(f"{r['target']}: {r['method']} {int(info['kernels'])} kernels, "
                             f"budget {info.get('budget_ms', float('nan')):.1f} ms, calibration "
                             f"{info.get('calibrated_ms', float('nan')):.1f} ms "
                             f"({int(info.get('calibration_probes', 0))} probes), runs "
                             f"{ms:.1f} ms/scan")
            lines.append("Budget: POT's own time per scan, its mean over the seeds' runs on each "
                         "target (or `--budget-ms` when given, here "
                         f"{budget:g}). BHM and ABHM get the kernel count whose full fit on that "
                         "seed came closest to it (secant steps on measured full fits, no "
                         "extrapolation; BHM at the default grid's fixed width, ABHM with its "
                         "Adam steps fixed; counts capped at `--max-kernels`, 400,000 by default, where BHM "
                         "stops short of the budget). Budget, the calibration fit's time and the mean "
                         "time over the seeds' runs: " + "; ".join(notes) + ".")
            lines.append("")
            lines.append("The paper's Table VI on its Carla towns (their data and setup, not "
                         "reproduced here; copied from SPEC.md section 5) for reference:")
            lines.append("")
            lines.append(paper_md())
            lines.append("")
    if not any(d["experiment"] == "per-time-unit" for d in docs):
        lines.append("## The paper's Table VI (Carla towns; the paper's numbers, for reference)")
        lines.append("")
        lines.append(paper_md())
        lines.append("")
    with open(out_md, "w") as f:
        f.write("\n".join(lines))
    print(f"wrote {out_md} from {len(docs)} runs")


if __name__ == "__main__":
    main()
