#!/usr/bin/env bash
# Parallel decimation quality (issue 16, item 4): the symmetric Hausdorff distance of a
# parallel decimation against the serial one's, and its face count against the target.
#
#   bench/run_parallel_quality.sh [--bin PATH] [--samples N] [--repeats R] [--jsonl FILE]
#                                 [--inputs "bunny x4 box"] [--peers "idas-qslim idas-sec"]
#                                 [--ratios "0.1 0.01"] [--threads "2 8"] [--table-only]
#
# For every input, peer and ratio: one serial run (serial decimation is deterministic) and
# R runs (default 3) at each parallel thread count, each a separate bench_decimation process
# (bench/bench_decimation.cpp). Different parallel runs race differently, so each row gives
# the median and the worst of its runs. Prints a markdown table to stdout; the raw JSON lines
# go to --jsonl (default build/bench/parallel_quality.jsonl); --table-only prints the table
# of an earlier run's --jsonl without running anything.
#
# Hausdorff: CGAL's approximate_Hausdorff_distance, N (default 300,000) random face samples
# over the input's surface plus every vertex, fixed seed, relative to the bounding-box
# diagonal, the larger of both directions (bench_decimation's hausdorff_symmetric).
#
# Build first: cmake --preset bench && cmake --build --preset bench --target bench_decimation
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
bin="$root/build/bench/bench/bench_decimation"
samples=300000
repeats=3
jsonl="$root/build/bench/parallel_quality.jsonl"
inputs="bunny x4 box"
peers="idas-qslim idas-sec"
ratios="0.1 0.01"
threads="2 8"
table_only=0

while [[ $# -gt 0 ]]; do
    case "$1" in
    --bin) bin="$2"; shift 2 ;;
    --samples) samples="$2"; shift 2 ;;
    --repeats) repeats="$2"; shift 2 ;;
    --jsonl) jsonl="$2"; shift 2 ;;
    --inputs) inputs="$2"; shift 2 ;;
    --peers) peers="$2"; shift 2 ;;
    --ratios) ratios="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --table-only) table_only=1; shift ;;
    *) echo "run_parallel_quality.sh: unknown option $1" >&2; exit 2 ;;
    esac
done

if [[ $table_only == 0 && ! -x "$bin" ]]; then
    echo "run_parallel_quality.sh: $bin not found; build it with" >&2
    echo "  cmake --preset bench && cmake --build --preset bench --target bench_decimation" >&2
    exit 2
fi

if [[ $table_only == 0 ]]; then
    mkdir -p "$(dirname "$jsonl")"
    : >"$jsonl"
    start=$(date +%s)
    for input in $inputs; do
        for peer in $peers; do
            for ratio in $ratios; do
                echo "$input $peer $ratio" >&2
                "$bin" --peer "$peer" --input "$input" --ratio "$ratio" --threads 1 \
                    --samples "$samples" >>"$jsonl"
                for t in $threads; do
                    for ((r = 0; r < repeats; ++r)); do
                        "$bin" --peer "$peer" --input "$input" --ratio "$ratio" --threads "$t" \
                            --samples "$samples" >>"$jsonl"
                    done
                done
            done
        done
    done
    echo "all runs: $(($(date +%s) - start)) s" >&2
fi

python3 - "$jsonl" "$inputs" "$peers" "$ratios" "$threads" <<'EOF'
import json, statistics, sys

path, inputs, peers, ratios, threads = sys.argv[1:]
runs = [json.loads(line) for line in open(path) if line.strip()]
exact = 1e-6  # below this the distance is rounding noise (both runs exact)


def group(inp, peer, ratio, t):
    return [r for r in runs if r["input"] == inp and r["peer"] == peer
            and abs(r["ratio"] - float(ratio)) < 1e-12 and r["threads"] == t]


def face_ok(r):
    # Within 0.1% of the target, or one face: a closed mesh loses two faces per collapse,
    # so its face count stays even and an odd target is missed by one.
    return abs(r["output_faces"] - r["target_faces"]) <= max(0.001 * r["target_faces"], 1)


def ratio_of(h, h1):
    if h1 < exact:
        return "exact" if h < exact else "inf"
    return f"{h / h1:.2f}"


def verdict(hs, h1):
    if h1 < exact:
        return "met (exact)" if max(hs) < exact else "**not met**"
    worst, med = max(hs) / h1, statistics.median(hs) / h1
    if worst <= 1.1:
        return "met"
    return "median only" if med <= 1.1 else "**not met**"


print("| input | algorithm | ratio | threads | runs | target | faces | face error (worst) "
      "| within 0.1% or 1 face | seconds (median) | tail s (median) | Hausdorff median | worst "
      "| median / serial | worst / serial | 1.1x |")
print("|---|---|---:|---:|---:|---:|---|---:|---|---:|---:|---:|---:|---:|---:|---|")
for inp in inputs.split():
    for peer in peers.split():
        for ratio in ratios.split():
            serial = group(inp, peer, ratio, 1)
            if not serial:
                continue
            h1 = serial[0]["hausdorff_symmetric"]
            for t in [1] + [int(x) for x in threads.split()]:
                g = group(inp, peer, ratio, t)
                if not g:
                    continue
                hs = [r["hausdorff_symmetric"] for r in g]
                errs = [r["face_error"] for r in g]
                worst_err = max(errs, key=abs)
                faces = "/".join(f"{r['output_faces']:,}" for r in g)
                ok = "yes" if all(face_ok(r) for r in g) else "**no**"
                secs = statistics.median(r["seconds_algorithm"] for r in g)
                tail = statistics.median(r.get("tail_seconds", 0) for r in g)
                med, worst = statistics.median(hs), max(hs)
                print(f"| {inp} | {peer} | {ratio} | {t} | {len(g)} | {g[0]['target_faces']:,} "
                      f"| {faces} | {100 * worst_err:+.3f}% | {ok} | {secs:.3f} | {tail:.3f} "
                      f"| {med:.3g} | {worst:.3g} | {ratio_of(med, h1)} | {ratio_of(worst, h1)} "
                      f"| {'(serial)' if t == 1 else verdict(hs, h1)} |")
EOF
