#!/usr/bin/env bash
# Builds and runs bench_policies, then rewrites the "## Policies" section of
# bench/RESULTS.md; every other section of the file is kept as it is, and so is the
# hand-written part of this one (between <!-- analysis --> and <!-- /analysis -->).
#
#   bench/run_policies.sh [--repetitions N] [extra Google Benchmark flags...]
#
# Configures the CMake preset "bench" (build dir build/bench) unless IDAS_BENCH_BUILD names
# another configured build dir (e.g. IDAS_BENCH_BUILD=build/h4). The micro-benchmarks
# (lock/, queue/, partition/) run with --benchmark_min_time=0.2; the whole runs (run/) are
# one iteration each, repeated N times (default 3), and the tables show the median.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
results="$root/bench/RESULTS.md"
repetitions=3
if [[ "${1:-}" == "--repetitions" ]]; then
    repetitions="$2"
    shift 2
fi
extra_args=("$@")
min_time="0.2"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

if [[ -n "${IDAS_BENCH_BUILD:-}" ]]; then
    build="$root/${IDAS_BENCH_BUILD#"$root"/}"
    build_cmds="cmake --build ${IDAS_BENCH_BUILD#"$root"/} --target bench_policies"
else
    build="$root/build/bench"
    build_cmds="cmake --preset bench && cmake --build build/bench --target bench_policies"
    cmake --preset bench >"$work/configure.log" 2>&1 || {
        cat "$work/configure.log" >&2
        exit 1
    }
fi
cmake --build "$build" --target bench_policies >"$work/build.log" 2>&1 || {
    tail -n 40 "$work/build.log" >&2
    exit 1
}
bin="$build/bench/bench_policies"

load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
micro_cmd=("$bin" "--benchmark_filter=^(lock|queue|partition)/" "--benchmark_min_time=$min_time"
    "--benchmark_out=$work/micro.json" "--benchmark_out_format=json" "${extra_args[@]}")
echo "+ ${micro_cmd[*]}" >&2
"${micro_cmd[@]}" 2>&1 | tee "$work/micro.txt"
runs_cmd=("$bin" "--benchmark_filter=^run/" "--benchmark_repetitions=$repetitions"
    "--benchmark_out=$work/runs.json" "--benchmark_out_format=json" "${extra_args[@]}")
echo "+ ${runs_cmd[*]}" >&2
"${runs_cmd[@]}" 2>&1 | tee "$work/runs.txt"
load_after="$(cut -d' ' -f1-3 /proc/loadavg)"

rel() { echo "${1#"$root"/}"; }
args_text="${extra_args[*]:+ ${extra_args[*]}}"
export RESULTS="$results" WORK="$work"
export DATE="$(date -u '+%Y-%m-%d %H:%M UTC')"
export MACHINE="$(nproc) logical CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(free -g | awk '/^Mem:/{print $2}') GiB RAM"
export COMPILER="$(${CXX:-c++} --version | head -n1)"
export LOAD="load average $load_before before, $load_after after"
export BUILD_CMDS="$build_cmds"
export SCRIPT_CMD="bench/run_policies.sh --repetitions $repetitions$args_text"
export MICRO_CMD="$(rel "$bin") --benchmark_filter='^(lock|queue|partition)/' --benchmark_min_time=$min_time$args_text"
export RUNS_CMD="$(rel "$bin") --benchmark_filter='^run/' --benchmark_repetitions=$repetitions$args_text"

python3 - <<'PY'
import json, os, re, statistics

results, work = os.environ["RESULTS"], os.environ["WORK"]

