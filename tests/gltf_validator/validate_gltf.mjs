// Runs the Khronos glTF-Validator (npm package gltf-validator) over .glb files.
//
//   node tests/gltf_validator/validate_gltf.mjs a.glb b.glb ...
//
// Prints each report's counts and every message; exits 1 if any file has an error
// (warnings, infos and hints are printed but pass), 2 on usage or setup problems.
// The package is looked up in $SOLID_GLTF_VALIDATOR_DIR (a node_modules folder),
// else in node_modules beside this script; install it with
//   npm ci --prefix tests/gltf_validator
import { readFile } from 'node:fs/promises';
import { createRequire } from 'node:module';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const modules = process.env.SOLID_GLTF_VALIDATOR_DIR || path.join(here, 'node_modules');
const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node validate_gltf.mjs FILE.glb...');
  process.exit(2);
}

let validator;
try {
  validator = createRequire(import.meta.url)(path.join(modules, 'gltf-validator'));
} catch (e) {
  console.error(`cannot load gltf-validator from ${modules}: ${e.message}`);
  process.exit(2);
}

const severities = ['error', 'warning', 'info', 'hint'];
let failed = false;
for (const file of files) {
  const report = await validator.validateBytes(new Uint8Array(await readFile(file)), {
    uri: path.basename(file),
    maxIssues: 1000,
  });
  const issues = report.issues;
  console.log(`${file}: validator ${report.validatorVersion}: ${issues.numErrors} errors, ` +
              `${issues.numWarnings} warnings, ${issues.numInfos} infos, ${issues.numHints} hints`);
  for (const m of issues.messages) {
    console.log(`  ${severities[m.severity] ?? m.severity}\t${m.code}\t${m.pointer ?? ''}\t${m.message}`);
  }
  if (issues.numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
