#!/usr/bin/env python3
"""Plots and tabulates the remeshing benchmark (bench/run_remeshing.sh).

Reads one JSON object per run (bench_remeshing's output), draws time and quality of every
peer per input, and rewrites the "## Remeshing" section of bench/RESULTS.md; every other
section of that file is kept as it is. Run information (date, machine, command...) comes
from environment variables set by run_remeshing.sh. With --before FILE (runs of an older
build, same format), a before/after table of idas serial is added.

    plot_remeshing.py --results FILE.jsonl --png FILE.png --markdown RESULTS.md [--before F]
"""
import argparse
import json
import os
import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SECTION = "## Remeshing"
INPUTS = ["bunny", "armadillo", "armadillo-x4"]
# (peer, threads, envelope) in plot and table order.
CONFIGS = [("cgal", 1, False), ("idas", 1, False), ("idas", 2, False), ("idas", 1, True),
           ("idas", 2, True)]
LABELS = {CONFIGS[0]: "CGAL", CONFIGS[1]: "idas 1T", CONFIGS[2]: "idas 2T",
          CONFIGS[3]: "idas 1T env", CONFIGS[4]: "idas 2T env"}
COLORS = {CONFIGS[0]: "#d62728", CONFIGS[1]: "#1f77b4", CONFIGS[2]: "#1f77b4",
          CONFIGS[3]: "#2ca02c", CONFIGS[4]: "#2ca02c"}


def key(r):
    return (r["peer"], int(r.get("threads", 1)), bool(r.get("envelope", False)))


def load(path):
    runs, failures = [], []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line:
                r = json.loads(line)
                (failures if "error" in r else runs).append(r)
    best = {}  # fastest run of each (input, config), with run count and slowest time
    for r in runs:
        k = (r["input"],) + key(r)
        r = dict(r, runs=1, slowest=r["seconds_algorithm"])
        old = best.get(k)
        if old:
            r["runs"], r["slowest"] = old["runs"] + 1, max(old["slowest"], r["slowest"])
            if old["seconds_algorithm"] <= r["seconds_algorithm"]:
                old["runs"], old["slowest"] = r["runs"], r["slowest"]
                continue
        best[k] = r
    return best, failures


