// Checks Kubernetes batch/v1 Job manifests offline against the Kubernetes API schema, as the
// npm package kubernetes-models ships it (generated from the API's OpenAPI document):
//   - types, formats, enums and required fields through the package's validate();
//   - unknown (say, misspelt) fields through TypeScript's excess-property check of the
//     manifest against the package's type declarations: the OpenAPI schema does not reject
//     them (no additionalProperties: false); the API server's strict field validation does.
//
//   node tests/farm/kubernetes/validate_job.mjs a.yaml b.yaml ...
//
// Prints one line per document ("FILE: document N: valid batch/v1 Job NAME") or its
// problems; exits 1 if any document is invalid, 2 on usage or setup problems. Install the
// packages with: npm ci --prefix tests/farm/kubernetes
import { readFileSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node validate_job.mjs FILE.yaml...');
  process.exit(2);
}
let YAML, ts, Job;
try {
  YAML = await import('yaml');
  ts = (await import('typescript')).default;
  ({ Job } = await import('kubernetes-models/batch/v1/Job'));
} catch (e) {
  console.error(`cannot load the packages from ${path.join(here, 'node_modules')}: ${e.message}`);
  process.exit(2);
}

// TypeScript's diagnostics for `const job: IJob = <manifest>`, compiled in memory as if the
// file lay beside this script, so that its import resolves to node_modules here.
function excessFields(manifest) {
  const name = path.join(here, '__manifest__.ts');
  const text = `import type { IJob } from "kubernetes-models/batch/v1/Job";\n` +
               `export const job: IJob = ${JSON.stringify(manifest, null, 2)};\n`;
  const options = {
    strict: true, noEmit: true, skipLibCheck: true, types: [],
    target: ts.ScriptTarget.ES2022, module: ts.ModuleKind.NodeNext, moduleResolution: ts.ModuleResolutionKind.NodeNext,
  };
  const host = ts.createCompilerHost(options);
  const { getSourceFile, fileExists, readFile } = host;
  host.getSourceFile = (file, language, ...rest) =>
    file === name ? ts.createSourceFile(file, text, language) : getSourceFile.call(host, file, language, ...rest);
  host.fileExists = (file) => file === name || fileExists.call(host, file);
  host.readFile = (file) => (file === name ? text : readFile.call(host, file));
  const program = ts.createProgram([name], options, host);
  return ts.getPreEmitDiagnostics(program).map((d) => ts.flattenDiagnosticMessageText(d.messageText, ' '));
}

let invalid = 0;
for (const file of files) {
  let documents;
  try {
    documents = YAML.parseAllDocuments(readFileSync(file, 'utf8'));
  } catch (e) {
    console.log(`${file}: ${e.message}`);
    invalid++;
    continue;
  }
  documents.forEach((document, n) => {
    const where = `${file}: document ${n + 1}`;
    const problems = document.errors.map((e) => e.message);
    const manifest = problems.length === 0 ? document.toJS() : null;
    if (manifest && (manifest.apiVersion !== 'batch/v1' || manifest.kind !== 'Job')) {
      problems.push(`not a batch/v1 Job (apiVersion ${manifest.apiVersion}, kind ${manifest.kind})`);
    }
    if (problems.length === 0) {
      try {
        new Job(manifest).validate();
      } catch (e) {
        problems.push(`schema: ${e.message}`);
      }
      for (const message of excessFields(manifest)) problems.push(`fields: ${message}`);
    }
    if (problems.length === 0) {
      console.log(`${where}: valid batch/v1 Job ${manifest.metadata?.name}`);
    } else {
      invalid++;
      for (const p of problems) console.log(`${where}: ${p}`);
    }
  });
}
process.exit(invalid > 0 ? 1 : 0);
