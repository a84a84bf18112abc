#!/usr/bin/env bash
# Builds and runs the core benchmarks, then rewrites their sections of bench/RESULTS.md
# ("## Triangle core" and, when bench_predicates builds, "## Predicates"); every other
# section of the file is kept as it is.
#
#   bench/run_core.sh [extra Google Benchmark flags...]
#
# Configures the CMake preset "bench" (build dir build/bench). If that configure or
# build fails, bench_tri_core is compiled directly with g++ instead and the failure is
# noted in RESULTS.md.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
results="$root/bench/RESULTS.md"
build="$root/build/bench"
min_time="0.2"
extra_args=("$@")
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

build_note=""
core_bin="$build/bench/bench_tri_core"
pred_bin=""
build_cmds="cmake --preset bench && cmake --build build/bench --target bench_tri_core"

if cmake --preset bench >"$work/configure.log" 2>&1 &&
    cmake --build "$build" --target bench_tri_core >"$work/build.log" 2>&1; then
    if [[ -f bench/bench_predicates.cpp ]]; then
        if cmake --build "$build" --target bench_predicates >"$work/build_pred.log" 2>&1; then
            pred_bin="$build/bench/bench_predicates"
            build_cmds+=" bench_predicates"
        else
            build_note+="bench_predicates failed to build (see cmake --build build/bench --target bench_predicates); its section was not updated. "
        fi
    fi
else
    echo "run_core.sh: preset build failed, compiling bench_tri_core directly" >&2
    tail -n 30 "$work/configure.log" "$work/build.log" 2>/dev/null >&2 || true
    mkdir -p "$build/direct"
    core_bin="$build/direct/bench_tri_core"
    direct=(g++ -std=c++20 -O3 -DNDEBUG -march=native -Wall -Wextra -I"$root/include"
        "-DIDAS_DATA_DIR=\"$root/data\"" bench/bench_tri_core.cpp -o "$core_bin"
        -lbenchmark -lpthread -lgmpxx -lgmp -ltbb)
    "${direct[@]}"
    build_cmds="${direct[*]}"
    build_note+="The CMake preset build failed, so bench_tri_core was compiled directly. "
fi

load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
core_cmd=("$core_bin" "--benchmark_min_time=$min_time" "--benchmark_out=$work/core.json"
    "--benchmark_out_format=json" "${extra_args[@]}")
echo "+ ${core_cmd[*]}" >&2
"${core_cmd[@]}" 2>&1 | tee "$work/core.txt"
if [[ -n "$pred_bin" ]]; then
    pred_cmd=("$pred_bin" "--benchmark_min_time=$min_time" "${extra_args[@]}")
    echo "+ ${pred_cmd[*]}" >&2
    "${pred_cmd[@]}" 2>&1 | tee "$work/pred.txt"
fi
load_after="$(cut -d' ' -f1-3 /proc/loadavg)"

rel() { echo "${1#"$root"/}"; }
export RESULTS="$results" WORK="$work" NOTE="$build_note"
export DATE="$(date -u '+%Y-%m-%d %H:%M UTC')"
export MACHINE="$(nproc) logical CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(free -g | awk '/^Mem:/{print $2}') GiB RAM"
export COMPILER="$(${CXX:-c++} --version | head -n1)"
export LOAD="load average $load_before before, $load_after after"
export BUILD_CMDS="$build_cmds"
args_text="${extra_args[*]:+ ${extra_args[*]}}"
export CORE_CMD="$(rel "$core_bin") --benchmark_min_time=$min_time --benchmark_out=<tmp>/core.json --benchmark_out_format=json$args_text"
export PRED_CMD="${pred_bin:+$(rel "$pred_bin") --benchmark_min_time=$min_time$args_text}"

python3 - <<'PY'
import json, os, re

results, work = os.environ["RESULTS"], os.environ["WORK"]

def fmt_rate(x):
    for unit, scale in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if x >= scale:
            return f"{x / scale:.1f} {unit}/s"
    return f"{x:.0f} /s"

BACKENDS = ["indexed", "corner_table"]

def split_backend(name):
    """'op/split_edge/commit/indexed' -> ('op/split_edge/commit', 'indexed')."""
    head, _, tail = name.rpartition("/")
    return (head, tail) if tail in BACKENDS else (name, "")

