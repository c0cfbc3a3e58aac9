#!/usr/bin/env bash
# Installs dependencies, builds texdefrag with warnings as errors and runs the test suite
# (everything but tests labelled `slow`; run those with: ctest --test-dir build-ci -L slow).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
# Node.js packages (three.js for the HTML report, playwright-core for its browser test); the
# browser test skips with a message when they are absent.
bash scripts/install-npm.sh || echo "test.sh: npm packages not installed; the report browser test will skip" >&2
BUILD=${BUILD_DIR:-build-ci}
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DTEXDEFRAG_WERROR=ON
cmake --build "$BUILD" -j"$(nproc)"
ctest --test-dir "$BUILD" -LE slow --output-on-failure -j"$(nproc)" --timeout 900