def plot(best, path):
    fig, axes = plt.subplots(2, len(INPUTS), figsize=(13, 8))
    for col, inp in enumerate(INPUTS):
        for row, (field, label) in enumerate([("seconds_algorithm", "algorithm seconds (wall)"),
                                              ("min_angle_deg", "minimum angle (degrees)")]):
            ax = axes[row][col]
            names, values, colors, hatches = [], [], [], []
            for cfg in CONFIGS:
                r = best.get((inp,) + cfg)
                names.append(LABELS[cfg])
                values.append(r[field] if r else 0)
                colors.append(COLORS[cfg])
                hatches.append("//" if cfg[1] > 1 else "")
            x = list(range(len(names)))
            bars = ax.bar(x, values, color=colors, hatch=hatches, edgecolor="black",
                          linewidth=0.5)
            for b, v in zip(bars, values):
                ax.annotate(f"{v:.2f}" if field.startswith("sec") else f"{v:.1f}",
                            (b.get_x() + b.get_width() / 2, v), ha="center", va="bottom",
                            fontsize=8, xytext=(0, 2), textcoords="offset points")
            ax.set_xticks(x)
            ax.set_xticklabels(names, rotation=30, ha="right", fontsize=8)
            faces = next((r["input_faces"] for k, r in best.items() if k[0] == inp), 0)
            if row == 0:
                ax.set_title(f"{inp} ({faces:,} faces)", fontsize=10)
            ax.set_ylabel(label)
            ax.margins(y=0.15)
    fig.suptitle("Isotropic remeshing, target edge length 0.005 of the diagonal, 5 iterations\n"
                 "top: time (lower is better); bottom: smallest angle (higher is better); "
                 "hatched: 2 threads; green: with the envelope", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    fig.savefig(path, dpi=110)


def mark(ok):
    return "met" if ok else "**not met**"


def farthest(r):
    """Out->in distance of the farthest output sample (23 per face, exact distances to the
    input), relative to the diagonal: deterministic, unlike CGAL's random-sample estimate."""
    return r["envelope_check_max_over_eps"] * r["eps_relative"]


def targets(best):
    out = ["**idas serial (no envelope) against CGAL** (targets: time ratio at most 1; "
           "valence-6 fraction and minimum angle at least CGAL's; Hausdorff at most CGAL's)", "",
           "| input | seconds idas / CGAL | ratio | | valence-6 idas / CGAL | | min angle idas / "
           "CGAL | | farthest output point idas / CGAL | | Hausdorff sym. idas / CGAL | | "
           "out->in CGAL estimate, idas / CGAL |",
           "|---|---:|---:|---|---:|---|---:|---|---:|---|---:|---|---:|"]
    for inp in INPUTS:
        a, c = best.get((inp, "idas", 1, False)), best.get((inp, "cgal", 1, False))
        if not a or not c:
            continue
        q = a["seconds_algorithm"] / c["seconds_algorithm"]
        cells = [f"{a['seconds_algorithm']:.2f} / {c['seconds_algorithm']:.2f}", f"{q:.2f}",
                 mark(q <= 1),
                 f"{100 * a['valence6']:.1f}% / {100 * c['valence6']:.1f}%",
                 mark(a["valence6"] >= c["valence6"]),
                 f"{a['min_angle_deg']:.1f} / {c['min_angle_deg']:.1f}",
                 mark(a["min_angle_deg"] >= c["min_angle_deg"]),
                 f"{farthest(a):.3g} / {farthest(c):.3g}",
                 mark(farthest(a) <= farthest(c)),
                 f"{a['hausdorff_symmetric']:.3g} / {c['hausdorff_symmetric']:.3g}",
                 mark(a["hausdorff_symmetric"] <= c["hausdorff_symmetric"]),
                 f"{a['hausdorff_out_in']:.3g} / {c['hausdorff_out_in']:.3g}"]
        out.append(f"| {inp} | " + " | ".join(cells) + " |")
    out += ["", "**idas 2-thread speedup over 1 thread** (target: at least 1.6 on armadillo x4)",
            "", "| input | envelope | 1T (s) | 2T (s) | speedup | |", "|---|---|---:|---:|---:|---|"]
    for inp in INPUTS:
        for env in [False, True]:
            a, b = best.get((inp, "idas", 1, env)), best.get((inp, "idas", 2, env))
            if not a or not b:
                continue
            s = a["seconds_algorithm"] / b["seconds_algorithm"]
            verdict = mark(s >= 1.6) if inp == "armadillo-x4" else ""
            out.append(f"| {inp} | {'on' if env else 'off'} | {a['seconds_algorithm']:.2f} | "
                       f"{b['seconds_algorithm']:.2f} | {s:.2f} | {verdict} |")
    out += ["", "**Envelope runs: faces outside eps by the independent sampled check** "
            "(target: 0)", "", "| input | threads | faces | faces outside | max distance / eps | |",
            "|---|---:|---:|---:|---:|---|"]
    for inp in INPUTS:
        for t in [1, 2]:
            r = best.get((inp, "idas", t, True))
            if r:
                n = r["envelope_check_faces_outside"]
                out.append(f"| {inp} | {t} | {r['output_faces']:,} | {n} | "
                           f"{r['envelope_check_max_over_eps']:.3f} | {mark(n == 0)} |")
    return out


def all_runs(best):
    out = ["| input | peer | seconds | slowest (runs) | load | output faces | valence-6 | "
           "min angle | mean min angle | faces < 20° | edge / L | Hausdorff out->in | "
           "Hausdorff sym. | outside eps | peak RSS delta (MB) | manifold, chi |",
           "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for inp in INPUTS:
        for cfg in CONFIGS:
            r = best.get((inp,) + cfg)
            if not r:
                continue
            out.append(
                f"| {inp} | {LABELS[cfg]} | {r['seconds_algorithm']:.2f} | {r['slowest']:.2f} "
                f"({r['runs']}) | {r.get('load', '?')} | {r['output_faces']:,} | "
                f"{100 * r['valence6']:.1f}% | {r['min_angle_deg']:.1f} | "
                f"{r['mean_min_angle_deg']:.1f} | {r['faces_below_20_deg']} | "
                f"{r['edge_length_ratio']:.3f} | {r['hausdorff_out_in']:.3g} | "
                f"{r['hausdorff_symmetric']:.3g} | {r['envelope_check_faces_outside']} | "
                f"{r['peak_rss_delta_mb']:.0f} | {'yes' if r['manifold'] else 'NO'}, "
                f"{r['euler']} |")
    return out


def before_after(before, after, note):
    out = ["### Before and after", "",
           "idas serial without envelope; \"before\" is " + (note or "an older revision") +
           ": a bench_remeshing built from it, passed as --before-bin and run interleaved "
           "with \"after\".", "",
           "| input | build | seconds | output faces | valence-6 | min angle | mean min angle | "
           "faces < 20° | Hausdorff out->in | Hausdorff sym. |",
           "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for inp in INPUTS:
        for name, runs in [("before", before), ("after", after)]:
            r = runs.get((inp, "idas", 1, False))
            if r:
                out.append(f"| {inp} | {name} | {r['seconds_algorithm']:.2f} | "
                           f"{r['output_faces']:,} | {100 * r['valence6']:.1f}% | "
                           f"{r['min_angle_deg']:.1f} | {r['mean_min_angle_deg']:.1f} | "
                           f"{r['faces_below_20_deg']} | {r['hausdorff_out_in']:.3g} | "
                           f"{r['hausdorff_symmetric']:.3g} |")
    return out


def section(best, failures, before, before_note):
    env = os.environ.get
    any_run = next(iter(best.values()), {})
    lines = [
        SECTION, "",
        "`bench_remeshing` (bench/bench_remeshing.cpp) run by `bench/run_remeshing.sh`: "
        "isotropic remeshing of bunny (data/bunny.obj, open), armadillo (data/armadillo.obj) "
        "and armadillo x4 (one 1-to-4 midpoint subdivision at run time, 345,928 faces, the "
        f"same surface) at target edge length {any_run.get('length_relative', 0.005):g} of "
        f"the bounding-box diagonal, {any_run.get('iterations', 5)} iterations, each case "
        "its own process.", "",
        "- Peers: `CGAL::Polygon_mesh_processing::isotropic_remeshing` (Surface_mesh over "
        "Epick, default parameters: one relaxation step per iteration, projection on, no "
        "feature protection; border edges are split and collapsed along the border) against "
        "`idas::algorithms::isotropic_remeshing` on 1 and 2 threads, without and with the "
        f"exact envelope invariant (eps {any_run.get('eps_relative', 1e-3):g} of the "
        "diagonal; its construction is not timed). idas treats borders as CGAL does (border edges split and collapsed along the border, border vertices not smoothed; `--boundary keep` would freeze them).",
        "- Seconds: the remeshing call only (both build their projection tree inside it).",
        "- Quality: fraction of interior vertices with valence 6, smallest angle, mean over "
        "faces of each face's smallest angle, faces whose smallest angle is below 20 degrees, "
        "mean edge length / target. Hausdorff: CGAL `approximate_Hausdorff_distance` "
        "(as in the decimation benchmark) divided by the diagonal; out->in samples the "
        "output, sym. is the larger of both directions. The targets' out->in figure is the "
        "farthest output point of the envelope check below (every face sampled, exact "
        "distances, the same for both peers): CGAL's out->in estimate draws random samples "
        "and moves by more than the peers differ (bunny: CGAL's own output 0.00123 to "
        "0.00138 across builds); it is kept as the last column.",
        "- Outside eps: the independent envelope check, for every run: each output face "
        "sampled at 23 points (corners, edge midpoints, centroid, 16 stratified), distances "
        "to the input by `idas::triangle_aabb_tree`; faces with a sample farther than eps.",
        "",
        f"- Date: {env('DATE', '?')}",
        f"- Machine: {env('MACHINE', '?')} ({env('LOAD', '?')}). The machine is shared: "
        "compare ratios within one run; the load column is the 1-minute load average after "
        "each case.",
        f"- Compiler: {env('COMPILER', '?')}; peer: {env('PEERS', '?')} (Debian package)",
        f"- Build: `{env('BUILD', '?')}`",
        f"- Command: `{env('COMMAND', '?')}` (all cases took {env('WALL', '?')} s)", "",
        "![remeshing time and minimum angle](remeshing.png)", "", "### Targets", ""]
    lines += targets(best)
    lines += ["", "### All runs", ""]
    lines += all_runs(best)
    if failures:
        lines += ["", "Failed runs: " + "; ".join(
            f"{f['peer']} {f['input']} {f.get('args', '')}: {f['error']}" for f in failures)]
    if before:
        lines += [""] + before_after(before, best, before_note)
    return "\n".join(lines) + "\n"


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--results", required=True)
    p.add_argument("--png", required=True)
    p.add_argument("--markdown", required=True)
    p.add_argument("--before")
    p.add_argument("--before-note", help="what the --before build is")
    a = p.parse_args()
    best, failures = load(a.results)
    before = None
    if a.before and os.path.exists(a.before):
        before = load(a.before)[0]
    plot(best, a.png)
    text = open(a.markdown).read() if os.path.exists(a.markdown) else "# Results\n"
    new = section(best, failures, before, a.before_note)
    # Replace our section (up to the next level-2 heading) or append it.
    pattern = re.compile(r"^## Remeshing\n.*?(?=^## |\Z)", re.S | re.M)
    if pattern.search(text):
        text = pattern.sub(lambda _: new + "\n", text, count=1)
    else:
        text = text.rstrip("\n") + "\n\n" + new
    text = text.rstrip("\n") + "\n"
    with open(a.markdown, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
