#!/usr/bin/env python3
"""Tabulates and plots bench/run_tetmesh.sh's results (one JSON object per run).

    plot_tetmesh.py --results FILE.jsonl [--table] [--time-png FILE] [--amips-png FILE]

--table prints the Markdown table of RESULTS.md; --time-png draws the seconds of every tool
and thread count per input; --amips-png the AMIPS histogram of each tool at one thread,
summed over the inputs every tool meshed (so the tools are compared on the same inputs).
The plots need matplotlib (Debian's python3-matplotlib); the table does not.
"""
import argparse
import json


def load(path):
    return [json.loads(line) for line in open(path) if line.strip()]


def label(r):
    return "%s %dt" % (r["tool"], r["threads"]) if r["tool"] != "TetGen" else "TetGen"


def fmt(x, spec):
    return "-" if x is None else format(x, spec)


def table(rows):
    print("| input | tool | s | tets | vertices | AMIPS min / mean / max | AMIPS > 10 | min dihedral"
          " | inverted | closed 2-manifold | boundary -> input | input -> boundary |")
    print("|---|---|---:|---:|---:|---|---:|---:|---:|---|---:|---:|")
    for r in rows:
        name = r["input"]
        if r["status"] != "ok":
            print("| %s | %s | %s |  |  |  |  |  |  |  |  |  |" % (name, label(r), r["status"][:60]))
            continue
        i, s = r["info"], r["seconds"]
        a = i["amips"]
        hist = a["histogram"]
        above = sum(c for b, c in zip(hist["bounds"], hist["counts"]) if b >= 10)
        infinite = i["tets"] - a["finite_tets"]
        ref = i["reference"]
        print("| %s | %s | %.2f | %d | %d | %s / %s / %s | %d | %.2f | %d | %s | %s | %s |" % (
            name, label(r), s["wall"], i["tets"], i["referenced_vertices"],
            fmt(a["min"], ".2f"), fmt(a["mean"], ".2f"), fmt(a["max"], ".3g"),
            above + infinite, i["dihedral_angle_deg"]["min"], i["inverted_tets"],
            "yes" if i["boundary"]["closed_2_manifold"] else "no",
            fmt(ref["surface_to_reference"]["relative"], ".2e"),
            fmt(ref["reference_to_surface"]["relative"], ".2e")))


def time_plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    inputs = list(dict.fromkeys(r["input"] for r in rows))
    series = list(dict.fromkeys(label(r) for r in rows))
    width = 0.8 / len(series)
    fig, ax = plt.subplots(figsize=(max(8, 0.9 * len(inputs)), 4.5))
    for k, s in enumerate(series):
        xs, ys = [], []
        for j, name in enumerate(inputs):
            for r in rows:
                if r["input"] == name and label(r) == s and r["status"] == "ok":
                    xs.append(j + (k - (len(series) - 1) / 2) * width)
                    ys.append(r["seconds"]["wall"])
        ax.bar(xs, ys, width, label=s)
    ax.set_yscale("log")
    ax.set_ylabel("seconds (whole command)")
    ax.set_xticks(range(len(inputs)))
    ax.set_xticklabels(inputs, rotation=35, ha="right", fontsize=8)
    ax.legend(fontsize=8, ncol=3)
    ax.set_title("Tetrahedral meshing: time per input (a missing bar: the tool failed)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def amips_plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    one = [r for r in rows if r["threads"] == 1]
    tools = list(dict.fromkeys(r["tool"] for r in one))
    inputs = [name for name in dict.fromkeys(r["input"] for r in one)
              if all(any(r["input"] == name and r["tool"] == t and r["status"] == "ok" for r in one)
                     for t in tools)]
    fig, ax = plt.subplots(figsize=(9, 4.5))
    bounds = None
    for t in tools:
        counts = None
        for r in one:
            if r["tool"] == t and r["input"] in inputs and r["status"] == "ok":
                h = r["info"]["amips"]["histogram"]
                bounds = h["bounds"]
                counts = h["counts"] if counts is None else [a + b for a, b in zip(counts, h["counts"])]
        if counts is None:
            continue
        total = sum(counts)
        ax.step(range(len(counts)), [c / total for c in counts], where="post", label=t)
    if bounds is not None:
        ticks = [k for k, b in enumerate(bounds) if b == int(b)]
        ax.set_xticks(ticks)
        ax.set_xticklabels([("%g" % bounds[k]) for k in ticks], fontsize=8)
    ax.set_yscale("log")
    ax.set_xlabel("AMIPS energy (bins: quarters up to 10, then coarser; 3 = regular tet)")
    ax.set_ylabel("fraction of tets")
    ax.set_title("AMIPS per tool, one thread, the %d inputs every tool meshed" % len(inputs))
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", required=True)
    ap.add_argument("--table", action="store_true")
    ap.add_argument("--time-png")
    ap.add_argument("--amips-png")
    a = ap.parse_args()
    rows = load(a.results)
    if a.table:
        table(rows)
    if a.time_png:
        time_plot(rows, a.time_png)
    if a.amips_png:
        amips_plot(rows, a.amips_png)


if __name__ == "__main__":
    main()
