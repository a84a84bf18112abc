#!/usr/bin/env python3
"""Plots and tabulates the decimation benchmark (bench/run_decimation.sh).

Reads one JSON object per run (bench_decimation's output), draws the decimation time of
every peer and thread count grouped by input and target, and rewrites the "## Decimation"
section of bench/RESULTS.md; every other section of that file is kept as it is. Run
information (date, machine, command...) comes from environment variables set by
run_decimation.sh.

    plot_decimation.py --results FILE.jsonl --png FILE.png --markdown RESULTS.md
"""
import argparse
import json
import os
import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SECTION = "## Decimation"
EXACT = 1e-6  # relative Hausdorff distances below this are rounding noise
INPUTS = ["x4", "x16"]
RATIOS = [0.1, 0.01]
# (peer, threads) in plot and table order.
CONFIGS = [
    ("idas-sec", 1), ("idas-sec", 2), ("cgal-sec", 1),
    ("idas-qslim", 1), ("idas-qslim", 2), ("cgal-gh", 1), ("openmesh-quadric", 1),
]
LABELS = {
    ("idas-sec", 1): "idas SEC 1T", ("idas-sec", 2): "idas SEC 2T", ("cgal-sec", 1): "CGAL SEC",
    ("idas-qslim", 1): "idas QSlim 1T", ("idas-qslim", 2): "idas QSlim 2T",
    ("cgal-gh", 1): "CGAL GH", ("openmesh-quadric", 1): "OpenMesh quadric",
}
COLORS = {"idas": "#1f77b4", "cgal": "#d62728", "openmesh": "#2ca02c"}
# Peers that keep the same guarantees as idas (manifold output, no normal flips).
GUARANTEED = {"shortest-edge": ["cgal-sec"], "qslim": ["cgal-gh", "openmesh-quadric"]}
IDAS = {"shortest-edge": "idas-sec", "qslim": "idas-qslim"}
ALGO_NAME = {"shortest-edge": "shortest edge collapse", "qslim": "QSlim / quadrics"}


def load(path):
    runs, failures = [], []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            r = json.loads(line)
            (failures if "error" in r else runs).append(r)
    best = {}  # fastest run of each case, with the number of runs and the slowest time
    for r in runs:
        key = (r["peer"], r["input"], float(r["ratio"]), int(r["threads"]))
        old = best.get(key)
        r = dict(r, runs=1, slowest=r["seconds_algorithm"])
        if old:
            r["runs"], r["slowest"] = old["runs"] + 1, max(old["slowest"], r["slowest"])
            if old["seconds_algorithm"] <= r["seconds_algorithm"]:
                old["runs"], old["slowest"] = r["runs"], r["slowest"]
                continue
        best[key] = r
    return best, failures


def pct(r):
    return f"{round(100 * r)}%" if r >= 0.1 else f"{100 * r:g}%"


def plot(best, path):
    fig, axes = plt.subplots(len(INPUTS), len(RATIOS), figsize=(12, 9.5))
    for ax, (inp, ratio) in zip(axes.flat, [(i, r) for i in INPUTS for r in RATIOS]):
        names, values, colors, hatches = [], [], [], []
        for cfg in CONFIGS:
            r = best.get((cfg[0], inp, ratio, cfg[1]))
            names.append(LABELS[cfg])
            values.append(r["seconds_algorithm"] if r else 0)
            colors.append(COLORS[cfg[0].split("-")[0]])
            hatches.append("//" if cfg[1] > 1 else "")
        x = list(range(len(names)))
        bars = ax.bar(x, values, color=colors, hatch=hatches, edgecolor="black", linewidth=0.5)
        for b, v in zip(bars, values):
            ax.annotate(f"{v:.2f}" if v else "n/a", (b.get_x() + b.get_width() / 2, v),
                        ha="center", va="bottom", fontsize=8, xytext=(0, 2),
                        textcoords="offset points")
        ax.axvline(2.5, color="gray", linewidth=0.8, linestyle=":")
        ax.set_xticks(x)
        ax.set_xticklabels(names, rotation=45, ha="right", fontsize=8)
        faces = next((r["input_faces"] for k, r in best.items() if k[1] == inp), 0)
        ax.set_title(f"armadillo {inp} ({faces:,} faces) to {pct(ratio)}", fontsize=10)
        ax.set_ylabel("algorithm seconds (wall)")
        ax.margins(y=0.12)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in COLORS.values()]
    handles.append(plt.Rectangle((0, 0), 1, 1, facecolor="white", edgecolor="black", hatch="//"))
    fig.legend(handles, ["idas", "CGAL 5.5", "OpenMesh 9.0", "2 threads"], loc="lower center",
               ncol=4, fontsize=9)
    fig.suptitle("Decimation time per peer and thread count (lower is better)\nshortest edge "
                 "collapse left of the dotted line, quadric decimation right of it", fontsize=11)
    fig.tight_layout(rect=(0, 0.04, 1, 0.95))
    fig.savefig(path, dpi=110)


