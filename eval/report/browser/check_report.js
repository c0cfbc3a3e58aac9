#!/usr/bin/env node
// Opens a texdefrag HTML report (index.html, from the file system) in headless Chromium (Debian's
// /usr/bin/chromium, driven by playwright-core; no browser is ever downloaded), and for every model:
// waits for the viewer to load, checks that each view's viewport is not blank (pixel variance),
// that input and output differ where they should (chart colours of a defragmented output differ
// from the input's more than its texture does), and that the console shows no error. Screenshots
// of the viewer become the report's thumbnails (thumbs/<model>.png, thumbs/<model>_charts.png);
// the results are written to check.json.
//
// Usage: NODE_PATH=tools/node/node_modules node check_report.js REPORT_DIR [--models N]
// Exit: 0 all checks passed, 1 a check failed, 77 Chromium (or playwright-core) cannot start.
'use strict';
const fs = require('fs');
const os = require('os');
const path = require('path');

const SKIP = 77;
const CHROMIUM = process.env.TEXDEFRAG_CHROMIUM || '/usr/bin/chromium';
// WebGL on the CPU through ANGLE's SwiftShader. note: not --use-gl=swiftshader: Chromium 156
// (Debian 12, 2026-11) starts its GPU process with it, then restarts it, and the page's first
// WebGL context is lost (blank viewports).
const FLAGS = ['--headless', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--disable-gpu-sandbox', '--no-first-run', '--disable-background-networking', '--disable-component-update',
  '--disable-sync'];
const MIN_VARIANCE = 25;  // per-channel variance (8-bit levels^2) below which a viewport is blank

function skip(msg) {
  console.log('check_report: SKIPPED: ' + msg);
  process.exit(SKIP);
}

// Per viewport of the viewer canvas: mean and variance of RGB, and the mean absolute difference
// to the first (input) viewport. Runs in the page.
function viewportStats() {
  const TD = window.TD, m = TD.state.model;
  const c = document.getElementById('viewer-canvas');
  const t = document.createElement('canvas');
  t.width = c.width; t.height = c.height;
  const g = t.getContext('2d');
  g.drawImage(c, 0, 0);
  const cols = Math.min(m.views.length, 3);
  const cw = Math.floor(c.width / cols), ch = Math.floor(c.height / Math.ceil(m.views.length / cols));
  const cells = m.views.map(function (v, i) {
    const x = (i % cols) * cw + 3, y = Math.floor(i / cols) * ch + 3;
    return { key: v.key, label: v.label, too_large: v.too_large, charts: v.charts,
      data: g.getImageData(x, y, cw - 6, ch - 6).data };
  });
  return cells.map(function (cell) {
    const d = cell.data, n = d.length / 4;
    let s = 0, s2 = 0, diff = 0;
    const ref = cells[0].data;
    for (let i = 0; i < d.length; i += 4)
      for (let k = 0; k < 3; ++k) { s += d[i + k]; s2 += d[i + k] * d[i + k]; diff += Math.abs(d[i + k] - ref[i + k]); }
    const mean = s / (3 * n);
    return { key: cell.key, label: cell.label, too_large: cell.too_large, charts: cell.charts,
      mean: mean, variance: s2 / (3 * n) - mean * mean, diff_to_input: diff / (3 * n) };
  });
}

// A lost WebGL context draws nothing: wait for the browser to restore it, else say so (a lost
// context is not a blank model).
async function waitForContext(page, id) {
  try {
    await page.waitForFunction(function () { return !window.TD.state.contextLost; }, null, { timeout: 30000 });
  } catch (e) {
    throw new Error(id + ': the WebGL context was lost and not restored within 30 s (Chromium ' + CHROMIUM +
      ', flags ' + FLAGS.join(' ') + ')');
  }
}

