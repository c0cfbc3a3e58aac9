#!/usr/bin/env bash
# The browser check skips with a message where Chromium cannot start (issue 17): check_report.js
# with a Chromium that does not exist, and with one that exits at once (/bin/false), must exit 77
# and say why; the test itself skips (77) where Node.js or playwright-core is absent.
# Usage: test_report_browser_skip.sh SOURCE_DIR WORK_DIR
set -uo pipefail
src=$1 work=$2
modules="$src/tools/node/node_modules"
command -v node >/dev/null || { echo "SKIPPED: node not found (scripts/install-deps.sh)"; exit 77; }
[ -d "$modules/playwright-core" ] || { echo "SKIPPED: $modules/playwright-core absent (run scripts/install-npm.sh)"; exit 77; }
rm -rf "$work" && mkdir -p "$work/report"
echo '<!DOCTYPE html><html><body>no viewer</body></html>' > "$work/report/index.html"
for chromium in "$work/no-such-chromium" /bin/false; do
  out=$(TEXDEFRAG_CHROMIUM="$chromium" NODE_PATH="$modules" node "$src/eval/report/browser/check_report.js" "$work/report" 2>&1)
  rc=$?
  if [ "$rc" -ne 77 ] || ! grep -q "SKIPPED" <<<"$out"; then
    echo "FAIL: with TEXDEFRAG_CHROMIUM=$chromium: exit $rc, expected 77 with a SKIPPED message: $out"
    exit 1
  fi
  echo "$chromium: $out"
done
echo "test_report_browser_skip: passed"
