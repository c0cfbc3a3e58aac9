#!/usr/bin/env bash
# `texdefrag eval` on a non-OBJ model (issue 12: eval accepts the production formats): the bundled
# building converted to OSGB by OpenSceneGraph's osgconv (texture embedded), repacked, and
# compared: no face lost, positions exact, every texel copied. Skips (77) without osgconv.
# Usage: test_eval_formats.sh TEXDEFRAG_EXE SOURCE_DIR
set -euo pipefail
exe=$1; src=$2
command -v osgconv >/dev/null || { echo "skipped: osgconv not found (scripts/install-deps.sh installs openscenegraph)"; exit 77; }
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
cp "$src"/examples/building/building.obj "$src"/examples/building/building.mtl "$src"/examples/building/building_0.jpg "$work/"
(cd "$work" && osgconv building.obj building.osgb >/dev/null 2>&1) || fail "osgconv"
"$exe" run -q -c "$src/configs/repack.json" "$work/building.osgb" -o "$work/out"
"$exe" eval "$work/building.osgb" "$work/out/building.osgb" --json --samples 5000 --no-appearance > "$work/eval.json"
python3 - "$work/eval.json" <<'PY' || fail "eval figures"
import json, sys
j = json.load(open(sys.argv[1]))
m = j["matching"]
assert m["lost"] == 0 and m["matched"] == 5992, m
f = j["fidelity"]
assert f["copied_fraction"] == 1.0, f
PY
echo "eval on OSGB: ok"
