#!/usr/bin/env bash
# Deterministic decimation quality (issue 19: "quality within 2% of the serial executor's
# figures"): for each input, algorithm and ratio, the serial executor (one thread), the
# deterministic policy and the try-lock executor (both at --threads T), each a separate
# bench_decimation process, with the self-intersection invariant on (the tool's default).
#
#   bench/run_deterministic_quality.sh [--bin PATH] [--threads T] [--samples N]
#       [--cases "bunny.obj:x1 armadillo.obj:x1 blub.obj:x4 100071_sf.obj:x4 bunny.obj:x4
#                 armadillo.obj:x4"] [--ratios "0.1 0.05 0.01"] [--shuffles "0"]
#       [--jsonl FILE] [--table-only]
#
# A case FILE:LEVEL is data/FILE (--data) at subdivision LEVEL (x1: as it is; x4: one 1-to-4
# midpoint subdivision, the same surface with four times the faces). Meshes of at most
# 16,384 faces are decimated serially by every policy (`face_target::serial_up_to_faces`),
# so the cases start above it. Each run is deterministic, so repeating one measures the same
# mesh again; --shuffles "0 1 2" renumbers the input (bench_decimation --shuffle: vertices
# and faces permuted, corners rotated), which moves the deterministic mesh in about half the
# cases and the serial one hardly at all (bench/RESULTS.md, "Deterministic decimation
# quality over 36 cases"): more cases or numberings give more samples.
#
# Per case: the symmetric Hausdorff distance and the mean distance (both ways' means
# summed) of each parallel run over the serial run's (bench_decimation: CGAL's
# approximate_Hausdorff_distance, N samples (default 200,000) per base surface area plus
# every vertex, fixed seed). Then the geometric mean and the extremes of each ratio over all
# cases. A decimation's Hausdorff distance is one point's, so any change of order moves one
# case by tens of percent either way; the geometric mean over many cases is the figure that
# says whether a policy is worse than the serial order.
#
# Build first: cmake --preset bench && cmake --build --preset bench --target bench_decimation
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
bin="$root/build/bench/bench/bench_decimation"
threads=2
samples=200000
cases="bunny.obj:x1 armadillo.obj:x1 blub.obj:x4 100071_sf.obj:x4 bunny.obj:x4 armadillo.obj:x4"
ratios="0.1 0.05 0.01"
shuffles="0"
jsonl="$root/build/bench/deterministic_quality.jsonl"
table_only=0

while [[ $# -gt 0 ]]; do
    case "$1" in
    --bin) bin="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --samples) samples="$2"; shift 2 ;;
    --cases) cases="$2"; shift 2 ;;
    --ratios) ratios="$2"; shift 2 ;;
    --shuffles) shuffles="$2"; shift 2 ;;
    --jsonl) jsonl="$2"; shift 2 ;;
    --table-only) table_only=1; shift ;;
    *) echo "run_deterministic_quality.sh: unknown option $1" >&2; exit 2 ;;
    esac
done

if [[ $table_only == 0 ]]; then
    if [[ ! -x "$bin" ]]; then
        echo "run_deterministic_quality.sh: $bin not found; build it with" >&2
        echo "  cmake --preset bench && cmake --build --preset bench --target bench_decimation" >&2
        exit 2
    fi
    mkdir -p "$(dirname "$jsonl")"
    : >"$jsonl"
    start=$(date +%s)
    for c in $cases; do
        file=${c%%:*} level=${c##*:}
        for algorithm in qslim sec; do
            for ratio in $ratios; do
                for shuffle in $shuffles; do
                    echo "$file $level $algorithm $ratio $shuffle" >&2
                    for run in "serial idas-$algorithm 1" \
                        "deterministic idas-$algorithm-det $threads" \
                        "try_lock idas-$algorithm $threads"; do
                        read -r mode peer run_threads <<<"$run"
                        line=$("$bin" --peer "$peer" --input "$level" --data "$root/data/$file" \
                            --ratio "$ratio" --threads "$run_threads" --samples "$samples" \
                            --shuffle "$shuffle" --self-intersections)
                        echo "{\"case\":\"$file $level\",\"mode\":\"$mode\",\"run\":$line}" >>"$jsonl"
                    done
                done
            done
        done
    done
    echo "all runs: $(($(date +%s) - start)) s" >&2
fi

python3 - "$jsonl" <<'EOF'
import json, math, sys
from collections import defaultdict

runs = [json.loads(line) for line in open(sys.argv[1]) if line.strip()]
cases = defaultdict(dict)
for r in runs:
    x = r["run"]
    cases[(r["case"], x["algorithm"], x["ratio"], x["shuffle"])][r["mode"]] = x

modes = ("deterministic", "try_lock")
ratios = {m: {"hausdorff": [], "mean": []} for m in modes}


def mean_distance(x):
    return x["mean_distance_out_in"] + x["mean_distance_in_out"]


print("| input | algorithm | ratio | numbering | input faces | faces (serial / det / try) "
      "| Hausdorff serial | det / serial | try / serial | mean dist. det / serial "
      "| try / serial | seconds serial / det / try |")
print("|---|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---|")
for (case, algorithm, ratio, shuffle), m in cases.items():
    if any(k not in m for k in ("serial",) + modes):
        continue
    s = m["serial"]
    row = []
    for mode in modes:
        h = m[mode]["hausdorff_symmetric"] / s["hausdorff_symmetric"]
        d = mean_distance(m[mode]) / mean_distance(s)
        ratios[mode]["hausdorff"].append(h)
        ratios[mode]["mean"].append(d)
        row.append((h, d))
    faces = " / ".join(f"{m[k]['output_faces']:,}" for k in ("serial",) + modes)
    secs = " / ".join(f"{m[k]['seconds_algorithm']:.3f}" for k in ("serial",) + modes)
    print(f"| {case} | {algorithm} | {ratio} | {shuffle} | {s['input_faces']:,} | {faces} "
          f"| {s['hausdorff_symmetric']:.3g} | {row[0][0]:.3f} | {row[1][0]:.3f} "
          f"| {row[0][1]:.3f} | {row[1][1]:.3f} | {secs} |")


def summary(xs):
    logs = [math.log(x) for x in xs]
    mu = sum(logs) / len(logs)
    sd = math.sqrt(sum((v - mu) ** 2 for v in logs) / (len(logs) - 1)) if len(logs) > 1 else 0
    half = 1.96 * sd / math.sqrt(len(logs))
    return (f"{math.exp(mu):.4f} (95% interval {math.exp(mu - half):.3f}-{math.exp(mu + half):.3f}),"
            f" {min(xs):.3f}-{max(xs):.3f}")


print()
print("| policy | cases | Hausdorff / serial: geometric mean, range | "
      "mean distance / serial: geometric mean, range |")
print("|---|---:|---|---|")
for mode in modes:
    if ratios[mode]["hausdorff"]:
        print(f"| {mode} | {len(ratios[mode]['hausdorff'])} | {summary(ratios[mode]['hausdorff'])} "
              f"| {summary(ratios[mode]['mean'])} |")
EOF
