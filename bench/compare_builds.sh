#!/usr/bin/env bash
# Two builds of the `idas` tool side by side, one process per case, interleaved (OLD then
# NEW, case by case), so that both see the same machine: the self-intersection
# invariant's cost, deterministic rounds against try-locks, remeshing and the harmonic
# triangulation. Prints a line per run and a table of medians.
#
#   bench/compare_builds.sh OLD_IDAS NEW_IDAS [ROUNDS]
#
# OLD_IDAS / NEW_IDAS: `idas` binaries (build each with `cmake --preset release && cmake
# --build --preset release --target idas_cli`, e.g. in a `git worktree` of the older
# commit). Inputs: armadillo subdivided 1-to-4 once and twice (x4: 345,928 faces; x16:
# 1,383,712), written to build/bench/compare/ by bench_inputs the first time.
set -euo pipefail
[[ $# -ge 2 ]] || { sed -n 2,12p "$0"; exit 2; }
old="$(realpath "$1")" new="$(realpath "$2")" rounds="${3:-2}"
cd "$(dirname "$0")/.."
root="$PWD"
work="$root/build/bench/compare"
mkdir -p "$work"
inputs="$root/build/bench/bench/bench_inputs"
if [[ ! -s "$work/x4.obj" || ! -s "$work/x16.obj" ]]; then
    [[ -x "$inputs" ]] || { cmake --preset bench >/dev/null &&
        cmake --build --preset bench --target bench_inputs; }
    "$inputs" data/armadillo.obj "$work/x4.obj" --levels 1 >&2
    "$inputs" data/armadillo.obj "$work/x16.obj" --levels 2 >&2
fi
results="$work/results.txt"
: >"$results"

# run LABEL BINARY ARGS...: one line "LABEL|build|seconds|rounds" into the results.
run() {
    local label="$1" bin="$2" build=old
    shift 2
    [[ "$bin" == "$new" ]] && build=new
    "$bin" "$@" --json 2>/dev/null | python3 -c "
import json, sys
t = sys.stdin.read(); j = json.loads(t[t.find('{'):t.rfind('}') + 1])
s = j.get('seconds_algorithm', j.get('seconds_flipping'))
print('$label|$build|%.3f|%s' % (s, j.get('rounds', '')))" | tee -a "$results"
}

cd "$work"
for ((r = 0; r < rounds; ++r)); do
    for t in 1 2; do
        for a in "--ratio 0.1" "--algorithm shortest-edge --ratio 0.01"; do
            for bin in "$old" "$new"; do
                # shellcheck disable=SC2086
                run "x4 $a, $t thread(s), invariant" "$bin" decimate x4.obj out.ply $a --threads "$t"
                # shellcheck disable=SC2086
                run "x4 $a, $t thread(s), no invariant" "$bin" decimate x4.obj out.ply $a \
                    --allow-self-intersections --threads "$t"
                # shellcheck disable=SC2086
                run "x4 $a, $t thread(s), deterministic" "$bin" decimate x4.obj "det_$t.ply" $a \
                    --deterministic --threads "$t"
            done
        done
        for bin in "$old" "$new"; do
            run "x4 remesh, $t thread(s)" "$bin" remesh x4.obj out.ply --edge-length 0.004 \
                --iterations 3 --threads "$t"
            run "x4 remesh, $t thread(s), deterministic" "$bin" remesh x4.obj out.ply \
                --edge-length 0.004 --iterations 3 --deterministic --threads "$t"
            run "harmonic 200k, $t thread(s)" "$bin" harmonic out.msh --gaussian 200000 \
                --threads "$t"
            run "harmonic 200k, $t thread(s), deterministic" "$bin" harmonic out.msh \
                --gaussian 200000 --deterministic --threads "$t"
        done
    done
done
for bin in "$old" "$new"; do
    run "x16 --ratio 0.1, 2 thread(s)" "$bin" decimate x16.obj out.ply --ratio 0.1 --threads 2
    run "x16 --ratio 0.1, 2 thread(s), deterministic" "$bin" decimate x16.obj out.ply \
        --ratio 0.1 --deterministic --threads 2
done
python3 - "$results" <<'PY'
import statistics, sys
rows = [line.rstrip("\n").split("|") for line in open(sys.argv[1]) if line.count("|") == 3]
cases = list(dict.fromkeys(r[0] for r in rows))
print("| case | old s | new s | new / old |")
print("|---|---:|---:|---:|")
for c in cases:
    med = {b: statistics.median(float(r[2]) for r in rows if r[0] == c and r[1] == b)
           for b in ("old", "new")}
    print(f"| {c} | {med['old']:.3f} | {med['new']:.3f} | {med['new'] / med['old']:.2f} |")
PY
