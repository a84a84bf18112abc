#!/usr/bin/env bash
# Side-by-side isotropic remeshing benchmark (issue 5): idas against CGAL's
# Polygon_mesh_processing::isotropic_remeshing.
#
#   bench/run_remeshing.sh [--repeats N] [--samples S] [--length L] [--iterations K]
#                          [--envelope EPS] [--build-dir DIR] [--before-bin FILE]
#                          [--before-note TEXT]
#
# Builds bench_remeshing (CMake preset "bench", or the given build directory), then runs
# every case as its own process:
#
#   inputs  bunny, armadillo, armadillo x4 (345,928 faces: 1-to-4 subdivision at run time)
#   peers   cgal; idas on 1 and 2 threads, without and with the envelope (EPS of the
#           diagonal, default 1e-3)
#   target  edge length L of the bounding-box diagonal (default 0.005), K iterations (5)
#
# Within each input the peers run back to back, N rounds (default 1), so their ratios come
# from the same stretch of machine time; the tables use each case's fastest run. One JSON
# object per run goes to bench/remeshing_results.jsonl; bench/plot_remeshing.py then draws
# bench/remeshing.png and rewrites the "## Remeshing" section of bench/RESULTS.md (other
# sections are kept).
#
# --before-bin FILE: a bench_remeshing built from an older revision; its idas serial runs
# (no envelope) go, interleaved with the others, to bench/remeshing_before.jsonl and into
# a before/after table; --before-note TEXT says what that revision is (printed above it).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
repeats=1
samples=500000
length=0.005
iterations=5
envelope=1e-3
build_dir=""
before_bin=""
before_note=""
while [[ $# -gt 0 ]]; do
    case "$1" in
    --repeats) repeats="$2"; shift 2 ;;
    --samples) samples="$2"; shift 2 ;;
    --length) length="$2"; shift 2 ;;
    --iterations) iterations="$2"; shift 2 ;;
    --envelope) envelope="$2"; shift 2 ;;
    --build-dir) build_dir="$2"; shift 2 ;;
    --before-bin) before_bin="$2"; shift 2 ;;
    --before-note) before_note="$2"; shift 2 ;;
    *)
        echo "usage: bench/run_remeshing.sh [--repeats N] [--samples S] [--length L]" \
            "[--iterations K] [--envelope EPS] [--build-dir DIR] [--before-bin FILE] [--before-note TEXT]" >&2
        exit 2
        ;;
    esac
done
command_line="bench/run_remeshing.sh --repeats $repeats --samples $samples --length $length --iterations $iterations --envelope $envelope${before_bin:+ --before-bin $before_bin}"

results="$root/bench/remeshing_results.jsonl"
before_results="$root/bench/remeshing_before.jsonl"
if [[ -z "$build_dir" ]]; then
    build="cmake --preset bench && cmake --build --preset bench --target bench_remeshing"
    cmake --preset bench >/dev/null
    cmake --build --preset bench --target bench_remeshing
    build_dir="$root/build/bench"
else
    build="cmake --build $build_dir --target bench_remeshing"
    cmake --build "$build_dir" --target bench_remeshing
fi
bin="$build_dir/bench/bench_remeshing"
log="$build_dir/remeshing.log"
: >"$results"
[[ -n "$before_bin" ]] && : >"$before_results"
: >"$log"

load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
started=$SECONDS
date_utc="$(date -u '+%Y-%m-%d %H:%M UTC')"

run_case() { # input rep peer [extra args...]
    local input="$1" rep="$2" peer="$3" bin="$bin" results="$results"
    shift 3
    if [[ "$peer" == before ]]; then
        peer=idas bin="$before_bin" results="$before_results"
    fi
    local args=(--peer "$peer" --input "$input" --samples "$samples" --length "$length"
        --iterations "$iterations" "$@")
    local line status=0
    echo "+ bench_remeshing ${args[*]}" | tee -a "$log" >&2
    line="$("$bin" "${args[@]}" 2>>"$log")" || status=$?
    if [[ $status -eq 0 ]]; then
        echo "${line%\}},\"rep\":$rep,\"load\":\"$(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$results"
    else
        echo "  failed with exit status $status (see $log)" >&2
        printf '{"peer":"%s","input":"%s","rep":%s,"args":"%s","error":"exit status %s"}\n' \
            "$peer" "$input" "$rep" "$*" "$status" >>"$results"
    fi
}

for input in bunny armadillo armadillo-x4; do
    for ((rep = 1; rep <= repeats; ++rep)); do
        run_case "$input" "$rep" cgal
        run_case "$input" "$rep" idas --threads 1
        [[ -n "$before_bin" ]] && run_case "$input" "$rep" before --threads 1
        run_case "$input" "$rep" idas --threads 2
        run_case "$input" "$rep" idas --threads 1 --envelope "$envelope"
        run_case "$input" "$rep" idas --threads 2 --envelope "$envelope"
    done
done

export DATE="$date_utc"
export MACHINE="$(nproc) logical CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(free -g | awk '/^Mem:/{print $2}') GiB RAM"
export COMPILER="$(${CXX:-c++} --version | head -n1)"
export LOAD="load average $load_before before, $(cut -d' ' -f1-3 /proc/loadavg) after"
export COMMAND="$command_line"
export BUILD="$build"
export WALL="$((SECONDS - started))"
export PEERS="CGAL $(awk '$2 == "CGAL_VERSION" {print $3}' /usr/include/CGAL/version.h)"
# Debian's python3-matplotlib belongs to the system interpreter (see run_decimation.sh).
python=/usr/bin/python3
[[ -x "$python" ]] || python=python3
"$python" "$root/bench/plot_remeshing.py" --results "$results" --png "$root/bench/remeshing.png" \
    --markdown "$root/bench/RESULTS.md" ${before_bin:+--before "$before_results"} \
    ${before_note:+--before-note "$before_note"}