def mark(ok):
    return "met" if ok else "**not met**"


def targets(best):
    out = []
    # 1. idas serial time against the fastest peer with the same guarantees.
    out += ["**idas serial time / fastest guaranteed peer** (target: at most 0.5)", "",
            "| algorithm | input | target | idas 1T (s) | fastest peer (s) | ratio | |",
            "|---|---|---|---:|---|---:|---|"]
    for algo in ["shortest-edge", "qslim"]:
        for inp in INPUTS:
            for ratio in RATIOS:
                mine = best.get((IDAS[algo], inp, ratio, 1))
                peers = [best[k] for k in ((p, inp, ratio, 1) for p in GUARANTEED[algo])
                         if k in best]
                if not mine or not peers:
                    continue
                fastest = min(peers, key=lambda r: r["seconds_algorithm"])
                q = mine["seconds_algorithm"] / fastest["seconds_algorithm"]
                out.append(f"| {ALGO_NAME[algo]} | {inp} | {pct(ratio)} | "
                           f"{mine['seconds_algorithm']:.2f} | {fastest['peer']} "
                           f"{fastest['seconds_algorithm']:.2f} | {q:.2f} | {mark(q <= 0.5)} |")
    # 2. QSlim's Hausdorff distance against CGAL Garland-Heckbert.
    out += ["", "**idas QSlim Hausdorff / CGAL Garland-Heckbert Hausdorff**, same target face "
            "count, serial runs (target: at most 1.1)", "",
            "| input | target | faces (idas / CGAL) | one-sided out->in | ratio | | symmetric | "
            "ratio | |", "|---|---|---|---:|---:|---|---:|---:|---|"]
    exact_seen = False
    for inp in INPUTS:
        for ratio in RATIOS:
            q, g = best.get(("idas-qslim", inp, ratio, 1)), best.get(("cgal-gh", inp, ratio, 1))
            if not q or not g:
                continue
            cells = []
            for h in ["hausdorff_out_in", "hausdorff_symmetric"]:
                cells.append(f"{q[h]:.3g} / {g[h]:.3g}")
                if max(q[h], g[h]) < EXACT:
                    cells += ["-", "met (both exact)"]
                    exact_seen = True
                else:
                    cells += [f"{q[h] / g[h]:.2f}", mark(q[h] / g[h] <= 1.1)]
            out.append(f"| {inp} | {pct(ratio)} | {q['output_faces']:,} / {g['output_faces']:,} | "
                       + " | ".join(cells) + " |")
    if exact_seen:
        out += ["", f"Distances below {EXACT:g} are rounding noise: a target above armadillo's "
                "86,482 faces (x16 to 10% is 138,371) lets quadric decimation undo the flat 1-to-4 "
                "splits and return exactly to armadillo's surface, so no ratio is meaningful there."]
    # 3. Two threads against one on the 1.38M-face input.
    out += ["", "**idas 2-thread speedup over 1 thread on x16** (target: at least 1.6)", "",
            "| algorithm | target | 1T (s) | 2T (s) | speedup | |", "|---|---|---:|---:|---:|---|"]
    for algo in ["shortest-edge", "qslim"]:
        for ratio in RATIOS:
            a = best.get((IDAS[algo], "x16", ratio, 1))
            b = best.get((IDAS[algo], "x16", ratio, 2))
            if not a or not b:
                continue
            s = a["seconds_algorithm"] / b["seconds_algorithm"]
            out.append(f"| {ALGO_NAME[algo]} | {pct(ratio)} | {a['seconds_algorithm']:.2f} | "
                       f"{b['seconds_algorithm']:.2f} | {s:.2f} | {mark(s >= 1.6)} |")
    # 4. Output face count against the target.
    idas_runs = [r for k, r in best.items() if k[0].startswith("idas")]
    if idas_runs:
        worst = max(idas_runs, key=lambda r: abs(r["face_error"]))
        ok = abs(worst["face_error"]) <= 0.01
        out += ["", f"**Output face count vs target** (target: within 1%): largest idas error "
                f"{100 * worst['face_error']:+.3f}% ({worst['peer']} {worst['threads']}T, "
                f"{worst['input']} to {pct(worst['ratio'])}: {worst['output_faces']:,} faces for "
                f"a target of {worst['target_faces']:,}): {mark(ok)}."]
    return out


