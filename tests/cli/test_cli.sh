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
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
