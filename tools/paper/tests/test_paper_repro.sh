#!/usr/bin/env bash
# test_paper_repro: the reproduction pipeline of tools/paper/reproduce.sh end to end on a tiny
# synthetic tile (cut -> own atlas per building -> bench of paper.json and one ablation -> figures ->
# paper numbers), then the cut of a real tile when ../shared/data is there (skipped with a message
# otherwise). Seconds. Usage: test_paper_repro.sh TEXDEFRAG_EXE WORKDIR [SHARED_DATA_DIR]
set -euo pipefail
exe=$1 work=$2 shared=${3:-}
here=$(cd "$(dirname "$0")/.." && pwd)
py=${TEXDEFRAG_PYTHON:-/usr/bin/python3}
fail() { echo "FAIL: $*" >&2; exit 1; }
rm -rf "$work"
mkdir -p "$work"

# A synthetic residential building on its ground: one "tile".
"$exe" synth --archetype residential --faces 3000 --seed 11 --page-size 256 --texels-per-edge 2 -o "$work/tile" >/dev/null
tile=$(ls "$work"/tile/*.obj)
TEXDEFRAG_PYTHON=$py bash "$here/reproduce.sh" "$work/set" "$work/res" --tile "$tile" --min-faces 50 --per-tile 1 \
  --synth-count 0 --samples 2000 --no-mmethod --configs "paper ablations/tetris" --exe "$exe" >"$work/log.txt" 2>&1 ||
  { cat "$work/log.txt" >&2; fail "reproduce.sh failed"; }

"$py" - "$work" "$tile" <<'EOF'
import csv, json, os, sys
work, tile = sys.argv[1], sys.argv[2]
def fail(m):
    print("FAIL: " + m, file=sys.stderr); sys.exit(1)
man = json.load(open(os.path.join(work, "set", "manifest.json")))
models = man["models"]
if len(models) != 1 or models[0]["kind"] != "real":
    fail("expected one cut building in the manifest, got %s" % models)
m = models[0]
# The kept building is the cut's largest, and its own-atlas copy holds exactly its faces.
stem = os.path.splitext(os.path.basename(tile))[0]
cut = json.load(open(os.path.join(work, "set", "cut", stem, stem + "_buildings.json")))
sizes = [p["faces"] for p in cut["parts"] if p["name"] != "rest"]
if m["faces"] != max(sizes) or m["part"] != "building_0":
    fail("kept %s (%d faces), the largest building has %d" % (m["part"], m["faces"], max(sizes)))
total = sum(p["faces"] for p in cut["parts"])
in_faces = sum(1 for l in open(tile) if l.startswith("f "))
if total != in_faces:
    fail("cut parts hold %d faces, the tile %d" % (total, in_faces))
obj = os.path.join(work, "set", m["path"])
got = sum(1 for l in open(obj) if l.startswith("f "))
if got != m["faces"]:
    fail("%s has %d faces, the building %d" % (obj, got, m["faces"]))
rep = json.load(open(os.path.splitext(obj)[0] + ".report.json"))
rows = [r for r in csv.DictReader(open(os.path.join(work, "res", "results.csv")))]
by = {r["config"]: r for r in rows}
for c in ("paper", "tetris"):
    r = by.get(c)
    if not r or r["status"] != "ok":
        fail("no ok record for %s: %s" % (c, r))
    if r["meta.kind"] != "real" or int(float(r["lost_faces"])) != 0:
        fail("%s: kind %s, lost faces %s" % (c, r["meta.kind"], r["lost_faces"]))
    if not float(r["chart_reduction"]) > 0.3:
        fail("%s: chart reduction %s on a synthetic building" % (c, r["chart_reduction"]))
# repack kept every input chart (own atlas, same charts): the charts the bench counts in the input
# equal the cut building's charts before repacking.
cin = int(float(by["paper"]["charts_in"]))
if cin < 10:
    fail("charts in %d" % cin)
num = open(os.path.join(work, "res", "paper_numbers_all.md")).read()
if "| 18 | median ARAP distortion | 0.011 (M-method 0.017) |" not in num or "Models: 1 " not in num:
    fail("paper_numbers_all.md:\n" + num)
for f in ("summary.md", "summary_ablations.md"):
    if not os.path.isfile(os.path.join(work, "res", f)):
        fail("no " + f)
print("synthetic tile ok: building of %d faces, charts %d -> %s (paper)" % (m["faces"], cin, by["paper"]["charts_out"]))
EOF
# Figures: only where matplotlib is installed (plots.py exits 3 without it, summary still written).
if "$py" -c "import matplotlib" 2>/dev/null; then
  for f in fig16_chart_reduction fig17_seam_reduction fig18_distortion fig19_texture_size fig20_vertex_replication; do
    [ -s "$work/res/figures/$f.png" ] || fail "no figures/$f.png"
    [ -s "$work/res/figures_ablations/$f.png" ] || fail "no figures_ablations/$f.png"
  done
else
  echo "matplotlib absent: figures not checked"
fi

# Bad arguments are refused with a message naming them.
if "$py" "$here/make_buildings.py" -o "$work/bad" --exe "$exe" --tile "$work/no_such.obj" 2>"$work/err.txt"; then fail "missing tile accepted"; fi
grep -q "no_such.obj" "$work/err.txt" || fail "missing tile not named: $(cat "$work/err.txt")"

# Real data: the smallest development tile, cut and given its own atlas.
real=$shared/contextcapture/rural_t007_078_L15
if [ -z "$shared" ] || [ ! -d "$real" ]; then
  echo "real-data part skipped: no $real (../shared/data absent)"
  exit 0
fi
"$py" "$here/make_buildings.py" -o "$work/real" --tile "$(ls "$real"/*.obj)" --per-tile 1 --exe "$exe" >"$work/real.log" 2>&1 ||
  { cat "$work/real.log" >&2; fail "make_buildings.py on $real"; }
"$py" - "$work/real" <<'EOF'
import json, os, sys
out = sys.argv[1]
man = json.load(open(os.path.join(out, "manifest.json")))
ms = man["models"]
if len(ms) != 1 or ms[0]["faces"] < 200:
    print("FAIL: real tile: %s" % ms, file=sys.stderr); sys.exit(1)
obj = os.path.join(out, ms[0]["path"])
if sum(1 for l in open(obj) if l.startswith("f ")) != ms[0]["faces"]:
    print("FAIL: %s face count" % obj, file=sys.stderr); sys.exit(1)
print("real tile ok: %s, %d faces" % (ms[0]["name"], ms[0]["faces"]))
EOF
echo "test_paper_repro: ok"
