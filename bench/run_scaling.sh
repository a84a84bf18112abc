#!/usr/bin/env bash
# Scaling end to end (issue 20): what a user waits for at 1, 2, 4, ... threads.
#
#   bench/run_scaling.sh [--threads "1 2 4 8 16"] [--points N] [--levels L]
#                        [--bin DIR] [--repeats R] [--out FILE] [--no-plot]
#
# Runs the `idas` tool itself, one process per case, each with --json, so every figure is
# a whole command (reading, checking and writing included) with its per-phase wall times:
#
#   decimate-qslim    armadillo x16 (L = 2 levels of 1-to-4 subdivision, 1,383,712 faces)
#                     to 10% by QSlim
#   decimate-sec      the same to 1% by shortest edge collapse
#   remesh            the same, target edge length 0.002 of the diagonal, 5 iterations
#   harmonic-reduced  N Gaussian points (default 1,000,000), Delaunay + 3-2 flips
#   harmonic-complete the same, complete mode
#   cgal-delaunay     CGAL's Delaunay_triangulation_3 of the same points alone (serial on
#                     one thread, its Parallel_tag insertion on more): the peer of the
#                     harmonic targets (bench_harmonic --cgal-only)
#
# Thread counts default to 1, 2, 4, ... up to the machine's cores. The subdivided input is
# written once by bench_inputs. Binaries: --bin DIR holding `idas`, `bench_inputs` and
# `bench_harmonic` (copied there from a release build, e.g. for a machine without a
# compiler); otherwise the release preset builds idas and the bench preset the two others.
# One JSON line per run goes to build/bench/scaling_results.jsonl (or --out), and
# bench/plot_scaling.py writes the "## Scaling" section of bench/RESULTS.md (speedups of
# algorithm and whole command, per-phase times, and the 16-thread figures Amdahl's law
# predicts from the two smallest thread counts, per phase) and bench/scaling.png.
# --no-plot (a machine without matplotlib) writes the plot's settings beside the results
# instead, as FILE.env: `set -a; . FILE.env; bench/plot_scaling.py --results FILE ...` there.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
cores="$(nproc)"
threads=""
points=1000000
levels=2
bin=""
repeats=1
out=""
plot=1
while [[ $# -gt 0 ]]; do
    case "$1" in
    --threads) threads="$2"; shift 2 ;;
    --points) points="$2"; shift 2 ;;
    --levels) levels="$2"; shift 2 ;;
    --bin) bin="$2"; shift 2 ;;
    --repeats) repeats="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --no-plot) plot=0; shift ;;
    *)
        echo "usage: bench/run_scaling.sh [--threads \"1 2 4\"] [--points N] [--levels L] [--bin DIR] [--repeats R] [--out FILE] [--no-plot]" >&2
        exit 2
        ;;
    esac
done
if [[ -z "$threads" ]]; then
    threads=1
    for t in 2 4 8 16 32 64; do ((t <= cores)) && threads="$threads $t"; done
fi
command_line="bench/run_scaling.sh --threads \"$threads\" --points $points --levels $levels --repeats $repeats"

if [[ -z "$bin" ]]; then
    cmake --preset release >/dev/null
    cmake --build --preset release --target idas_cli
    cmake --preset bench >/dev/null
    cmake --build --preset bench --target bench_inputs bench_harmonic
    idas="$root/build/release/examples/idas"
    inputs="$root/build/bench/bench/bench_inputs"
    harmonic="$root/build/bench/bench/bench_harmonic"
else
    idas="$bin/idas" inputs="$bin/bench_inputs" harmonic="$bin/bench_harmonic"
fi
work="$root/build/bench/scaling"
mkdir -p "$work"
results="${out:-$root/build/bench/scaling_results.jsonl}"
: >"$results"

input="$work/armadillo_l$levels.obj"
[[ -s "$input" ]] || "$inputs" "$root/data/armadillo.obj" "$input" --levels "$levels" >&2

load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
date_utc="$(date -u '+%Y-%m-%d %H:%M UTC')"
started=$SECONDS

run_case() { # case threads command...
    local name="$1" t="$2"
    shift 2
    echo "+ $name, $t thread(s): $*" >&2
    local line
    line="$("$@" 2>>"$work/stderr.log" | tr -d '\n')"
    echo "${line%\}},\"case\":\"$name\",\"threads_asked\":$t,\"load\":\"$(cut -d' ' -f1 /proc/loadavg)\"}" |
        tee -a "$results" >/dev/null
}

for ((r = 0; r < repeats; ++r)); do
    for t in $threads; do
        run_case decimate-qslim "$t" "$idas" decimate "$input" "$work/qslim.ply" --algorithm qslim \
            --ratio 0.1 --threads "$t" --json
        run_case decimate-sec "$t" "$idas" decimate "$input" "$work/sec.ply" \
            --algorithm shortest-edge --ratio 0.01 --threads "$t" --json
        run_case remesh "$t" "$idas" remesh "$input" "$work/remesh.ply" --edge-length 0.002 \
            --iterations 5 --threads "$t" --json
        run_case harmonic-reduced "$t" "$idas" harmonic "$work/reduced.msh" --gaussian "$points" \
            --mode reduced --threads "$t" --json
        run_case harmonic-complete "$t" "$idas" harmonic "$work/complete.msh" --gaussian "$points" \
            --mode complete --threads "$t" --json
        run_case cgal-delaunay "$t" "$harmonic" --cgal-only --points "$points" --threads "$t"
    done
done

settings=(
    "SCALING_DATE=$date_utc" "SCALING_COMMAND=$command_line" "SCALING_LOAD=$load_before"
    "SCALING_MINUTES=$(((SECONDS - started + 59) / 60))" "SCALING_CORES=$cores"
    "SCALING_CPU=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')"
    "SCALING_INPUT=$(basename "$input"): $(grep -c '^f ' "$input") faces; $points Gaussian points"
)
if ((!plot)); then
    printf '%q\n' "${settings[@]}" >"${results%.jsonl}.env"
    echo "results: $results; settings for bench/plot_scaling.py: ${results%.jsonl}.env" >&2
    exit 0
fi
python=/usr/bin/python3 # Debian's matplotlib belongs to the system interpreter
[[ -x "$python" ]] || python=python3
env "${settings[@]}" "$python" "$root/bench/plot_scaling.py" --results "$results" \
    --png "$root/bench/scaling.png" --markdown "$root/bench/RESULTS.md"
