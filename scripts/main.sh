#!/usr/bin/env bash
# Installs dependencies, builds the release preset and runs the main job on a bundled
# real mesh: QSlim decimation of the Stanford bunny (with its five scan holes) to 10%
# of its faces on two threads, with statistics of the input and the result.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake --preset release
cmake --build --preset release
mkdir -p out
./build/release/examples/idas info data/bunny.obj
./build/release/examples/idas decimate data/bunny.obj out/bunny_qslim.obj --algorithm qslim --ratio 0.1 --threads 2
./build/release/examples/idas info out/bunny_qslim.obj
