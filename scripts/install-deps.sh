#!/usr/bin/env bash
# Installs every Debian package texdefrag needs to build, test and plot. Idempotent: packages that
# are already installed are skipped, so running it twice costs one dpkg query.
set -euo pipefail
PKGS=(
  build-essential cmake pkg-config git
  libopenmesh-dev        # mesh adjacency (framework)
  libeigen3-dev          # linear algebra, sparse solvers (mergers, detectors)
  libceres-dev           # ARAP optimiser variant (mergers.arap)
  libpng-dev libjpeg62-turbo-dev  # texture pages: PNG and JPEG read and write, linked directly
  libopenimageio-dev     # pages in other formats (TIFF, BMP, TGA, EXR...), in a module loaded on use
  nlohmann-json3-dev     # configs and run reports
  libcli11-dev           # command line
  libgtest-dev libgmock-dev googletest  # unit tests
  libbenchmark-dev       # benchmarks
  python3 python3-matplotlib python3-numpy  # eval/plots
  libopenscenegraph-dev openscenegraph  # OSGB pyramids (reader/writer; osgconv checks the output)
  libtinygltf-dev        # glTF 2.0 / GLB reader and writer
  libdraco-dev           # Draco mesh compression in glTF (KHR_draco_mesh_compression)
  libtbb-dev             # parallel loops inside one model
  python3-distributed    # texdefrag batch on a Dask cluster
  python3-dev pybind11-dev  # the Python module
  chromium               # report viewer test (headless)
  help2man dpkg-dev fakeroot file  # man page and the .deb (CPack)
  clang libclang-rt-14-dev  # .ci/run: ASan/UBSan build and the libFuzzer targets (Debian 12: clang 14)
)
missing=()
# three.js (report viewer) and gltf-validator (tests) come from npm (scripts/install-npm.sh); Node.js
# is on the machine image (NodeSource build, which bundles npm), else Debian's.
command -v npm >/dev/null 2>&1 || PKGS+=(nodejs npm)
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
