#!/usr/bin/env python3
"""Tabulates and plots the scaling benchmark (bench/run_scaling.sh).

Reads one JSON object per run (the `idas` tool's --json output, or bench_harmonic's for
the CGAL peer), keeps each (case, threads) pair's fastest run, and rewrites the
"## Scaling" section of bench/RESULTS.md (other sections are kept): speedups of the
algorithm and of the whole command, the per-phase wall times, the issue's target ratios,
and the 16-thread figures Amdahl's law predicts phase by phase from the two smallest thread
counts measured. Draws bench/scaling.png when matplotlib is there.

    plot_scaling.py --results FILE.jsonl --png FILE.png --markdown RESULTS.md
"""
import argparse
import json
import os
import re

SECTION = "## Scaling"
CASES = ["decimate-qslim", "decimate-sec", "remesh", "harmonic-reduced", "harmonic-complete"]
PREDICT_AT = 16


def algorithm_seconds(r):
    """The algorithm's wall time: the editing itself, plus the Delaunay input of harmonic."""
    if "seconds_algorithm" in r:
        return r["seconds_algorithm"]
    if "seconds_flipping" in r:
        return r["seconds_delaunay"] + r["seconds_flipping"]
    return r["cgal_delaunay_seconds"]


def total_seconds(r):
    return r.get("seconds_total", r.get("cgal_delaunay_seconds"))


def is_algorithm_phase(name):
    return name.split("_")[0] in ("decimation", "remeshing", "flipping", "delaunay")


def load(path):
    best = {}
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            r = json.loads(line)
            key = (r["case"], r["threads_asked"])
            if key not in best or total_seconds(r) < total_seconds(best[key]):
                best[key] = r
    return best


def amdahl(ta, a, tb, b, at):
    """Time at `at` threads of a phase that took a seconds on ta threads and b on tb,
    with its serial fraction fitted from the two (clamped to [0, 1])."""
    if a <= 0:
        return b
    ratio = b / a
    denominator = 1 - 1 / tb - ratio + ratio / ta
    s = 1.0 if abs(denominator) < 1e-12 else (ratio / ta - 1 / tb) / denominator
    s = min(1.0, max(0.0, s))
    one = a / (s + (1 - s) / ta)
    return one * (s + (1 - s) / at)


def prediction(runs_by_threads):
    """(algorithm, total) seconds predicted at PREDICT_AT threads, phase by phase."""
    # The two largest thread counts measured below it: their serial fractions are the ones
    # that still matter at more threads.
    counts = sorted(t for t in runs_by_threads if t < PREDICT_AT)
    if len(counts) < 2:
        return None
    ta, tb = counts[-2], counts[-1]
    pa, pb = runs_by_threads[ta].get("phases"), runs_by_threads[tb].get("phases")
    if not pa or not pb:
        return None
    algorithm = total = 0.0
    for name, a in pa.items():
        if name == "total" or name not in pb:
            continue
        t = amdahl(ta, a, tb, pb[name], PREDICT_AT)
        total += t
        if is_algorithm_phase(name):
            algorithm += t
    return algorithm, total


