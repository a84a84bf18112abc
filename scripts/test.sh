#!/usr/bin/env bash
# Installs dependencies, builds the release preset and runs the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake --preset release
cmake --build --preset release
ctest --preset release -j"$(nproc)"
# The parallel executor's tests (triangle and tet) again under ThreadSanitizer (exit code 66 on any report).
cmake --preset tsan
cmake --build --preset tsan --target idas_parallel_tests
./build/tsan/tests/idas_parallel_tests -tc="parallel*,METIS*,harmonic*,adjacency*,vertex_try_lock*" -tce="*envelope*"