def all_runs(best):
    out = ["Seconds: the fastest of the case's runs, then the slowest and the number of runs "
           "(the other columns are those of the fastest run).", "",
           "| input | target | peer | threads | seconds | slowest (runs) | output faces | "
           "face error | Hausdorff out->in | Hausdorff sym. | peak RSS delta (MB) | "
           "manifold, chi | collapses |",
           "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|"]
    for inp in INPUTS:
        for ratio in RATIOS:
            for peer, threads in CONFIGS:
                r = best.get((peer, inp, ratio, threads))
                if not r:
                    out.append(f"| {inp} | {pct(ratio)} | {peer} | {threads} | failed | | | | | | "
                               "| | |")
                    continue
                topo = f"{'yes' if r['manifold'] else 'NO'}, {r['euler']}"
                mem = f"{r['peak_rss_delta_mb']:.0f}" + ("" if r["peak_reset"] else " (not reset)")
                out.append(f"| {inp} | {pct(ratio)} | {peer} | {threads} | "
                           f"{r['seconds_algorithm']:.2f} | {r['slowest']:.2f} ({r['runs']}) | "
                           f"{r['output_faces']:,} | "
                           f"{100 * r['face_error']:+.3f}% | {r['hausdorff_out_in']:.3g} | "
                           f"{r['hausdorff_symmetric']:.3g} | {mem} | {topo} | "
                           f"{r.get('collapses', 0):,} |")
    out += ["", "idas executor counters: queue entries pushed and popped, popped entries found "
            "stale, stale entries swept out of the queue without being popped, collapses refused "
            "(link condition or normal flip), lock failures, entries deferred to the final serial "
            "pass:", "",
            "| input | target | peer | threads | pushed | popped | stale | swept | refused | "
            "lock failures | deferred |", "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for inp in INPUTS:
        for ratio in RATIOS:
            for peer, threads in CONFIGS:
                r = best.get((peer, inp, ratio, threads))
                if not r or not peer.startswith("idas"):
                    continue
                out.append(f"| {inp} | {pct(ratio)} | {peer} | {threads} | {r['pushed']:,} | "
                           f"{r['popped']:,} | {r['stale']:,} | {r.get('purged', 0):,} | "
                           f"{r['refused']:,} | {r['lock_failures']:,} | "
                           f"{r['deferred_to_serial']:,} |")
    return out


def section(best, failures, png):
    env = os.environ.get
    samples = next(iter(best.values()))["hausdorff_samples_per_area"] if best else 0
    lines = [SECTION, "",
             "`bench_decimation` (bench/bench_decimation.cpp) run by `bench/run_decimation.sh`: "
             "armadillo (data/armadillo.obj, 86,482 faces) upsampled at run time by 1-to-4 midpoint "
             "subdivision to x4 (345,928 faces) and x16 (1,383,712 faces), decimated to 10% and 1% "
             "of its faces. Each case is a separate process.", "",
             "- Peers. Shortest edge collapse: `idas::algorithms::shortest_edge_collapse<true>` "
             "(link condition, no normal flip) against CGAL `Surface_mesh_simplification::"
             "edge_collapse` with `Edge_length_cost` + `Midpoint_placement` and "
             "`Bounded_normal_change_filter` (which CGAL 5.5 has but does not use by default; "
             "it refuses collapses that turn a face's normal by 90 degrees or more, like idas's "
             "`no_normal_flip`). Quadrics: `idas::algorithms::qslim` (area-weighted plane "
             "quadrics, optimal placement) against CGAL `GarlandHeckbert_plane_policies` (classic "
             "Garland-Heckbert plane quadrics, not area-weighted, optimal placement), also with "
             "`Bounded_normal_change_filter`, and OpenMesh `DecimaterT` with `ModQuadricT` "
             "(priority) and `ModNormalFlippingT` (binary, 90 degrees; OpenMesh collapses "
             "halfedges, so the merged vertex stays at an endpoint). CGAL uses "
             "`Surface_mesh<Simple_cartesian<double>::Point_3>`, OpenMesh `TriMesh_ArrayKernelT` "
             "with double points and normals. CGAL's stop predicate counts faces (a collapse "
             "visitor keeps the count), OpenMesh uses `decimate_to_faces`, idas its "
             "`face_target`.",
             "- Seconds: wall time of the decimation call only. idas: `Algorithm::run` (includes "
             "QSlim's quadric set-up and filling the queue). CGAL: `edge_collapse` (includes "
             "collecting edges, costs and, for GH, creating and filling the quadric map). "
             "OpenMesh: requesting status and face normals, computing normals, building the "
             "decimater and its modules, `initialize` and `decimate_to_faces`. Excluded for all: "
             "reading, subdivision, building the peer's mesh from the face list, garbage "
             "collection and extracting the result.",
             "- Hausdorff: CGAL `approximate_Hausdorff_distance` (random uniform face samples at a "
             f"fixed density of {samples:g} per armadillo surface area, plus every vertex, fixed "
             "seed), divided by the input's bounding-box diagonal; the same method for every peer. "
             "The reference is armadillo itself: the subdivided inputs are the same surface. "
             "\"out->in\" samples the output; \"sym.\" is the larger of both directions.",
             "- Peak RSS delta: `getrusage(RUSAGE_SELF)` peak at the end of the decimation (before "
             "the Hausdorff step) minus the RSS after loading and subdividing the input, with the "
             "kernel's peak mark reset in between: the peer's own mesh, its working memory and the "
             "(small) extracted result.",
             "- \"manifold, chi\": the output face list is an oriented 2-manifold, and its Euler "
             "characteristic (the input's is 2).", "",
             f"- Date: {env('DATE', '?')}",
             f"- Machine: {env('MACHINE', '?')} ({env('LOAD', '?')}). The machine is shared: "
             "compare ratios between peers of one run, not absolute times across runs.",
             f"- Compiler: {env('COMPILER', '?')}; peers: {env('PEERS', '?')} (Debian packages)",
             f"- Build: `{env('BUILD', '?')}`",
             f"- Command: `{env('COMMAND', '?')}` (all cases took {env('WALL', '?')} s in all)",
             "", f"![decimation time per peer]({os.path.basename(png)})", "",
             "### Targets", ""]
    lines += targets(best)
    lines += ["", "### All runs", ""]
    if failures:
        lines += ["Failed runs: " + "; ".join(
            f"{f['peer']} {f['input']} {pct(float(f['ratio']))} {f['threads']}T ({f['error']})"
            for f in failures), ""]
    lines += all_runs(best)
    return "\n".join(lines) + "\n"


def rewrite(markdown, text):
    old = open(markdown).read() if os.path.exists(markdown) else "# idas benchmark results\n"
    parts = re.split(r"(?m)^(?=## )", old)
    preamble, body = parts[0], parts[1:]
    replaced = False
    for i, p in enumerate(body):
        if p.splitlines()[0].strip() == SECTION:
            body[i], replaced = text, True
    if not replaced:
        body.append(text)
    out = preamble.rstrip("\n") + "\n\n" + "\n".join(s.rstrip("\n") + "\n" for s in body)
    with open(markdown, "w") as f:
        f.write(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", required=True)
    ap.add_argument("--png", required=True)
    ap.add_argument("--markdown", required=True)
    a = ap.parse_args()
    best, failures = load(a.results)
    plot(best, a.png)
    rewrite(a.markdown, section(best, failures, a.png))
    print(f"wrote {a.png} and the {SECTION!r} section of {a.markdown}")


if __name__ == "__main__":
    main()
