#!/usr/bin/env bash
# The cost of the no-self-intersection invariant (issue 16 item 5 b): idas QSlim and
# shortest edge collapse with and without it, at 1 and 2 threads, on armadillo (x1) and its
# 1-to-4 subdivision (x4), to 10%; runs alternate, REPS of each, the median reported.
# Every output's intersecting face pairs are counted (exact).
#
#   bench/run_self_intersection.sh [REPS]      (build: cmake --preset bench &&
#                                               cmake --build --preset bench --target bench_decimation)
set -euo pipefail
cd "$(dirname "$0")/.."
reps="${1:-3}"
bin=build/bench/bench/bench_decimation
out=$(mktemp)
for input in x1 x4; do
    for peer in idas-qslim idas-sec; do
        for threads in 1 2; do
            for rep in $(seq "$reps"); do
                for guard in "" --self-intersections; do
                    samples=0
                    [ "$rep" = 1 ] && samples=200000
                    $bin --peer $peer --input $input --ratio 0.1 --threads $threads \
                        --samples $samples $guard >>"$out"
                done
            done
        done
    done
done
python3 - "$out" <<'PY'
import json, statistics, sys
rows = [json.loads(line) for line in open(sys.argv[1])]
print("| input | algorithm | threads | without s | with s | ratio | Hausdorff without / with | pairs meeting without / with |")
print("|---|---|---|---|---|---|---|---|")
keys = sorted({(r["input"], r["peer"], r["threads"]) for r in rows}, key=lambda k: (k[0], k[1], k[2]))
for k in keys:
    off = [r for r in rows if (r["input"], r["peer"], r["threads"]) == k and not r["refuse_self_intersections"]]
    on = [r for r in rows if (r["input"], r["peer"], r["threads"]) == k and r["refuse_self_intersections"]]
    t_off = statistics.median(r["seconds_algorithm"] for r in off)
    t_on = statistics.median(r["seconds_algorithm"] for r in on)
    h_off = max(r["hausdorff_symmetric"] for r in off)
    h_on = max(r["hausdorff_symmetric"] for r in on)
    print(f"| {k[0]} | {k[1]} | {k[2]} | {t_off:.3f} | {t_on:.3f} | {t_on / t_off:.2f}x | "
          f"{h_off:.5f} / {h_on:.5f} | {max(r['self_intersections'] for r in off)} / "
          f"{max(r['self_intersections'] for r in on)} |")
PY
rm -f "$out"
