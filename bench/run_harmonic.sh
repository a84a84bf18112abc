#!/usr/bin/env bash
# Harmonic triangulations of Gaussian points (issue 7, the IDAS paper's Fig. 7).
#
#   bench/run_harmonic.sh [--points N] [--seed S] [--repeats R] [--bin PATH] [--out FILE]
#
# Builds bench_harmonic with the CMake preset "bench" (unless --bin is given), then runs
# each case as its own process, back to back, R times (default 1):
#
#   cgal      CGAL Delaunay_triangulation_3 of the N points alone (the reference time)
#   idas      Delaunay + flips, reduced (3-2 only) and complete (2-3, 3-2, 4-4, smoothing)
#             modes, on 1 and 2 threads; on 2 threads with the default lock policy
#             (own_part_first) and with vertex_try_lock ("-try" cases)
#
# One JSON line per run goes to build/bench/harmonic_results.jsonl (or --out); a Markdown table of
# the fastest run of each case, with the ratios the issue's targets are about (complete
# serial flipping / CGAL Delaunay, 1-thread / 2-thread flipping), is printed at the end,
# ready for the "## Harmonic triangulations" section of bench/RESULTS.md.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
points=1000000
seed=1
repeats=1
bin=""
out=""
while [[ $# -gt 0 ]]; do
    case "$1" in
    --points) points="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    --repeats) repeats="$2"; shift 2 ;;
    --bin) bin="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    *)
        echo "usage: bench/run_harmonic.sh [--points N] [--seed S] [--repeats R] [--bin PATH] [--out FILE]" >&2
        exit 2
        ;;
    esac
done
if [[ -z "$bin" ]]; then
    cmake --preset bench >/dev/null
    cmake --build --preset bench --target bench_harmonic
    bin="$root/build/bench/bench/bench_harmonic"
fi
results="${out:-$root/build/bench/harmonic_results.jsonl}"
mkdir -p "$(dirname "$results")"
: >"$results"

load_before="$(cut -d' ' -f1-3 /proc/loadavg)"
date_utc="$(date -u '+%Y-%m-%d %H:%M UTC')"

run_case() { # label args...
    local label="$1"
    shift
    echo "+ bench_harmonic $*" >&2
    local line
    line="$("$bin" --points "$points" --seed "$seed" "$@")"
    echo "${line%\}},\"case\":\"$label\",\"load\":\"$(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$results"
}

for ((rep = 1; rep <= repeats; ++rep)); do
    run_case cgal --delaunay-only
    run_case reduced-1 --mode reduced --threads 1
    run_case reduced-2 --mode reduced --threads 2
    run_case reduced-2-try --mode reduced --threads 2 --lock try
    run_case complete-1 --mode complete --threads 1
    run_case complete-2 --mode complete --threads 2
    run_case complete-2-try --mode complete --threads 2 --lock try
done

echo
echo "$date_utc, $(nproc) logical CPUs, load average $load_before before, $(cut -d' ' -f1-3 /proc/loadavg) after"
echo "command: bench/run_harmonic.sh --points $points --seed $seed --repeats $repeats"
python3 - "$results" <<'EOF'
import json, sys
runs = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
best, every = {}, {}
for r in runs:
    every.setdefault(r["case"], []).append(r["delaunay_seconds"] if r["case"] == "cgal" else r["flip_seconds"])
    key = r["case"]
    t = r["delaunay_seconds"] if key == "cgal" else r["flip_seconds"]
    if key not in best or t < best[key][0]:
        best[key] = (t, r)
cgal = best["cgal"][0]
print()
print("| case | threads | Delaunay s | flipping s | tets before | tets after | mean harmonic index before | after | flips | smoothed |")
print("|---|---|---|---|---|---|---|---|---|---|")
print(f"| CGAL Delaunay alone | 1 | {cgal:.2f} | | {best['cgal'][1]['tets']:,} | | | | | |")
for key in ["reduced-1", "reduced-2", "reduced-2-try", "complete-1", "complete-2", "complete-2-try"]:
    if key not in best:
        continue
    t, r = best[key]
    policy = r.get('lock', 'try') if r['threads'] > 1 else 'serial'
    print(f"| idas {r['mode']} ({policy}) | {r['threads']} | {r['delaunay_seconds']:.2f} | {t:.2f} | "
          f"{r['tets_before']:,} | {r['tets_after']:,} | {r['mean_index_before']:.4f} | "
          f"{r['mean_index_after']:.4f} | {r['flips']:,} | {r['smoothed']:,} |")
print()
def median(xs):
    xs = sorted(xs)
    return (xs[(len(xs) - 1) // 2] + xs[len(xs) // 2]) / 2
for mode in ["reduced", "complete"]:
    for two in [mode + "-2", mode + "-2-try"]:
        a, b = best.get(mode + "-1"), best.get(two)
        if a and b:
            print(f"- {mode}, {b[1].get('lock', 'try')}: 2-thread speedup of flipping "
                  f"{a[0] / b[0]:.2f}x fastest runs, {median(every[mode + '-1']) / median(every[two]):.2f}x medians "
                  f"(flip CPU seconds {a[1]['flip_cpu_seconds']:.2f} on 1 thread, "
                  f"{b[1]['flip_cpu_seconds']:.2f} on 2; {b[1].get('crossed_parts', 0):,} entries crossed parts, "
                  f"{b[1]['lock_failures']:,} lock failures, "
                  f"{b[1]['deferred_to_serial']:,} entries deferred to the serial pass)")
if "complete-1" in best:
    print(f"- complete serial flipping / CGAL Delaunay of the same points: "
          f"{best['complete-1'][0] / cgal:.2f}")
EOF
