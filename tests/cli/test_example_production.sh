#!/usr/bin/env bash
# The bundled production (examples/production, which scripts/demo.sh runs): `texdefrag run` on the
# folder writes the same tree, one report per tile, metadata.xml byte for byte, a summary with one
# task per level, every face of each tile, and writes nothing into the example.
# Usage: test_example_production.sh TEXDEFRAG_EXE SOURCE_DIR
set -euo pipefail
exe=$1; src=$2
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
ex="$src/examples/production"
before=$(cd "$ex" && find . -type f -exec md5sum {} + | sort)
"$exe" run -q -c "$src/configs/repack.json" "$ex" -o "$work/out"
after=$(cd "$ex" && find . -type f -exec md5sum {} + | sort)
[ "$before" = "$after" ] || fail "the example production was written"
cmp -s "$ex/metadata.xml" "$work/out/metadata.xml" || fail "metadata.xml not copied byte for byte"
for l in 15 16; do
  t="Data/Tile_+000_+000/Tile_+000_+000_L${l}_0"
  [ -s "$work/out/$t.obj" ] && [ -s "$work/out/$t.report.json" ] || fail "no output for $t"
  [ "$(grep -c '^f ' "$ex/$t.obj")" = "$(grep -c '^f ' "$work/out/$t.obj")" ] || fail "$t: face count changed"
done
python3 - "$work/out/texdefrag_summary.json" <<'PY' || fail "summary"
import json, sys
s = json.load(open(sys.argv[1]))
assert [t["level"] for t in s["tasks"]] == ["L15", "L16"], [t["level"] for t in s["tasks"]]
assert s["levels"]["all"]["tasks"] == 2, s["levels"]
PY
echo "example production: ok"
