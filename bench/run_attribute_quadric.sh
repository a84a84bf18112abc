#!/usr/bin/env bash
# QSlim with the attribute quadric (issue 21 item 2). First the tool's decimation time
# (seconds_algorithm) with the file's attributes at the default weight, at weight 0 and with
# --drop-attributes, on the coloured armadillo and textured blub to 10% at 1 and 2 threads;
# runs alternate, REPS of each, the median reported. Then, serially, the attribute errors
# and the distance to the input at weights 0 and the default (bench_attribute_quadric).
#
#   bench/run_attribute_quadric.sh BUILD_DIR [REPS]
#       BUILD_DIR holds examples/idas and bench/bench_attribute_quadric (IDAS_BUILD_BENCH=ON)
set -euo pipefail
cd "$(dirname "$0")/.."
build=$1
reps="${2:-5}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$build/bench/bench_attribute_quadric" --coloured data/armadillo.obj "$tmp/armadillo_colour.ply"
out="$tmp/runs.jsonl"
for input in "$tmp/armadillo_colour.ply" data/blub.obj; do
    for threads in 1 2; do
        for rep in $(seq "$reps"); do
            for mode in default weight0 drop; do
                case $mode in
                default) extra=() ;;
                weight0) extra=(--attribute-weight 0) ;;
                drop) extra=(--drop-attributes) ;;
                esac
                "$build/examples/idas" decimate "$input" "$tmp/out.ply" --ratio 0.1 --json \
                    --threads "$threads" "${extra[@]}" |
                    python3 -c 'import json, sys; d = json.load(sys.stdin); d["mode"] = sys.argv[1]; print(json.dumps(d))' "$mode" >>"$out"
            done
        done
    done
done
python3 - "$out" <<'PY'
import json, os, statistics, sys
rows = [json.loads(line) for line in open(sys.argv[1])]
print("| input | threads | attributes, default weight (s) | weight 0 (s) | --drop-attributes (s) | default / drop | weight 0 / drop |")
print("|---|---|---|---|---|---|---|")
for key in sorted({(r["input"], r["threads"]) for r in rows}):
    t = {m: statistics.median(r["seconds_algorithm"] for r in rows
                              if (r["input"], r["threads"]) == key and r["mode"] == m)
         for m in ("default", "weight0", "drop")}
    print(f"| {os.path.basename(key[0])} | {key[1]} | {t['default']:.3f} | {t['weight0']:.3f} | "
          f"{t['drop']:.3f} | {t['default'] / t['drop']:.2f}x | {t['weight0'] / t['drop']:.2f}x |")
PY
for input in "$tmp/armadillo_colour.ply" data/blub.obj; do
    "$build/bench/bench_attribute_quadric" "$input" --repeat 1 --weights 0,0.1,0.2,0.3,0.5
done
