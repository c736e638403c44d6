// The mesh stream's decoding rate where the web client runs it (the library's Web Worker runs
// viewers/web/stream_decoder.js over stream_decoder.wasm, the C++ decoder compiled to
// WebAssembly; node runs the same module here, V8 as chromium's): for each folder written by
// `meshmux convert IN -o OUT`, the base's vertices and faces are read from the package's base
// .glb (viewers/web/tests/node_package.mjs), every mesh chunk is applied in stored order, best of
// five runs, and the decoded state's digests are checked against report.json's stream_digests
// (the encoder's).
// usage: node bench/decode_rate.mjs OUT [OUT ...]      (prints a markdown table; exit 1 on a
//        digest mismatch or a decoding error)
import fs from 'node:fs';
import path from 'node:path';

import { applyChunk, freeStates, freshStates, readPackage } from '../viewers/web/tests/node_package.mjs';

let failed = false;
console.log('| model | meshes | splits | new triangles | best of 5 (ms) | M triangles/s | digests |');
console.log('|---|---:|---:|---:|---:|---:|---|');
for (const out of process.argv.slice(2)) {
  const name = path.basename(path.resolve(out));
  const { bytes, table, bases } = readPackage(path.join(out, 'model.mmxp'));
  if (!bases) { console.log(`| ${name} | – | – | – | – | – | the base is the whole model |`); continue; }
  const chunks = table.chunks.filter((c) => c.kind === 'mesh');
  let best = Infinity, states = null, faces = 0, splits = 0;
  for (const c of chunks) for (const p of c.parts) faces += p.face_end - p.face_begin, splits += p.vertex_end - p.vertex_begin;
  try {
    for (let run = 0; run < 5; run++) {
      if (states) freeStates(states);
      states = freshStates(table, bases);
      const t0 = performance.now();
      for (const c of chunks) applyChunk(states, bytes, c);
      best = Math.min(best, performance.now() - t0);
    }
  } catch (e) {
    console.log(`| ${name} | ${table.meshes.length} | ${splits} | ${faces} | – | – | decoding failed: ${e.message} |`);
    failed = true;
    continue;
  }
  const report = JSON.parse(fs.readFileSync(path.join(out, 'report.json'), 'utf8'));
  const digests = states.map((s) => s.digest());
  const same = JSON.stringify(digests) === JSON.stringify(report.stream_digests);
  if (!same) failed = true;
  console.log(`| ${name} | ${table.meshes.length} | ${splits} | ${faces} | ${best.toFixed(1)} | ${(faces / best / 1000).toFixed(2)} | ${same ? 'equal the encoder\'s' : 'DIFFER'} |`);
}
process.exitCode = failed ? 1 : 0;