def markdown(best):
    env = os.environ
    threads = sorted({t for (_, t) in best})
    out = [SECTION, ""]
    out.append(f"Measured {env.get('SCALING_DATE', '?')} on {env.get('SCALING_CPU', '?')} "
               f"({env.get('SCALING_CORES', '?')} cores; load before: "
               f"{env.get('SCALING_LOAD', '?')}), {env.get('SCALING_MINUTES', '?')} minutes. "
               f"Inputs: {env.get('SCALING_INPUT', '?')}. Release build, the `idas` tool, one "
               "process per run, fastest of the repeats.")
    out.append("")
    out.append(f"    {env.get('SCALING_COMMAND', 'bench/run_scaling.sh')}")
    out.append("")
    out.append("Algorithm: the editing (decimation, remeshing; for harmonic, Delaunay + flipping); "
               "total: the whole command (reading, checking, writing included). Speedups are "
               "against 1 thread in the same run.")
    out.append("")
    out.append("| case | threads | algorithm s | total s | algorithm speedup | total speedup "
               "| total / algorithm |")
    out.append("|---|---|---|---|---|---|---|")
    for case in CASES + ["cgal-delaunay"]:
        one = best.get((case, 1))
        for t in threads:
            r = best.get((case, t))
            if not r:
                continue
            a, tot = algorithm_seconds(r), total_seconds(r)
            sa = f"{algorithm_seconds(one) / a:.2f}x" if one else "-"
            st = f"{total_seconds(one) / tot:.2f}x" if one else "-"
            out.append(f"| {case} | {t} | {a:.3f} | {tot:.3f} | {sa} | {st} | {tot / a:.2f} |")
    out.append("")

    out.append(f"Per-phase wall seconds (1 thread / {threads[-1]} threads). Phases named "
               "`*_setup` and `*_serial_tail` run on one thread inside the algorithm.")
    out.append("")
    for case in CASES:
        one, many = best.get((case, 1)), best.get((case, threads[-1]))
        if not one or "phases" not in one:
            continue
        cells = []
        for name, s in one["phases"].items():
            if name == "total":
                continue
            m = many["phases"].get(name) if many else None
            cells.append(f"{name} {s:.2f}" + (f" / {m:.2f}" if m is not None else ""))
        out.append(f"- {case}: " + ", ".join(cells))
    out.append("")

    out.append(f"Predicted at {PREDICT_AT} threads by Amdahl's law, each phase's serial fraction "
               f"fitted from the two largest thread counts below {PREDICT_AT} above (a guide "
               f"where no {PREDICT_AT}-thread run is listed; a measured run replaces it):")
    out.append("")
    out.append(f"| case | algorithm s at 1 | predicted algorithm s at {PREDICT_AT} | speedup "
               f"| predicted total s at {PREDICT_AT} | total / algorithm |")
    out.append("|---|---|---|---|---|---|")
    for case in CASES:
        runs = {t: best[(c, t)] for (c, t) in best if c == case}
        p = prediction(runs)
        if not p or 1 not in runs:
            continue
        a1 = algorithm_seconds(runs[1])
        out.append(f"| {case} | {a1:.3f} | {p[0]:.3f} | {a1 / p[0]:.1f}x | {p[1]:.3f} "
                   f"| {p[1] / p[0]:.2f} |")
    out.append("")

    # The most threads at which both the harmonic run and CGAL's Delaunay were measured.
    both = [t for t in threads
            if ("cgal-delaunay", t) in best and ("harmonic-complete", t) in best]
    top = both[-1] if both else threads[-1]
    cg1, cgt = best.get(("cgal-delaunay", 1)), best.get(("cgal-delaunay", top))
    hc1, hct = best.get(("harmonic-complete", 1)), best.get(("harmonic-complete", top))
    if cg1 and hc1 and cgt and hct:
        out.append("Harmonic targets (same run): complete-mode flipping on one thread / CGAL's "
                   f"serial Delaunay = {hc1['seconds_flipping'] / cg1['cgal_delaunay_seconds']:.2f} "
                   "(target at most 1.0); at "
                   f"{top} threads, Delaunay + flipping / CGAL's parallel Delaunay = "
                   f"{algorithm_seconds(hct) / cgt['cgal_delaunay_seconds']:.2f} (target at most "
                   f"2.5 at 16 threads), whole command / CGAL's parallel Delaunay = "
                   f"{total_seconds(hct) / cgt['cgal_delaunay_seconds']:.2f} (target at most 4).")
        out.append("")
    return "\n".join(out) + "\n"


def write_section(path, text):
    old = open(path).read() if os.path.exists(path) else ""
    pattern = re.compile(r"^## Scaling\n.*?(?=^## |\Z)", re.S | re.M)
    new = pattern.sub(lambda _: text + "\n", old) if pattern.search(old) else \
        old.rstrip("\n") + "\n\n" + text
    with open(path, "w") as f:
        f.write(new)


def plot(best, png):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not found: no plot drawn")
        return
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, (title, measure) in zip(axes, [("algorithm", algorithm_seconds),
                                           ("whole command", total_seconds)]):
        counts = sorted({t for (_, t) in best})
        for case in CASES + ["cgal-delaunay"]:
            pts = [(t, best[(case, t)]) for t in counts if (case, t) in best]
            if (case, 1) not in best or len(pts) < 2:
                continue
            base = measure(best[(case, 1)])
            ax.plot([t for t, _ in pts], [base / measure(r) for _, r in pts], marker="o",
                    label=case)
        ax.plot(counts, counts, color="grey", linestyle=":", label="linear")
        ax.set_xscale("log", base=2)
        ax.set_xticks(counts, [str(c) for c in counts])
        ax.set_xlabel("threads")
        ax.set_title(f"speedup of the {title}")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("speedup over 1 thread")
    axes[1].legend(fontsize=8)
    env = os.environ
    fig.suptitle(f"{env.get('SCALING_CPU', '')} ({env.get('SCALING_CORES', '?')} cores)",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--results", required=True)
    ap.add_argument("--png", required=True)
    ap.add_argument("--markdown", required=True)
    a = ap.parse_args()
    best = load(a.results)
    text = markdown(best)
    write_section(a.markdown, text)
    plot(best, a.png)
    print(text)


if __name__ == "__main__":
    main()
