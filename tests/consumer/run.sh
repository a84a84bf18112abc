#!/usr/bin/env bash
# Installs the configured idas build tree into a scratch prefix, then configures,
# builds and runs tests/consumer against it with find_package(idas CONFIG REQUIRED).
set -euo pipefail
build_dir=$1 source_dir=$2 work=$3 mesh=$4
rm -rf "$work" && mkdir -p "$work"
cmake --install "$build_dir" --prefix "$work/prefix" > "$work/install.log"
cmake -S "$source_dir/tests/consumer" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" \
      -DCMAKE_BUILD_TYPE=Release > "$work/configure.log"
cmake --build "$work/build" > "$work/build.log"
"$work/build/consumer" "$mesh"
