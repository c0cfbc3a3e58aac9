#!/usr/bin/env bash
# Installs the build (cmake --install into a scratch prefix), builds tests/stage/external_plugin
# (a detector, a packer on the exported packing helpers, a merger on the exported merge engine) out
# of tree against the INSTALLED package, loads the modules through TEXDEFRAG_PLUGIN_PATH into the
# installed texdefrag and runs them in pipelines, from an empty working folder.
# Usage: test_external_plugin.sh BUILD_DIR SRC_DIR
set -euo pipefail
build=$1; src=$2
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" >/dev/null
# Only the installed package: the build tree is not on any search path.
cmake -S "$src/tests/stage/external_plugin" -B "$work/build" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF >"$work/configure.log" ||
  { cat "$work/configure.log"; echo "FAIL: configure against the installed package"; exit 1; }
grep -q "$work/prefix/lib/cmake/texdefrag" "$work/build/CMakeCache.txt" ||
  { grep texdefrag_DIR "$work/build/CMakeCache.txt"; echo "FAIL: texdefrag not found in the installed prefix"; exit 1; }
cmake --build "$work/build" -j2 >"$work/build.log" || { cat "$work/build.log"; echo "FAIL: build"; exit 1; }
export TEXDEFRAG_PLUGIN_PATH="$work/build"
bin="$work/prefix/bin/texdefrag"
mkdir "$work/empty" && cd "$work/empty"
for s in detectors.by_group packers.row mergers.by_material; do
  "$bin" plugins | grep -q "^$s " || { echo "FAIL: $s not listed"; exit 1; }
done
"$bin" plugins --describe detectors.by_group | grep -q "module: $work/build/" || { echo "FAIL: not loaded from the plugin build"; exit 1; }
"$bin" plugins --describe packers.shelf | grep -q "module: $work/prefix/lib/texdefrag/plugins/" ||
  { echo "FAIL: installed stages not loaded from the prefix"; exit 1; }
"$bin" plugins --describe detectors.by_group --json | grep -q '"ungrouped_region"' || { echo "FAIL: options not described"; exit 1; }
# A two-group model: two squares in separate groups, each triangle its own chart.
mkdir -p "$work/in"
python3 - "$work/in" <<'PY'
import struct, sys, zlib, os
d = sys.argv[1]
def png(path, w, h):
    raw = b''.join(b'\x00' + b''.join(bytes([(x * 16) % 256, (y * 16) % 256, 128]) for x in range(w)) for y in range(h))
    def chunk(t, data): return struct.pack('>I', len(data)) + t + data + struct.pack('>I', zlib.crc32(t + data) & 0xffffffff)
    open(path, 'wb').write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 2, 0, 0, 0)) + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b''))
png(os.path.join(d, 'tex.png'), 16, 16)
open(os.path.join(d, 'two.mtl'), 'w').write('newmtl m\nmap_Kd tex.png\n')
obj = ['mtllib two.mtl', 'usemtl m']
vt = [(0.1,0.1),(0.4,0.1),(0.4,0.4),(0.6,0.6),(0.9,0.6),(0.9,0.9)]
obj += ['vt %g %g' % t for t in vt]
for g, x0 in (('a', 0), ('b', 5)):
    obj.append('g ' + g)
    base = len([l for l in obj if l.startswith('v ')])
    for p in ((x0,0,0),(x0+1,0,0),(x0+1,1,0),(x0,1,0)):
        obj.append('v %g %g %g' % p)
    obj.append('f %d/1 %d/2 %d/3' % (base+1, base+2, base+3))
    obj.append('f %d/4 %d/5 %d/6' % (base+1, base+3, base+4))
open(os.path.join(d, 'two.obj'), 'w').write('\n'.join(obj) + '\n')
PY
cat > "$work/cfg.json" <<'JSON'
{"detector": {"type": "detectors.by_group"}, "merger": {"type": "mergers.none"}, "packer": {"type": "packers.shelf"}}
JSON
# The detector uses the exported detectors_common helpers: region statistics, and the label file and
# region-coloured model every detector can write into the output folder.
"$bin" run -q -c "$work/cfg.json" "$work/in/two.obj" -o "$work/out" --report \
  --set detector.write_labels=groups.txt --set detector.write_colored=groups.obj > "$work/report.json"
python3 - "$work/report.json" "$work/out/groups.txt" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
node = r["stages"]["detectors.by_group"]
assert node["groups"] == 2, node
assert node["regions"] == 2, node
assert node["faces_per_region"]["max"] == 2 and node["textured_faces"] == 4, node
assert r["output_stats"]["faces"] == 4, r["output_stats"]
labels = [l.strip() for l in open(sys.argv[2]) if l.strip() and not l.startswith("#")]
assert labels == ["0", "0", "1", "1"], labels
PY
test -s "$work/out/two.obj" || { echo "FAIL: no output"; exit 1; }
test -s "$work/out/groups.obj" && test -s "$work/out/groups.mtl" && test -s "$work/out/groups_palette.png" ||
  { ls "$work/out"; echo "FAIL: no region-coloured model from the exported helper"; exit 1; }
# The packer and the merger on the bundled example (installed with the package).
example="$work/prefix/share/texdefrag/examples/building/building.obj"
cat > "$work/cfg2.json" <<'JSON'
{"detector": {"type": "detectors.region_growing"}, "merger": {"type": "mergers.by_material"},
 "packer": {"type": "packers.row", "row_width": 2048}}
JSON
"$bin" run -q -c "$work/cfg2.json" "$example" -o "$work/out2" --report > "$work/report2.json"
python3 - "$work/report2.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
m = r["stages"]["mergers.by_material"]
p = r["stages"]["packers.row"]
assert m["constraint_regions"] >= 1, m
assert r["output_stats"]["charts"] < r["input_stats"]["charts"]["charts"], (r["output_stats"], r["input_stats"]["charts"])
assert p["pages"] >= 1 and p["row_width"] == 2048, p
assert r["output_stats"]["faces"] == r["input_stats"]["faces"]
PY
test -s "$work/out2/building.obj" || { echo "FAIL: no output for packers.row / mergers.by_material"; exit 1; }
echo "2 passed, 0 failed"
