#!/usr/bin/env bash
# The HTML report opened in headless Chromium: defragment the bundled example (configs/best.json),
# write its report, and run eval/report/browser/check_report.js on it (viewports not blank, input
# and output differ where they should, no console error, thumbnails written).
# Usage: test_report_browser.sh TEXDEFRAG_EXE SOURCE_DIR WORK_DIR. Exit 77 (skip) with a message
# where Node.js, the npm packages (scripts/install-npm.sh) or Chromium are absent or cannot start.
set -euo pipefail
exe=$1 src=$2 work=$3
modules="$src/tools/node/node_modules"
command -v node >/dev/null || { echo "SKIPPED: node not found (scripts/install-deps.sh)"; exit 77; }
[ -d "$modules/playwright-core" ] || { echo "SKIPPED: $modules/playwright-core absent (run scripts/install-npm.sh)"; exit 77; }
[ -f "$src/tools/node/build/three-bundle.js" ] || { echo "SKIPPED: three.js bundle absent (run scripts/install-npm.sh)"; exit 77; }
[ -x /usr/bin/chromium ] || [ -n "${TEXDEFRAG_CHROMIUM:-}" ] || { echo "SKIPPED: /usr/bin/chromium not installed (scripts/install-deps.sh)"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
"$exe" run --config "$src/configs/best.json" "$src/examples/building/building.obj" -o "$work/best" --quiet
"$exe" report --input "$src/examples/building/building.obj" --output "best=$work/best/building.obj" \
  --samples 20000 --chunk-faces 2000 -o "$work/report"
set +e
NODE_PATH="$modules" node "$src/eval/report/browser/check_report.js" "$work/report"
rc=$?
set -e
[ "$rc" -eq 0 ] || exit "$rc"
# The screenshots became the thumbnails.
for f in building.png building_charts.png; do
  [ -s "$work/report/thumbs/$f" ] || { echo "FAIL: thumbs/$f not written"; exit 1; }
done
echo "test_report_browser: passed"
