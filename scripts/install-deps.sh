#!/usr/bin/env bash
# Installs every Debian package texdefrag needs to build, test and plot. Idempotent: packages that
# are already installed are skipped, so running it twice costs one dpkg query.
set -euo pipefail
PKGS=(
  build-essential cmake pkg-config git
  libopenmesh-dev        # mesh adjacency (framework)
  libeigen3-dev          # linear algebra, sparse solvers (mergers, detectors)
  libceres-dev           # ARAP optimiser variant (mergers.arap)
  libopenimageio-dev     # texture pages: JPEG/PNG/TIFF read, PNG/JPEG write
  nlohmann-json3-dev     # configs and run reports
  libcli11-dev           # command line
  libgtest-dev libgmock-dev googletest  # unit tests
  libbenchmark-dev       # benchmarks
  python3 python3-matplotlib python3-numpy  # eval/plots
)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
