#!/usr/bin/env bash
# The bundled productions. examples/production (an OSGB pyramid: metadata.xml, a root PagedLOD file
# and two level files with embedded JPEG pages; scripts/demo.sh runs it): `texdefrag run` writes
# the same tree, the root (no textured face) copied byte for byte, one report per level file with
# every face kept, metadata.xml byte for byte, a summary with one task per level, every OSGB
# readable by osgconv (when installed), and nothing written into the example. It is regenerated
# from examples/production_obj by tools/osgb_pyramid/make_example.sh and must equal the committed
# files (when the generator is given). examples/production_obj (the OBJ form) is run the same way.
# Skips (exit 77) when OpenSceneGraph's osgdb plugins are missing.
# Usage: test_example_production.sh TEXDEFRAG_EXE SOURCE_DIR [MAKE_OSGB_PYRAMID]
set -euo pipefail
exe=$1; src=$2; gen=${3:-}
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
tile="Data/Tile_+000_+000/Tile_+000_+000"

# The OBJ production.
ex="$src/examples/production_obj"
before=$(cd "$ex" && find . -type f -exec md5sum {} + | sort)
"$exe" run -q -c "$src/configs/repack.json" "$ex" -o "$work/obj"
[ "$before" = "$(cd "$ex" && find . -type f -exec md5sum {} + | sort)" ] || fail "the OBJ example production was written"
cmp -s "$ex/metadata.xml" "$work/obj/metadata.xml" || fail "metadata.xml not copied byte for byte (OBJ)"
for l in 15 16; do
  t="${tile}_L${l}_0"
  [ -s "$work/obj/$t.obj" ] && [ -s "$work/obj/$t.report.json" ] || fail "no output for $t"
  [ "$(grep -c '^f ' "$ex/$t.obj")" = "$(grep -c '^f ' "$work/obj/$t.obj")" ] || fail "$t: face count changed"
done
echo "example production (OBJ): ok"

# The OSGB pyramid.
ex="$src/examples/production"
if [ -n "$gen" ]; then
  bash "$src/tools/osgb_pyramid/make_example.sh" "$gen" "$work/regenerated" >/dev/null 2>"$work/gen.err" ||
    { grep -q "plugin" "$work/gen.err" && { cat "$work/gen.err"; echo "SKIP: OpenSceneGraph plugins missing"; exit 77; }; cat "$work/gen.err"; fail "make_example.sh"; }
  diff -r "$ex/Data" "$work/regenerated/Data" >/dev/null || fail "examples/production differs from what make_example.sh generates"
  cmp -s "$ex/metadata.xml" "$work/regenerated/metadata.xml" || fail "metadata.xml differs from the generated one"
fi
before=$(cd "$ex" && find . -type f -exec md5sum {} + | sort)
if ! "$exe" run -q -c "$src/configs/repack.json" "$ex" -o "$work/osgb" 2>"$work/run.err"; then
  cat "$work/run.err"
  grep -q "osgDB plugin" "$work/run.err" && { echo "SKIP: OpenSceneGraph's osgdb plugins are missing"; exit 77; }
  fail "texdefrag run on examples/production"
fi
[ "$before" = "$(cd "$ex" && find . -type f -exec md5sum {} + | sort)" ] || fail "the example production was written"
cmp -s "$ex/metadata.xml" "$work/osgb/metadata.xml" || fail "metadata.xml not copied byte for byte"
cmp -s "$ex/$tile.osgb" "$work/osgb/$tile.osgb" || fail "the root file (no textured face) not copied byte for byte"
for l in 15 16; do
  t="${tile}_L${l}_0"
  [ -s "$work/osgb/$t.osgb" ] && [ -s "$work/osgb/$t.report.json" ] || fail "no output for $t"
  if command -v osgconv >/dev/null; then
    osgconv "$work/osgb/$t.osgb" "$work/check.osgt" >/dev/null 2>&1 || fail "osgconv cannot read $t.osgb"
    grep -q "osg::PagedLOD" "$work/check.osgt" || [ "$l" = 16 ] || fail "$t.osgb lost its PagedLOD"
  fi
done
python3 - "$work/osgb" <<'PY' || fail "summary or reports"
import json, os, sys
out = sys.argv[1]
s = json.load(open(os.path.join(out, "texdefrag_summary.json")))
assert [t["level"] for t in s["tasks"]] == ["root", "L15", "L16"], [t["level"] for t in s["tasks"]]
assert [t["status"] for t in s["tasks"]] == ["ok"] * 3, s["tasks"]
assert s["tasks"][0]["copied"] and s["tasks"][0]["faces"] == 0, s["tasks"][0]
for t in s["tasks"][1:]:
    assert t["faces"] > 1000 and t["missing_files"] == 0, t
    r = json.load(open(os.path.join(out, t["relative"][:-5] + ".report.json")))
    assert r["input_stats"]["faces"] == r["output_stats"]["faces"] == t["faces"], (t, r["output_stats"])
PY
echo "example production (OSGB): ok"
