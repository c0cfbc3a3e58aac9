#!/usr/bin/env bash
# Installs dependencies, builds texdefrag with warnings as errors and runs the test suite
# (everything but tests labelled `slow`; run those with: ctest --test-dir build-ci -L slow).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
BUILD=${BUILD_DIR:-build-ci}
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DTEXDEFRAG_WERROR=ON
cmake --build "$BUILD" -j"$(nproc)"
ctest --test-dir "$BUILD" -LE slow --output-on-failure -j"$(nproc)" --timeout 900
