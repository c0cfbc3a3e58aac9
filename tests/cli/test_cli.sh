#!/usr/bin/env bash
# The command line's contract: exit codes 0 ok / 1 failure / 2 usage or configuration error, and
# error messages that name the file, line or key. Usage: test_cli.sh TEXDEFRAG_EXE SRC_DIR
set -uo pipefail
exe=$1; src=$2
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
pass=0; fail=0
check() {  # check NAME EXPECTED_CODE EXPECTED_STDERR_FRAGMENT -- command...
  local name=$1 code=$2 frag=$3; shift 4
  "$@" >"$work/out" 2>"$work/err"; local got=$?
  if [ "$got" -ne "$code" ] || { [ -n "$frag" ] && ! grep -qF -- "$frag" "$work/err" "$work/out"; }; then
    echo "FAIL $name: exit $got (want $code), output:"; cat "$work/err" "$work/out" | head -5; fail=$((fail+1))
  else pass=$((pass+1)); fi
}
model="$src/examples/building/building.obj"
check "no subcommand" 2 "A subcommand is required" -- "$exe"
check "unknown option" 2 "" -- "$exe" run --nope
check "bad config" 2 "'gutter' = -1 outside [0, 64]" -- "$exe" run -c "$src/configs/bad/out_of_range.json" "$model" -o "$work/o1"
check "bad --set" 2 "expected STAGE.OPTION=VALUE" -- "$exe" run -c "$src/configs/repack.json" "$model" --set gutter -o "$work/o2"
check "missing model" 1 "$work/missing.obj" -- "$exe" run -c "$src/configs/repack.json" "$work/missing.obj" -o "$work/o3"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n' > "$work/bad.obj"
check "malformed model names file:line" 1 "bad.obj:4" -- "$exe" run -c "$src/configs/repack.json" "$work/bad.obj" -o "$work/o4"
check "output into input folder" 1 "is the input's folder" -- "$exe" run -c "$src/configs/repack.json" "$model" -o "$src/examples/building"
check "validate ok" 0 "ok" -- "$exe" validate -c "$src/configs/repack.json"
check "describe unknown" 2 "did you mean 'packers.shelf'" -- "$exe" plugins --describe packers.shelff
check "describe json" 0 "\"max_page_size\"" -- "$exe" plugins --describe packers.shelf --json
check "run ok" 0 "charts =>" -- "$exe" run -c "$src/configs/repack.json" "$model" -o "$work/o5"
test -s "$work/o5/building.obj" && test -s "$work/o5/building.report.json" || { echo "FAIL run wrote no output"; fail=$((fail+1)); }
check "quiet run prints nothing" 0 "" -- "$exe" run -q -c "$src/configs/repack.json" "$model" -o "$work/o6"
[ ! -s "$work/err" ] || { echo "FAIL quiet run wrote to stderr"; fail=$((fail+1)); }
check "eval ok" 0 "PSNR" -- "$exe" eval "$model" "$work/o5/building.obj"
check "eval missing file" 1 "$work/nope.obj" -- "$exe" eval "$model" "$work/nope.obj"
# --set takes exactly one KEY=VALUE per occurrence: an input after it is the input, not a value.
check "--set before the input" 0 "" -- "$exe" run -q -c "$src/configs/repack.json" --set packer.gutter=3 "$model" -o "$work/o9"
test -s "$work/o9/building.obj" || { echo "FAIL --set before the input wrote no output"; fail=$((fail+1)); }
check "--set takes one value" 2 "not expected: packer.max_page_size=512" -- "$exe" validate -c "$src/configs/repack.json" --set packer.gutter=3 packer.max_page_size=512
check "--set repeated" 0 "ok" -- "$exe" validate -c "$src/configs/repack.json" --set packer.gutter=3 --set=packer.max_page_size=512
# Issue 11, cases 1 and 2: no input file is ever written; output.name is a file stem.
mkdir -p "$work/in" && cp "$src"/examples/building/building.{obj,mtl} "$src"/examples/building/building_0.jpg "$work/in/"
sum_in() { (cd "$work/in" && sha256sum building.obj building.mtl building_0.jpg); }
before=$(sum_in)
check "write_colored onto the input refused" 2 "'write_colored' = \"$work/in/building.obj\"" -- "$exe" run -q -c "$src/configs/repack.json" "$work/in/building.obj" -o "$work/o7" --set detector.type=detectors.angle_growing --set "detector.write_colored=$work/in/building.obj"
check "output.name ../in/copy refused" 2 "output.name: '../in/copy'" -- "$exe" run -q -c "$src/configs/repack.json" "$work/in/building.obj" -o "$work/o8" --set output.name=../in/copy
check "output.name absolute refused" 2 "output.name: '$work/abs'" -- "$exe" run -q -c "$src/configs/repack.json" "$work/in/building.obj" -o "$work/o8" --set "output.name=$work/abs"
check "validate: write_colored names an .obj" 2 "write_colored 'in/building.mtl' must name an .obj file" -- "$exe" validate -c "$src/configs/best.json" --set detector.write_colored=in/building.mtl
check "run: write_colored .mtl refused before reading" 2 "must name an .obj file" -- "$exe" run -q -c "$src/configs/best.json" "$work/in/building.obj" -o "$work/o10" --set detector.write_colored=in/building.mtl
[ ! -e "$work/o10" ] || { echo "FAIL a refused write_colored left an output folder"; fail=$((fail+1)); }
check "validate refuses output.name a/b" 2 "output.name: 'a/b'" -- "$exe" validate -c "$src/configs/repack.json" --set output.name=a/b
[ "$(sum_in)" = "$before" ] && [ "$(ls "$work/in" | wc -l)" -eq 3 ] && [ ! -e "$work/abs.obj" ] || { echo "FAIL an input file was written"; fail=$((fail+1)); }
# Issue 11, typed options: required, --set SECTION.type= resets, a stray library is skipped.
printf '{"detector": {"type": "detectors.labels"}}' > "$work/labels.json"
check "validate: required labels path" 2 "detector (detectors.labels): 'path' is required" -- "$exe" validate -c "$work/labels.json"
check "validate: labels path missing" 2 "'path' = \"$work/none.txt\": no such file" -- "$exe" validate -c "$work/labels.json" --set "detector.path=$work/none.txt"
check "--set detector.type resets its options" 0 "ok" -- "$exe" validate -c "$src/configs/best.json" --set detector.type=detectors.angle_growing
check "--set after the type applies" 2 "unknown option 'w_flatness'" -- "$exe" validate -c "$src/configs/repack.json" --set detector.w_flatness=0.5 --set detector.type=detectors.angle_growing
mkdir -p "$work/plugins"
for lib in /usr/lib/x86_64-linux-gnu/libz.so.1 /lib/x86_64-linux-gnu/libz.so.1; do [ -e "$lib" ] && cp "$lib" "$work/plugins/stray.so" && break; done
check "stray .so skipped" 0 "skipping $work/plugins/stray.so: not a texdefrag plugin" -- env TEXDEFRAG_PLUGIN_PATH="$work/plugins" "$exe" validate -c "$src/configs/repack.json"
# Issue 11, case 5: small ones.
check "unknown subcommand" 2 "unknown subcommand 'frobnicate' (valid: run, validate" -- "$exe" frobnicate
for bad in nan inf -1; do
  check "eval --position-tolerance $bad" 2 "--position-tolerance" -- "$exe" eval "$model" "$work/o5/building.obj" --position-tolerance "$bad"
