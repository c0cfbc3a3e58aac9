#!/usr/bin/env bash
# Builds the Debian package on a fresh Debian 12 (one command; docs in README "Install"):
#   bash scripts/package.sh        -> build-deb/texdefrag_<version>_<arch>.deb
# then: sudo apt-get install ./build-deb/texdefrag_*.deb   (or dpkg -i; apt resolves the Depends)
# The package's Depends are Debian 12's runtime libraries found by dpkg-shlibdeps, plus python3
# and python3-numpy for the Python module.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
BUILD=${BUILD_DIR:-build-deb}
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DTEXDEFRAG_BUILD_TESTS=OFF -DTEXDEFRAG_BUILD_BENCHMARKS=OFF
cmake --build "$BUILD" -j"$(nproc)"
(cd "$BUILD" && cpack -G DEB)
ls -1 "$BUILD"/texdefrag_*.deb