def summary(path):
    runs = [b for b in json.load(open(path))["benchmarks"] if b.get("run_type", "iteration") == "iteration"]
    by = {}
    order = []
    for b in runs:
        base, backend = split_backend(b["name"])
        if base not in by:
            by[base] = {}
            order.append(base)
        by[base][backend] = b
    out = []

    def ns(b):
        return 1e9 / b["items_per_second"]

    def ratio(row):
        if all(k in row for k in BACKENDS):
            return f"{ns(row['corner_table']) / ns(row['indexed']):.2f}"
        return ""

    nav = [n for n in order if n.startswith("nav/")]
    if nav:
        out += ["Navigation, ns per item (items are switches, checks, vertices, faces or edges; CPU",
                "time); the last column is corner_table / indexed, below 1 where the corner table is",
                "faster. No row allocates.", "",
                "| benchmark | indexed | corner_table | ratio |", "|---|---:|---:|---:|"]
        for n in nav:
            row = by[n]
            cells = [f"{ns(row[k]):.2f}" if k in row else "" for k in BACKENDS]
            out.append(f"| `{n}` | " + " | ".join(cells) + f" | {ratio(row)} |")
        out.append("")
    ops = [n for n in order if n.startswith("op/")]
    if ops:
        out += ["Operations, ns per operation (CPU time; allocs/op in brackets, `ok` = the fraction",
                "no_normal_flip let through); the last column is corner_table / indexed:", "",
                "| operation | mode | indexed | corner_table | ratio |", "|---|---|---:|---:|---:|"]
        for n in ops:
            _, op, mode = n.split("/", 2)
            row = by[n]
            cells = []
            for k in BACKENDS:
                b = row.get(k)
                if b is None:
                    cells.append("")
                    continue
                note = f" ok {b.get('ok', 1):.3f}" if mode == "commit+no_normal_flip" else ""
                cells.append(f"{ns(b):.0f} ({b.get('allocs/op', 0):.2g}){note}")
            out.append(f"| `{op}` | {mode} | " + " | ".join(cells) + f" | {ratio(row)} |")
        out.append("")
    pairs = [n for n in order if n.startswith(("pair/", "op_in_mesh_order/"))]
    if pairs:
        out += ["Steady-state pairs, and operations visited in mesh order instead of random order",
                "(ns per operation, allocs/op in brackets):", "",
                "| benchmark | indexed | corner_table | ratio |", "|---|---:|---:|---:|"]
        for n in pairs:
            row = by[n]
            cells = [f"{ns(row[k]):.0f} ({row[k].get('allocs/op', 0):.2g})" if k in row else "" for k in BACKENDS]
            out.append(f"| `{n}` | " + " | ".join(cells) + f" | {ratio(row)} |")
        out.append("")
    mem = by.get("mem/connectivity", {})
    if mem:
        out += ["Connectivity memory (vertex positions add the same to both):", "",
                "| backend | bytes/face | bytes/vertex | positions, bytes/face |", "|---|---:|---:|---:|"]
        for k in BACKENDS:
            if k in mem:
                m = mem[k]
                out.append(f"| {k} | **{m['bytes/face']:.1f}** | {m['bytes/vertex']:.1f} | {m['attr_bytes/face']:.1f} |")
        out.append("")
    return out

def kept_analysis(title):
    """The hand-written part of a section, between <!-- analysis --> and <!-- /analysis -->."""
    if not os.path.exists(results):
        return []
    m = re.search(r"(?ms)^" + re.escape(title) + r"\n.*?(<!-- analysis -->.*?<!-- /analysis -->)", open(results).read())
    return [m.group(1), ""] if m else []

def header(cmd):
    lines = [f"- Date: {os.environ['DATE']}",
             f"- Machine: {os.environ['MACHINE']} ({os.environ['LOAD']})",
             f"- Compiler: {os.environ['COMPILER']}",
             f"- Build: `{os.environ['BUILD_CMDS']}`",
             f"- Command: `{cmd}`"]
    if os.environ["NOTE"]:
        lines.append(f"- Note: {os.environ['NOTE'].strip()}")
    return lines + [""]

core = ["## Triangle core", "",
        "`bench_tri_core` on data/bunny.obj. The method (batches on fresh copies for commits,",
        "in-place cycling for rollbacks, independent edge sets, counting allocator) is",
        "described at the top of bench/bench_tri_core.cpp. Times below are CPU time; when the",
        "machine is loaded, wall time (the \"Time\" column) is larger. The \"Library was built",
        "as DEBUG\" warning in the output is about Debian's libbenchmark package, not idas.", ""]
core += header(os.environ["CORE_CMD"])
core += summary(os.path.join(work, "core.json"))
core += kept_analysis("## Triangle core")
core += ["Full output:", "", "```text", open(os.path.join(work, "core.txt")).read().rstrip(), "```", ""]
sections = {"## Triangle core": "\n".join(core)}

pred_txt = os.path.join(work, "pred.txt")
if os.path.exists(pred_txt):
    pred = ["## Predicates", ""] + header(os.environ["PRED_CMD"])
    pred += ["```text", open(pred_txt).read().rstrip(), "```", ""]
    sections["## Predicates"] = "\n".join(pred)

intro = """# idas benchmark results

Regenerate the sections below with `bench/run_core.sh` from the repository root (it
configures the CMake preset `bench`, builds the benchmarks in build/bench and rewrites
its own sections of this file; other sections are left alone). Numbers depend on the
machine and on its load: compare runs made on the same machine.
"""
text = open(results).read() if os.path.exists(results) else intro
# Split into the preamble and "## " sections, replace ours, append missing ones.
parts = re.split(r"(?m)^(?=## )", text)
preamble, body = parts[0], parts[1:]
new_body, seen = [], set()
for p in body:
    title = p.splitlines()[0].strip()
    if title in sections:
        new_body.append(sections[title] + "\n")
        seen.add(title)
    else:
        new_body.append(p if p.endswith("\n") else p + "\n")
for title, content in sections.items():
    if title not in seen:
        new_body.append(content + "\n")
out = preamble.rstrip("\n") + "\n\n" + "\n".join(s.rstrip("\n") + "\n" for s in new_body)
open(results, "w").write(out)
print(f"wrote {results}")
PY