async function main() {
  const args = process.argv.slice(2);
  const dir = args[0];
  const maxModels = args.indexOf('--models') >= 0 ? Number(args[args.indexOf('--models') + 1]) : Infinity;
  if (!dir || !fs.existsSync(path.join(dir, 'index.html'))) {
    console.error('usage: check_report.js REPORT_DIR [--models N] (REPORT_DIR/index.html must exist)');
    process.exit(2);
  }
  let chromium;
  try {
    ({ chromium } = require('playwright-core'));
  } catch (e) {
    skip('playwright-core not installed (run scripts/install-npm.sh): ' + e.message);
  }
  if (!fs.existsSync(CHROMIUM)) skip(CHROMIUM + ' not found (scripts/install-deps.sh installs chromium)');
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'texdefrag-chromium-'));
  let context;
  try {
    context = await chromium.launchPersistentContext(profile, {
      executablePath: CHROMIUM, headless: true, args: FLAGS, viewport: { width: 1400, height: 1000 }, timeout: 60000,
    });
  } catch (e) {
    fs.rmSync(profile, { recursive: true, force: true });
    skip('Chromium cannot start: ' + String(e.message).split('\n')[0]);
  }
  const problems = [];
  const consoleErrors = [];
  const results = { report: path.resolve(dir), chromium: CHROMIUM, models: [] };
  try {
    const page = context.pages()[0] || await context.newPage();
    page.on('console', function (msg) {
      if (msg.type() === 'error') consoleErrors.push(msg.text() + ' (' + (msg.location().url || '?') + ')');
    });
    page.on('pageerror', function (err) { consoleErrors.push('page error: ' + err.message); });
    const url = 'file://' + path.resolve(dir, 'index.html');
    await page.goto(url, { waitUntil: 'load' });
    const models = await page.evaluate(function () { return window.TD.manifest.models.map(function (m) { return m.id; }); });
    for (const id of models.slice(0, maxModels)) {
      const t0 = Date.now();
      await page.evaluate(function (id) { window.TD.showModel(id, 'texture'); }, id);
      await page.waitForFunction(function () { return window.TD.state.ready === true; }, null, { timeout: 300000 });
      // Textures decode asynchronously: wait until every image has arrived, then render.
      await page.waitForFunction(function () {
        const views = Object.values(window.TD.state.views);
        return views.every(function (v) {
          return Object.values(v.textures).every(function (t) { return t.image && t.image.complete && t.image.naturalWidth > 0; });
        });
      }, null, { timeout: 120000 });
      await waitForContext(page, id);
      await page.evaluate(function () { window.TD.render(); });
      const textured = await page.evaluate(viewportStats);
      const canvas = await page.$('#viewer-canvas');
      await canvas.screenshot({ path: path.join(dir, 'thumbs', id + '.png') });
      await page.evaluate(function () { window.TD.setMode('chart'); window.TD.render(); });
      const charts = await page.evaluate(viewportStats);
      await canvas.screenshot({ path: path.join(dir, 'thumbs', id + '_charts.png') });
      // Regions (when a configuration has a detector): every face of every view coloured by the
      // region of its input face, so outputs match the input's colouring more than their charts do.
      const hasRegions = await page.evaluate(function () {
        return window.TD.state.model.views.some(function (v) { return v.regions; });
      });
      let regions = null;
      if (hasRegions) {
        await page.evaluate(function () { window.TD.setMode('region'); window.TD.render(); });
        regions = await page.evaluate(viewportStats);
      }
      await page.evaluate(function () { window.TD.setMode('texture'); });
      const rec = { id: id, seconds: (Date.now() - t0) / 1000, textured: textured, charts: charts, regions: regions };
      results.models.push(rec);
      textured.forEach(function (v, i) {
        if (v.too_large) return;
        for (const [mode, s] of [['textured', v], ['charts', charts[i]]])
          if (!(s.variance > MIN_VARIANCE))
            problems.push(id + ' ' + v.label + ' (' + mode + '): blank viewport (variance ' + s.variance.toFixed(1) + ')');
        // A defragmented output: its chart colouring must differ from the input's more than its
        // texture does (same camera, so pixels are aligned).
        if (i > 0 && !textured[0].too_large && v.charts !== textured[0].charts &&
            !(charts[i].diff_to_input > v.diff_to_input))
          problems.push(id + ' ' + v.label + ': chart view differs from the input by ' + charts[i].diff_to_input.toFixed(2) +
            ', texture by ' + v.diff_to_input.toFixed(2) + ' (charts should differ more)');
        if (regions) {
          if (!(regions[i].variance > MIN_VARIANCE))
            problems.push(id + ' ' + v.label + ' (regions): blank viewport (variance ' + regions[i].variance.toFixed(1) + ')');
          if (i > 0 && !textured[0].too_large && v.charts !== textured[0].charts &&
              !(regions[i].diff_to_input < charts[i].diff_to_input))
            problems.push(id + ' ' + v.label + ': region view differs from the input by ' + regions[i].diff_to_input.toFixed(2) +
              ', chart view by ' + charts[i].diff_to_input.toFixed(2) + ' (regions come from the input: should differ less)');
        }
      });
      console.log('check_report: ' + id + ': ' + textured.map(function (v, i) {
        return v.label + ' var ' + v.variance.toFixed(0) + '/' + charts[i].variance.toFixed(0) +
          (i ? ' diff tex ' + v.diff_to_input.toFixed(1) + ' charts ' + charts[i].diff_to_input.toFixed(1) : '') +
          (regions ? ' regions var ' + regions[i].variance.toFixed(0) + (i ? ' diff ' + regions[i].diff_to_input.toFixed(1) : '') : '');
      }).join('; ') + ' (' + rec.seconds.toFixed(1) + ' s)');
    }
    const status = await page.evaluate(function () { return window.TD.state.errors; });
    for (const e of status) problems.push('viewer: ' + e);
  } catch (e) {
    problems.push('browser check failed: ' + e.message);
  } finally {
    await context.close();
    fs.rmSync(profile, { recursive: true, force: true });
  }
  for (const e of consoleErrors) problems.push('console error: ' + e);
  results.console_errors = consoleErrors;
  const thumbs = {};
  for (const m of results.models) thumbs[m.id] = m.id + '.png';
  fs.writeFileSync(path.join(dir, 'thumbs', 'thumbs.js'), 'TD.thumbs = ' + JSON.stringify(thumbs) + ';\n');
  results.problems = problems;
  fs.writeFileSync(path.join(dir, 'check.json'), JSON.stringify(results, null, 1));
  for (const p of problems) console.log('check_report: FAIL: ' + p);
  console.log('check_report: ' + results.models.length + ' models checked, ' + problems.length + ' problems');
  process.exit(problems.length ? 1 : 0);
}

main().catch(function (e) { console.error(e); process.exit(1); });
