#!/usr/bin/env bash
# Installs dependencies, builds the release preset, runs the whole test suite and fuzzes
# the file readers briefly.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh --tests
cmake --preset release
cmake --build --preset release
ctest --preset release -j"$(nproc)"
# The parallel executor's tests (triangle and tet) again under ThreadSanitizer (exit code 66 on any report).
cmake --preset tsan
cmake --build --preset tsan --target idas_parallel_tests
# About 2 minutes on 2 cores (built at -O1 with line tables only, which halves the build:
# the races are the same). The deterministic harmonic triangulation runs here on 1,500
# points ("deterministic harmonic, small"); its 10k-point case, 2 minutes more under TSan,
# is left to the release run, and so is the comparison of QSlim's error with the serial
# executor's (eight decimations and sixteen Hausdorff distances: a quality check, whose
# decimations run in bands as the same-bytes tests' do). The limit turns a hang into a
# failure that names this step.
TSAN_OPTIONS="suppressions=$PWD/tests/tsan.supp ${TSAN_OPTIONS:-}" \
    timeout --signal=KILL 1200 ./build/tsan/tests/idas_parallel_tests -tc="parallel*,METIS*,harmonic*,adjacency*,vertex_try_lock*,deterministic*" \
    -tce="*envelope*,deterministic rounds: harmonic*,*stays near the serial*"
# Every file reader under libFuzzer with ASan + UBSan (exit 1 on any finding). CI has 2 cores
# and 40 minutes for this whole script: 10 s for each of the 12 targets, two at a time, is a minute
# plus under a minute to build the harnesses, enough to replay the seed and regression
# corpus and catch a reader that breaks on simple mutations. Fuzz longer locally:
# scripts/fuzz.sh 300.
bash scripts/fuzz.sh "${IDAS_CI_FUZZ_SECONDS:-10}"
