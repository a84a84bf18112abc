#!/usr/bin/env bash
# Side-by-side decimation benchmark (issue 4): idas against CGAL and OpenMesh.
#
#   bench/run_decimation.sh [--repeats-x4 N] [--repeats-x16 M] [--samples S]
#
# Builds bench_decimation with the CMake preset "bench", then runs every case as its own
# process (so that its peak memory is its own):
#
#   inputs   armadillo x4 (345,928 faces) and x16 (1,383,712), made by 1-to-4 midpoint
#            subdivision at run time
#   targets  10% and 1% of the input faces
#   peers    shortest edge collapse: idas-sec (1 and 2 threads), cgal-sec
#            quadrics:               idas-qslim (1 and 2 threads), cgal-gh, openmesh-quadric
#
# Within each (input, target) group the peers run back to back, so their ratios come from
# the same stretch of machine time. Every x4 case runs N times (default 2) and every x16
# case M times (default 1, to keep the whole script near 15 minutes on a quiet 2-core
# machine), all peers alike, one round of all peers after another; the tables use each
# case's fastest run and show the slowest next to it. One JSON object per run goes to
# bench/decimation_results.jsonl; bench/plot_decimation.py then draws bench/decimation.png
# and rewrites the "## Decimation" section of bench/RESULTS.md (other sections are kept).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
declare -A repeats=([x4]=2 [x16]=1)
samples=500000
while [[ $# -gt 0 ]]; do
    case "$1" in
    --repeats-x4) repeats[x4]="$2"; shift 2 ;;
    --repeats-x16) repeats[x16]="$2"; shift 2 ;;
    --samples) samples="$2"; shift 2 ;;
    *)
        echo "usage: bench/run_decimation.sh [--repeats-x4 N] [--repeats-x16 M] [--samples S]" >&2
        exit 2
        ;;
    esac
done
command_line="bench/run_decimation.sh --repeats-x4 ${repeats[x4]} --repeats-x16 ${repeats[x16]} --samples $samples"

results="$root/bench/decimation_results.jsonl"
log="$root/build/bench/decimation.log"
bin="$root/build/bench/bench/bench_decimation"

cmake --preset bench >/dev/null
cmake --build --preset bench --target bench_decimation
mkdir -p "$(dirname "$log")"
: >"$results"
: >"$log"

load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
started=$SECONDS
date_utc="$(date -u '+%Y-%m-%d %H:%M UTC')"

run_case() { # peer input ratio threads rep
    local args=(--peer "$1" --input "$2" --ratio "$3" --threads "$4" --samples "$samples")
    local line status=0
    echo "+ bench_decimation ${args[*]}" | tee -a "$log" >&2
    line="$("$bin" "${args[@]}" 2>>"$log")" || status=$?
    if [[ $status -eq 0 ]]; then
        echo "${line%\}},\"rep\":$5}" | tee -a "$results"
    else
        echo "  failed with exit status $status (see $log)" >&2
        printf '{"peer":"%s","input":"%s","ratio":%s,"threads":%s,"rep":%s,"error":"exit status %s"}\n' \
            "$1" "$2" "$3" "$4" "$5" "$status" >>"$results"
    fi
}

for input in x4 x16; do
    for ratio in 0.1 0.01; do
        for ((rep = 1; rep <= repeats[$input]; ++rep)); do
            run_case idas-sec "$input" "$ratio" 1 "$rep"
            run_case idas-sec "$input" "$ratio" 2 "$rep"
            run_case cgal-sec "$input" "$ratio" 1 "$rep"
            run_case idas-qslim "$input" "$ratio" 1 "$rep"
            run_case idas-qslim "$input" "$ratio" 2 "$rep"
            run_case cgal-gh "$input" "$ratio" 1 "$rep"
            run_case openmesh-quadric "$input" "$ratio" 1 "$rep"
        done
    done
done

export DATE="$date_utc"
export MACHINE="$(nproc) logical CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(free -g | awk '/^Mem:/{print $2}') GiB RAM"
export COMPILER="$(${CXX:-c++} --version | head -n1)"
export LOAD="load average $load_before before, $(cut -d' ' -f1-3 /proc/loadavg) after"
export COMMAND="$command_line"
export BUILD="cmake --preset bench && cmake --build --preset bench --target bench_decimation"
export WALL="$((SECONDS - started))"
export PEERS="CGAL $(awk '$2 == "CGAL_VERSION" {print $3}' /usr/include/CGAL/version.h), OpenMesh $(dpkg-query -W -f='${Version}' libopenmesh-dev 2>/dev/null || echo '?')"
# Debian's python3-matplotlib belongs to the system interpreter, which a pyenv or venv
# python3 earlier on PATH would not see.
python=/usr/bin/python3
[[ -x "$python" ]] || python=python3
"$python" "$root/bench/plot_decimation.py" --results "$results" --png "$root/bench/decimation.png" \
    --markdown "$root/bench/RESULTS.md"
