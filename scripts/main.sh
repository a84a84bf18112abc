#!/usr/bin/env bash
# Installs dependencies, builds the release preset and runs the main job on a bundled
# real mesh (the Stanford bunny, with its five scan holes).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake --preset release
cmake --build --preset release
mkdir -p out
./build/release/examples/idas info data/bunny.obj
./build/release/examples/idas demo data/bunny.obj out/bunny_demo.obj
./build/release/examples/idas info out/bunny_demo.obj
