#!/usr/bin/env bash
# The build tree's texdefrag finds its modules and configurations relative to itself, from any
# working folder: --version, `configs`, `-c NAME` equal to `-c PATH`, the default configuration,
# and an unknown name as a configuration error (exit 2) listing the shipped names.
# Usage: test_layout.sh TEXDEFRAG_EXE
set -euo pipefail
bin=$(readlink -f "$1")
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
cd "$work"
fail() { echo "FAIL: $*"; exit 1; }

"$bin" --version > version.txt
for k in '^texdefrag [0-9]+\.[0-9]+\.[0-9]+$' '^revision: ' '^compiler: ' '^model formats: .*obj' '^features: ' '^prefix: /'; do
  grep -Eq "$k" version.txt || { cat version.txt; fail "--version lacks $k"; }
done

"$bin" configs > configs.txt
for n in best paper mmethod repack ablations/arap ablations/no_regions; do
  grep -Eq "^[* ] $n " configs.txt || { cat configs.txt; fail "configs does not list $n"; }
done
grep -q '^\* best ' configs.txt || fail "best is not marked as the default"
grep -q 'bad' configs.txt && fail "configs lists configs/bad"
root=$(sed -n 's/^prefix: \([^ ]*\) .*/\1/p' version.txt)
test "$("$bin" configs --paths | awk '$1 == "paper" {print $2}')" = "$root/share/texdefrag/configs/paper.json" ||
  fail "configs --paths: paper is not under $root/share/texdefrag/configs"

# A name and its file give the same effective configuration (the run report's "config").
model=$root/share/texdefrag/examples/building/building.obj
"$bin" run -q --no-write --report -c repack "$model" > by_name.json
"$bin" run -q --no-write --report -c "$root/share/texdefrag/configs/repack.json" "$model" > by_path.json
"$bin" run -q --no-write --report "$model" > default.json
"$bin" run -q --no-write --report -c best.json "$model" > best.json.json
python3 - <<'PY'
import json
a, b, d, e = (json.load(open(f)) for f in ("by_name.json", "by_path.json", "default.json", "best.json.json"))
assert a["config"] == b["config"], "-c repack differs from -c <path>/repack.json"
assert d["config"] == e["config"], "run without -c is not best"
assert d["config"] != a["config"], "best and repack have the same effective configuration"
assert d["config_origin"].endswith("share/texdefrag/configs/best.json"), d["config_origin"]
PY
"$bin" validate -c ablations/arap | grep -q ': ok$' || fail "validate -c ablations/arap"

# A local file wins over a shipped name; an unknown name is a configuration error listing the names.
cp "$root/share/texdefrag/configs/repack.json" ./paper
"$bin" run -q --no-write --report -c paper "$model" | python3 -c 'import json,sys; assert json.load(sys.stdin)["config_origin"] == "paper"'
set +e
"$bin" run -c no_such_config "$model" -o out 2> err.txt; rc=$?
set -e
test $rc -eq 2 || fail "unknown configuration name: exit $rc, expected 2"
grep -q "configuration 'no_such_config': no such file, and not a shipped configuration (ablations/angle_growing" err.txt ||
  { cat err.txt; fail "unknown configuration message"; }
test ! -e out || fail "output written for an unknown configuration"
echo "layout: ok"
