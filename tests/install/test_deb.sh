#!/usr/bin/env bash
# Builds the .deb from the build folder (cpack), checks its metadata (Debian 12 runtime libraries
# as Depends, man page, FHS layout), unpacks it into a scratch root (dpkg -x) and runs the bundled
# example, --version, configs and the Python module from an empty folder away from the build tree.
# Usage: test_deb.sh BUILD_DIR PYTHON. Exits 77 (skipped) without dpkg-deb/dpkg-shlibdeps.
set -euo pipefail
build=$(readlink -f "$1"); python=$2
for t in dpkg-deb dpkg-shlibdeps cpack; do
  command -v $t >/dev/null || { echo "skipped: $t not found (scripts/install-deps.sh installs dpkg-dev)"; exit 77; }
done
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
cpack -G DEB --config "$build/CPackConfig.cmake" -B "$work/pkg" > "$work/cpack.log" 2>&1 ||
  { cat "$work/cpack.log"; fail "cpack"; }
deb=$(ls "$work"/pkg/texdefrag_*.deb)
dpkg-deb -f "$deb" Depends > "$work/depends"
cat "$work/depends"
for d in libc6 libstdc++6 libopenimageio2.4 python3-numpy; do
  grep -q "$d" "$work/depends" || fail "Depends lacks $d"
done
dpkg-deb -c "$deb" | awk '{print $6}' > "$work/files"
for f in ./usr/bin/texdefrag ./usr/lib/texdefrag/plugins/texdefrag_packers_shelf.so ./usr/share/texdefrag/configs/best.json \
         ./usr/share/texdefrag/configs/ablations/arap.json ./usr/share/doc/texdefrag/README.md \
         ./usr/share/man/man1/texdefrag.1.gz ./usr/lib/cmake/texdefrag/texdefragConfig.cmake \
         ./usr/include/texdefrag/stage/registry.h ./usr/lib/python3/dist-packages/texdefrag/__init__.py \
         ./usr/share/texdefrag/examples/building/building.obj; do
  grep -qx "$f" "$work/files" || fail "package lacks $f"
done
grep -q "configs/bad" "$work/files" && fail "package ships configs/bad"
zcat "$build/man/texdefrag.1.gz" | grep -q '^\.SH' || fail "man page has no sections"

dpkg -x "$deb" "$work/root"
root="$work/root/usr"
mkdir "$work/empty" && cd "$work/empty"
env -u TEXDEFRAG_PLUGIN_PATH "$root/bin/texdefrag" --version | grep -q "^prefix: $root " || fail "--version prefix is not the unpacked root"
"$root/bin/texdefrag" configs | grep -q '^\* best ' || fail "configs from the package"
cp -r "$root/share/texdefrag/examples/building" model
env -u TEXDEFRAG_PLUGIN_PATH "$root/bin/texdefrag" run -q model/building.obj -o out
test -s out/building.obj -a -s out/building.report.json || fail "no output from the packaged run"
grep -q "\"config_origin\": \"$root/share/texdefrag/configs/best.json\"" out/building.report.json ||
  fail "the packaged run did not use the packaged best.json"
"$root/bin/texdefrag" eval model/building.obj out/building.obj > /dev/null || fail "eval from the package"
# The build tree is nowhere in the run: every stage module came from the unpacked root.
"$root/bin/texdefrag" plugins --json | "$python" -c '
import json, sys
root = sys.argv[1]
for s in json.load(sys.stdin):
    assert s["source"] == "framework" or s["source"].startswith(root + "/lib/texdefrag/plugins/"), s["source"]
' "$root"
PYTHONPATH="$root/lib/python3/dist-packages" "$python" -c '
import sys, texdefrag
assert texdefrag.__file__.startswith(sys.argv[1]), texdefrag.__file__
assert texdefrag._t.install_root() == sys.argv[1], texdefrag._t.install_root()
assert "best" in texdefrag.configs()
r = texdefrag.run("model/building.obj", "out_py", config="repack")
assert r.report["output_stats"]["faces"] == r.report["input_stats"]["faces"]
' "$root"
echo "deb: ok ($(basename "$deb"), $(stat -c %s "$deb") bytes)"
