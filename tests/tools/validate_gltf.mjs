// Validates one .gltf/.glb with Khronos' gltf-validator and prints its JSON report.
// Exit 0 when the file has no errors, 1 when it has, 2 when it could not be read.
import { createRequire } from 'module';
import fs from 'fs';
import path from 'path';

const require = createRequire(import.meta.url);
const validator = require('gltf-validator');

const file = process.argv[2];
if (!file) {
  console.error('usage: node validate_gltf.mjs FILE');
  process.exit(2);
}
let data;
try {
  data = new Uint8Array(fs.readFileSync(file));
} catch (e) {
  console.error(`validate_gltf: ${file}: ${e.message}`);
  process.exit(2);
}
const dir = path.dirname(file);
validator
  .validateBytes(data, {
    uri: path.basename(file),
    maxIssues: 200,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.join(dir, decodeURIComponent(uri)), (err, d) =>
          err ? reject(err.toString()) : resolve(new Uint8Array(d)));
      }),
  })
  .then((report) => {
    console.log(JSON.stringify(report, null, 1));
    process.exit(report.issues.numErrors > 0 ? 1 : 0);
  })
  .catch((e) => {
    console.error(`validate_gltf: ${file}: ${e}`);
    process.exit(2);
  });
