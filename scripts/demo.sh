#!/usr/bin/env bash
# Installs dependencies, builds texdefrag, runs the main pipeline on the bundled example and prints
# its metrics (input vs output), then runs it on the bundled production (examples/production: a
# ContextCapture OSGB pyramid, metadata.xml + a root PagedLOD file + levels 15 and 16 with embedded
# JPEG pages) and prints its per-tile lines.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
BUILD=${BUILD_DIR:-build}
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DTEXDEFRAG_BUILD_TESTS=OFF -DTEXDEFRAG_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$BUILD" -j"$(nproc)"
CONFIG=${CONFIG:-configs/best.json}
MODEL=examples/building/building.obj
OUT=${OUT:-out/demo}
"$BUILD/bin/texdefrag" run -c "$CONFIG" "$MODEL" -o "$OUT"
"$BUILD/bin/texdefrag" eval "$MODEL" "$OUT/building.obj"
"$BUILD/bin/texdefrag" run -c "$CONFIG" examples/production -o "$OUT/production"
