#!/usr/bin/env bash
# Regenerates examples/production, the bundled ContextCapture-style OSGB pyramid, from the bundled
# OBJ production examples/production_obj (same tile, levels 15 and 16, same JPEG pages, same
# metadata.xml). Reproducible: the same inputs give the same bytes (test_example_production
# checks it when it can run the generator).
# Usage: tools/osgb_pyramid/make_example.sh [MAKE_OSGB_PYRAMID] [OUT_DIR]
#   MAKE_OSGB_PYRAMID default build/tools/osgb_pyramid/make_osgb_pyramid; OUT_DIR default examples/production
set -euo pipefail
src=$(cd "$(dirname "$0")/../.." && pwd)
gen=$(realpath "${1:-$src/build/tools/osgb_pyramid/make_osgb_pyramid}")
out=$(realpath -m "${2:-$src/examples/production}")
tile=Tile_+000_+000
obj="$src/examples/production_obj"
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
# Run beside the OBJ files, so the image names embedded in the OSGB files are plain file names.
(cd "$obj/Data/$tile" && "$gen" "$tmp" "$tile" "15=${tile}_L15_0.obj" "16=${tile}_L16_0.obj")
cp "$obj/metadata.xml" "$tmp/metadata.xml"
mkdir -p "$out"
rm -rf "$out/Data"
cp -r "$tmp/Data" "$out/Data"
cp "$tmp/metadata.xml" "$out/metadata.xml"
(cd "$out" && find metadata.xml Data -type f | sort | xargs ls -l | awk '{print $5, $9}')