def load(name):
    runs = json.load(open(os.path.join(work, name)))["benchmarks"]
    by = {}
    for b in runs:
        if b.get("run_type", "iteration") != "iteration" or b.get("error_occurred"):
            continue
        by.setdefault(b.get("run_name", b["name"]), []).append(b)
    # The median repetition by real time stands for the benchmark.
    return {k: sorted(v, key=lambda b: b["real_time"])[len(v) // 2] for k, v in by.items()}

micro, runs = load("micro.json"), load("runs.json")
SCALE = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}

def seconds(b, key="real_time"):
    return b[key] * SCALE[b["time_unit"]]

def find(d, prefix):
    return [(k, d[k]) for k in d if k.startswith(prefix)]

out = ["## Policies", "",
       "`bench_policies` (bench/bench_policies.cpp; its header describes the method) on",
       "data/bunny.obj (locks) and armadillo x4 (armadillo after one 1-to-4 midpoint",
       "subdivision, 345,928 faces; queues, partitions, whole runs), backend indexed_tri.", "",
       f"- Date: {os.environ['DATE']}",
       f"- Machine: {os.environ['MACHINE']} ({os.environ['LOAD']})",
       f"- Compiler: {os.environ['COMPILER']}",
       f"- Build: `{os.environ['BUILD_CMDS']}`",
       f"- Command: `{os.environ['SCRIPT_CMD']}`, which runs `{os.environ['MICRO_CMD']}` and",
       f"  `{os.environ['RUNS_CMD']}`", ""]

# ---- locks
out += ["### Lock policies", "",
        "Uncontended, 1 thread: ns per claim of one operation's region (CPU time). `region`",
        "claims a precomputed vertex list (the lock's own cost); `walk` claims as the executor",
        "does for triangle meshes (walk both stars, search the held list for repeats);",
        "`+try_acquire` lets the lock word say whether a vertex is already held.", "",
        "| benchmark | ns/claim | vertices/claim |", "|---|---:|---:|"]
for name in ["lock/region/none", "lock/region/vertex_try_lock", "lock/walk/none",
             "lock/walk/vertex_try_lock", "lock/walk/vertex_try_lock+try_acquire"]:
    if name in micro:
        b = micro[name]
        vpc = f"{b['vertices/claim']:.1f}" if "vertices/claim" in b else ""
        out.append(f"| `{name}` | {seconds(b, 'cpu_time') * 1e9:.1f} | {vpc} |")
out += ["", "Contended (vertex_try_lock): T threads claim regions from pools of 32 edges, one",
        "shared pool of neighbouring edges (overlapping) or one pool per thread with no vertex",
        "in common (disjoint). Wall time; ns/claim is per thread (T x wall / claims), success is",
        "the fraction of claims that got their whole region; a failed claim releases what it",
        "took. `shared lines`: 64-byte lines of lock words that two disjoint pools both touch.", "",
        "| regions | threads | ns/claim per thread | success | ns per successful claim | shared lines |",
        "|---|---:|---:|---:|---:|---:|"]
for mode in ["overlapping", "disjoint"]:
    for k, b in sorted(find(micro, f"lock/contended/{mode}/"), key=lambda kb: kb[1].get("threads", 1)):
        t = b.get("threads", 1)
        ns = t * 1e9 / b["items_per_second"]
        s = b.get("success", 1.0)
        sl = f"{b['shared_lines']:.0f}" if "shared_lines" in b else ""
        out.append(f"| {mode} | {t} | {ns:.0f} | {s:.3f} | {ns / s if s > 0 else float('inf'):.0f} | {sl} |")

# ---- queues
out += ["", "### Queue policies", "",
        "The queue traffic of a serial shortest edge collapse (sec) and of a QSlim run (qslim)",
        "of armadillo x4 to 10%, each recorded once and replayed on each policy (CPU time per",
        "replay; sweeps: wall time of the stale sweeps inside it). fifo pops in push order: its",
        "row is the cost of its operations on this traffic, not a decimation order.", ""]
for algo in ["sec", "qslim"]:
    replay = find(micro, f"queue/replay_{algo}/")
    if not replay:
        continue
    b0 = replay[0][1]
    out += [f"{algo}: {b0['pushes']:,.0f} pushes, {b0['pops']:,.0f} pops, {b0['sweeps']:.0f} sweeps.", "",
            "| traffic | policy | ms/replay | ns/event | sweeps, ms | / binary_heap |",
            "|---|---|---:|---:|---:|---:|"]
    base = micro.get(f"queue/replay_{algo}/binary_heap")
    for k, b in replay:
        ms = seconds(b, "cpu_time") * 1e3
        ratio = f"{ms / (seconds(base, 'cpu_time') * 1e3):.2f}" if base else ""
        out.append(f"| {algo} | `{k.split('/')[-1]}` | {ms:.0f} | {1e9 / b['items_per_second']:.0f} | "
                   f"{b.get('sweep_ms', 0):.0f} | {ratio} |")
    out.append("")

out += ["Whole serial runs on armadillo x4 to 10%, one per queue policy (seconds: the",
        "run_report's wall time, and the process's CPU time, of the median repetition by wall",
        "time; popped/stale/purged: queue entries popped, found stale when popped, and swept",
        "out while stale):", "",
        "| algorithm | queue | seconds | CPU s | CPU / dary_heap<4> | popped | stale | purged | faces |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
for algo, label in [("sec_serial", "shortest edge collapse"), ("qslim_serial", "QSlim")]:
    rows = find(runs, f"run/{algo}/")
    base = next((b for k, b in rows if "dary_heap<4>" in k), None)
    for k, b in rows:
        q = k.split("/")[2]
        ratio = f"{b['cpu_s'] / base['cpu_s']:.2f}" if base else ""
        out.append(f"| {label} | `{q}` | {seconds(b):.2f} | {b['cpu_s']:.2f} | {ratio} | {b['popped']:,.0f} | "
                   f"{b['stale']:,.0f} | {b['purged']:,.0f} | {b['faces']:,.0f} |")

# ---- partitions
out += ["", "### Partition policies", "",
        "assign() on armadillo x4 (CPU time). cut: fraction of edges across parts; boundary:",
        "fraction of vertices with a neighbour in another part; cross region: fraction of edges",
        "whose claim region spans two parts (operations that can meet another worker);",
        "imbalance: largest part / mean part. `sparse`: the same mesh decimated to 10% and not",
        "consolidated (90% of the vertex slots dead), as in the phases after a collapse phase.", "",
        "| policy | mesh | parts | ms | cut | boundary | cross region | imbalance |",
        "|---|---|---:|---:|---:|---:|---:|---:|"]
for k, b in find(micro, "partition/"):
    parts = k.rsplit(":", 1)[-1]
    mesh = "sparse" if "assign_sparse" in k else "x4"
    pol = k.split("/")[2]
    bnd = f"{b['boundary']:.4f}" if "boundary" in b else ""
    out.append(f"| {pol} | {mesh} | {parts} | {seconds(b, 'cpu_time') * 1e3:.1f} | {b['cut']:.4f} | "
               f"{bnd} | {b['cross_region']:.4f} | {b['imbalance']:.3f} |")
out += ["", "Whole runs at 2 threads on armadillo x4 (seconds: the run_report's, median of the",
        "repetitions; remeshing: one iteration at 0.01 x diagonal, the four phases summed, with",
        "each phase's seconds):", "",
        "| run | partition | seconds | CPU s | lock_failures | stolen | deferred_to_serial | faces | phases (split / collapse / swap / smooth s) |",
        "|---|---|---:|---:|---:|---:|---:|---:|---|"]
for algo, label in [("sec_2t", "shortest edge collapse to 10%"), ("remesh_2t", "remeshing, 1 iteration")]:
    for k, b in find(runs, f"run/{algo}/"):
        p = k.split("/")[2]
        phases = " / ".join(f"{b[n]:.2f}" for n in ["split_s", "collapse_s", "swap_s", "smooth_s"] if n in b)
        out.append(f"| {label} | {p} | {seconds(b):.2f} | {b['cpu_s']:.2f} | {b['lock_failures']:,.0f} | {b['stolen']:,.0f} | "
                   f"{b['deferred_to_serial']:,.0f} | {b['faces']:,.0f} | {phases} |")
out += ["", "Bytes per face per triangle backend: \"Triangle core\" above; bytes per tet",
        "(indexed_tet, the only tet backend so far): \"Tetrahedral core\".", ""]

text = open(results).read() if os.path.exists(results) else "# idas benchmark results\n"
m = re.search(r"(?ms)^## Policies\n.*?(<!-- analysis -->.*?<!-- /analysis -->)", text)
if m:
    out += [m.group(1), ""]
out += ["<details><summary>Full output</summary>", "", "```text",
        open(os.path.join(work, "micro.txt")).read().rstrip(),
        open(os.path.join(work, "runs.txt")).read().rstrip(), "```", "", "</details>", ""]
section = "\n".join(out)

parts = re.split(r"(?m)^(?=## )", text)
preamble, body = parts[0], parts[1:]
new_body, seen = [], False
for p in body:
    if p.splitlines()[0].strip() == "## Policies":
        new_body.append(section + "\n")
        seen = True
    else:
        new_body.append(p if p.endswith("\n") else p + "\n")
if not seen:
    new_body.append(section + "\n")
open(results, "w").write(preamble.rstrip("\n") + "\n\n" + "\n".join(s.rstrip("\n") + "\n" for s in new_body))
print(f"wrote {results}")
PY
