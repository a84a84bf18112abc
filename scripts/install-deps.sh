#!/usr/bin/env bash
# Installs every build, test and benchmark dependency of idas from Debian 12
# packages. Safe to run any number of times (apt-get install is idempotent).
#   scripts/install-deps.sh           everything
#   scripts/install-deps.sh --tests   what building and testing need (scripts/test.sh):
#                                     not the benchmarks' peers, Google Benchmark, plots
set -euo pipefail

for_tests=0
case "${1:-}" in
  --tests) for_tests=1 ;;
  "") ;;
  *) echo "usage: $0 [--tests]" >&2; exit 2 ;;
esac

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

packages=(
  build-essential cmake ninja-build pkg-config git
  # design-card packages: the core headers need only these
  libtbb-dev libeigen3-dev libgmp-dev libboost-dev libmetis-dev doctest-dev
  # the tool and the tests
  libcli11-dev libfmt-dev nlohmann-json3-dev
  # the Python module (python/) and its tests
  pybind11-dev python3-dev python3-numpy python3-pytest
  # the CGAL-based headers (envelope, Delaunay, tetmesh)
  libcgal-dev libmpfr-dev
  # scripts/fuzz.sh: libFuzzer ships in compiler-rt (libclang_rt.fuzzer), which the generic
  # package installs for the same default clang version as "clang"
  clang libclang-rt-dev
)
if [ "$for_tests" -eq 0 ]; then
  # the benchmarks (Google Benchmark, the OpenMesh peer, plots) and formatting
  packages+=(libbenchmark-dev libopenmesh-dev python3-matplotlib clang-format)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ "${#missing[@]}" -gt 0 ]; then
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update
  $SUDO apt-get install -y --no-install-recommends "${missing[@]}"
else
  echo "install-deps: all packages already installed"
fi
