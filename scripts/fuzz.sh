#!/usr/bin/env bash
# Fuzzes every file reader with libFuzzer: builds the harnesses of tests/fuzz/ with clang++
# (ASan + UBSan, no recovery) and runs each target for SECONDS_PER_READER (default 60) on
# its seed corpus tests/fuzz/corpus/<target>/. A crash, sanitizer report, exception other
# than idas::input_error, allocation over 2 GB, leak or input taking over 10 s is a
# finding: its input is saved under $IDAS_FUZZ_OUT/findings/<target>/ (default
# build/fuzz/findings/) and the script exits 1. Reproduce with: build/fuzz/fuzz_<harness> FILE
#
#   scripts/fuzz.sh [SECONDS_PER_READER]
#   IDAS_FUZZ_TARGETS="ply_ascii msh41_binary" scripts/fuzz.sh 300   # some targets only
#   IDAS_FUZZ_JOBS=1 scripts/fuzz.sh 60                              # one target at a time
#
# The last line is always "fuzz: N passed, M failed".
set -euo pipefail
cd "$(dirname "$0")/.."

seconds="${1:-60}"
out="${IDAS_FUZZ_OUT:-build/fuzz}"
cxx="${IDAS_FUZZ_CXX:-clang++}"

# target -> harness; each target has its own seed corpus, so every variant of a format
# gets its share of the time even though one harness reads them all.
declare -A harness_of=(
    [obj]=obj [off]=off [ply_ascii]=ply [ply_binary]=ply [stl_ascii]=stl [stl_binary]=stl
    [msh22_ascii]=msh [msh22_binary]=msh [msh41_ascii]=msh [msh41_binary]=msh
    [points_xyz]=points [points_ply]=points)
all_targets="obj off ply_ascii ply_binary stl_ascii stl_binary msh22_ascii msh22_binary
             msh41_ascii msh41_binary points_xyz points_ply"
read -r -a targets <<<"$(echo ${IDAS_FUZZ_TARGETS:-$all_targets})"
for t in "${targets[@]}"; do
    [ -n "${harness_of[$t]:-}" ] || { echo "fuzz.sh: unknown target '$t'" >&2; exit 2; }
done

flags=(-std=c++20 -O1 -g -fno-omit-frame-pointer -Wall -Wextra -Wpedantic -Werror
       -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined -Iinclude -Itests/fuzz)
mkdir -p "$out/logs"

# Build the harnesses the targets need, in parallel; a harness is rebuilt when any
# header or harness source is newer than it.
declare -A pids=()
for t in "${targets[@]}"; do
    h="${harness_of[$t]}"
    [ -z "${pids[$h]:-}" ] || continue
    bin="$out/fuzz_$h"
    if [ -x "$bin" ] && [ -z "$(find include tests/fuzz -name '*.?pp' -newer "$bin" | head -n1)" ]; then
        pids[$h]=done
        continue
    fi
    "$cxx" "${flags[@]}" "tests/fuzz/fuzz_$h.cpp" -o "$bin" -lgmpxx -lgmp -ltbb \
        >"$out/logs/build_$h.log" 2>&1 &
    pids[$h]=$!
done
for h in "${!pids[@]}"; do
    [ "${pids[$h]}" = done ] && continue
    if ! wait "${pids[$h]}"; then
        cat "$out/logs/build_$h.log" >&2
        echo "fuzz.sh: building the $h harness failed" >&2
        echo "fuzz: 0 passed, ${#targets[@]} failed"
        exit 1
    fi
done

# The targets run as many at a time as there are cores (each is one process): CI's two
# cores fuzz twelve targets of 10 s in about a minute.
jobs="${IDAS_FUZZ_JOBS:-$(nproc)}"
fuzz_one() { # writes the target's exit status beside its log
    local t="$1" h="${harness_of[$1]}"
    local work="$out/corpus/$1" findings="$out/findings/$1"
    # Findings are those of this run: a fixed one from before must not fail it again.
    rm -rf "$findings"
    mkdir -p "$work" "$findings"
    # New inputs go to the first (scratch) corpus; the seeds are only read.
    local status=0
    "$out/fuzz_$h" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
        -dict="tests/fuzz/dict/$h.dict" -artifact_prefix="$findings/" -print_final_stats=1 \
        "$work" "tests/fuzz/corpus/$t" >"$out/logs/$t.log" 2>&1 || status=$?
    echo "$status" >"$out/logs/$t.status"
}
declare -A running=()
for t in "${targets[@]}"; do
    while [ "${#running[@]}" -ge "$jobs" ]; do
        wait -n || true
        for r in "${!running[@]}"; do
            kill -0 "${running[$r]}" 2>/dev/null || unset "running[$r]"
        done
    done
    rm -f "$out/logs/$t.status"
    fuzz_one "$t" &
    running[$t]=$!
done
wait

passed=0 failed=0
for t in "${targets[@]}"; do
    findings="$out/findings/$t" log="$out/logs/$t.log"
    status=$(cat "$out/logs/$t.status" 2>/dev/null || echo "no status")
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n1)
    if [ "$status" = 0 ] && [ -z "$(ls -A "$findings")" ]; then
        passed=$((passed + 1))
        echo "fuzz: $t: clean (${runs:-?} runs in ${seconds} s)"
    else
        failed=$((failed + 1))
        echo "fuzz: $t: FINDING (exit $status), input(s) in $findings/, log $log"
        grep -E "ERROR|runtime error|idas fuzz finding|Timeout|out-of-memory|uncaught" "$log" |
            head -n 5 | sed 's/^/    /' || true # no matching line must not end the script
    fi
done
echo "fuzz: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