done
mkdir -p "$work/bom" && cp "$src/examples/building/building_0.jpg" "$work/bom/"
{ printf '\xEF\xBB\xBF'; cat "$src/examples/building/building.obj"; } > "$work/bom/building.obj"
{ printf '\xEF\xBB\xBF'; cat "$src/examples/building/building.mtl"; } > "$work/bom/building.mtl"
check "UTF-8 BOM in OBJ and MTL accepted" 0 "" -- "$exe" run -q -c "$src/configs/repack.json" "$work/bom/building.obj" -o "$work/o9"
mkdir -p "$work/png"
printf 'mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl a\nf 1/1 2/2 3/3\n' > "$work/png/m.obj"
printf 'newmtl a\nmap_Kd page.png\n' > "$work/png/m.mtl"
# a PNG signature and a valid 8x8 RGB IHDR, then a truncated IDAT
python3 -c 'import struct, zlib, sys
def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
sys.stdout.buffer.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 8, 8, 8, 2, 0, 0, 0)) + chunk(b"IDAT", b"\x78\x9c\x01\x02")[:12])' > "$work/png/page.png"
check "corrupt PNG names the file" 1 "$work/png/page.png" -- "$exe" run -q -c "$src/configs/repack.json" "$work/png/m.obj" -o "$work/o10"
! grep -q "libpng error" "$work/err" || { echo "FAIL a raw libpng line reached stderr:"; cat "$work/err"; fail=$((fail+1)); }
# A production (folder of tiles) with one malformed tile: the others are written, the failure is in
# the summary naming the file, exit 1 (docs/production.md).
mkdir -p "$work/prod/good" "$work/prod/bad"
cp "$src"/examples/building/building.{obj,mtl} "$src"/examples/building/building_0.jpg "$work/prod/good/"
cp "$work/bad.obj" "$work/prod/bad/bad.obj"
check "production goes on past a failing tile" 1 "FAILED production task 1/2 (bad/bad.obj): $work/prod/bad/bad.obj:4" -- "$exe" run -q -c "$src/configs/repack.json" "$work/prod" -o "$work/o11"
test -s "$work/o11/good/building.obj" && [ ! -e "$work/o11/bad/bad.obj" ] && grep -q '"failed": 1' "$work/o11/texdefrag_summary.json" \
  || { echo "FAIL production: good tile not written, bad tile written or summary without the failure"; fail=$((fail+1)); }
printf '{"packer": {"type": "packers.shelf", "gutter": 6666666e666666466666666}}\n' > "$work/overflow.json"
check "number overflow in a config names the file" 2 "$work/overflow.json: invalid JSON" -- "$exe" validate -c "$work/overflow.json"
check "number overflow in --set names the key" 2 "'gutter' must be an integer" -- "$exe" validate -c "$src/configs/repack.json" --set packer.gutter=6666e66666
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
