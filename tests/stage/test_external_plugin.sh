#!/usr/bin/env bash
# Builds tests/stage/external_plugin out of tree against the build tree's texdefrag package, loads
# it through TEXDEFRAG_PLUGIN_PATH and runs it in a pipeline. Usage: test_external_plugin.sh BUILD_DIR SRC_DIR
set -euo pipefail
build=$1; src=$2
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
cmake -S "$src/tests/stage/external_plugin" -B "$work/build" -DCMAKE_BUILD_TYPE=Release -Dtexdefrag_DIR="$build" >/dev/null
cmake --build "$work/build" >/dev/null
export TEXDEFRAG_PLUGIN_PATH="$work/build"
bin="$build/bin/texdefrag"
"$bin" plugins | grep -q '^detectors.by_group ' || { echo "FAIL: detectors.by_group not listed"; exit 1; }
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
"$bin" run -q -c "$work/cfg.json" "$work/in/two.obj" -o "$work/out" --report > "$work/report.json"
python3 - "$work/report.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
node = r["stages"]["detectors.by_group"]
assert node["groups"] == 2, node
assert node["regions"] == 2, node
assert r["output_stats"]["faces"] == 4, r["output_stats"]
PY
test -s "$work/out/two.obj" || { echo "FAIL: no output"; exit 1; }
echo "1 passed, 0 failed"
