#!/usr/bin/env bash
# Installs every build, test and benchmark dependency of idas from Debian 12
# packages. Safe to run any number of times (apt-get install is idempotent).
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

packages=(
  build-essential cmake ninja-build pkg-config git
  # design-card packages: the core headers need only these
  libtbb-dev libeigen3-dev libgmp-dev libboost-dev libmetis-dev doctest-dev
  # the tool, tests and benchmarks
  libcli11-dev libfmt-dev nlohmann-json3-dev libbenchmark-dev python3-matplotlib
  # the Python module (python/) and its tests
  pybind11-dev python3-dev python3-numpy python3-pytest
  # peers and the optional CGAL-based headers
  libcgal-dev libopenmesh-dev libmpfr-dev
  clang-format
  # scripts/fuzz.sh: libFuzzer ships in compiler-rt (libclang_rt.fuzzer), which the generic
  # package installs for the same default clang version as "clang"
  clang libclang-rt-dev
)

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
