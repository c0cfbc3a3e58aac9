#!/usr/bin/env bash
# Installs the project's Node.js packages (tools/node/package.json, locked by package-lock.json)
# into tools/node/node_modules with `npm ci`. Node.js and npm come from scripts/install-deps.sh.
# playwright-core never downloads a browser (it drives the system Chromium); the variable below
# keeps any install hook from trying.
set -euo pipefail
cd "$(dirname "$0")/../tools/node"
if ! command -v npm >/dev/null; then
  echo "install-npm.sh: npm not found (run scripts/install-deps.sh first)" >&2
  exit 1
fi
export PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1
# note: --ignore-scripts, then esbuild's own hook only: 3d-tiles-tools' dependency better-sqlite3
# would otherwise compile SQLite from source (minutes on 2 cores; its prebuilt binary comes from
# GitHub, not the npm registry), and the b3dm/GLB commands the tests run never load it.
npm ci --no-audit --no-fund --loglevel=error --ignore-scripts
npm rebuild esbuild --no-audit --no-fund --loglevel=error
# three.js as one classic script for the HTML report (eval/report): tools/node/build/three-bundle.js.
npm run --silent build-three
