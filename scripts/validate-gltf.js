#!/usr/bin/env node
// Runs the Khronos glTF validator (npm gltf-validator, installed by scripts/install-npm.sh into
// tools/node/node_modules) on each .glb/.gltf given, loading external buffers and images relative
// to each file. Prints one JSON line per file: {"file", "errors", "warnings", "infos", "messages"}
// (messages: the first error and warning texts). Exit code: 0 when no file has an error, 1 when
// one has, 2 when the validator is not installed or a file cannot be read.
'use strict';
const fs = require('fs');
const path = require('path');

let validator;
try {
  validator = require(path.join(__dirname, '..', 'tools', 'node', 'node_modules', 'gltf-validator'));
} catch (e) {
  console.error('validate-gltf.js: gltf-validator not installed (run scripts/install-npm.sh)');
  process.exit(2);
}

async function validate(file) {
  const bytes = fs.readFileSync(file);
  const report = await validator.validateBytes(new Uint8Array(bytes), {
    uri: path.basename(file),
    maxIssues: 0,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, data) =>
          err ? reject(err.toString()) : resolve(new Uint8Array(data)));
      }),
  });
  const issues = report.issues;
  const messages = issues.messages
    .filter((m) => m.severity <= 1)
    .slice(0, 10)
    .map((m) => `${m.severity === 0 ? 'error' : 'warning'} ${m.code} ${m.pointer || ''}: ${m.message}`);
  return {file, errors: issues.numErrors, warnings: issues.numWarnings, infos: issues.numInfos, messages};
}

(async () => {
  let failed = false;
  for (const file of process.argv.slice(2)) {
    try {
      const r = await validate(file);
      console.log(JSON.stringify(r));
      if (r.errors > 0) failed = true;
    } catch (e) {
      console.log(JSON.stringify({file, errors: -1, messages: [String(e)]}));
      process.exit(2);
    }
  }
  process.exit(failed ? 1 : 0);
})();
