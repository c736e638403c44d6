// The web client's mesh decoder (stream_decoder.js over stream_decoder.wasm: the C++ decoder
// compiled to WebAssembly, what the library's worker runs) in node, on a package converted here
// (the built-in sample, or --model FILE):
//   1. the whole stream decodes to exactly the encoder's state (report.json's stream_digests);
//   2. 1,000 copies with a mesh part damaged (bytes flipped, zeroed or swapped, seeded) are each
//      either refused with an Error naming the mesh, or decode to a state whose every index
//      names a vertex held; nothing else is thrown and nothing runs away (each copy under 5 s).
// usage: node decoder_test.mjs --meshmux BIN --work DIR [--model FILE] [--copies 1000]
// Exit: 0 pass, 1 fail, 77 skipped (no renderer: convert wrote no package).
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';

import { opt, skip } from './harness.mjs';
import { applyChunk, freeStates, freshStates, readPackage } from './node_package.mjs';

const meshmux = opt('--meshmux'), work = opt('--work'), copies = Number(opt('--copies', '1000'));
if (!meshmux || !work) {
  console.error('usage: node decoder_test.mjs --meshmux BIN --work DIR [--model FILE] [--copies 1000]');
  process.exit(2);
}
fs.rmSync(work, { recursive: true, force: true });
fs.mkdirSync(work, { recursive: true });
let input = opt('--model');
if (!input) {
  input = path.join(work, 'sample.glb');
  assert.equal(spawnSync(meshmux, ['sample', '-o', input, '-q']).status, 0);
}
const out = path.join(work, 'out');
const converted = spawnSync(meshmux, ['convert', input, '-o', out, '-q'], { encoding: 'utf8' });
assert.equal(converted.status, 0, converted.stderr);
if (!fs.existsSync(path.join(out, 'model.mmxp'))) skip('convert wrote no package here (no offscreen renderer)');

const { bytes, table, bases } = readPackage(path.join(out, 'model.mmxp'));
assert.ok(bases, 'the sample streams mesh refinements');
const chunks = table.chunks.filter((c) => c.kind === 'mesh' && c.parts.length);
assert.ok(chunks.length > 0);

// The view table carries every texture level's width, the base's first (what a client re-reading
// the table for a smaller canvas needs and no chunk holds), as report.json lists them.
if (table.view_table) {
  const shipped = JSON.parse(fs.readFileSync(path.join(out, 'report.json'), 'utf8')).texture_levels.shipped;
  assert.deepEqual(table.view_table.texture_widths, shipped.map((l) => l.width), 'view_table.texture_widths');
}

// 1. The whole stream, to the encoder's state.
const states = freshStates(table, bases);
for (const c of chunks) applyChunk(states, bytes, c);
const expected = JSON.parse(fs.readFileSync(path.join(out, 'report.json'), 'utf8')).stream_digests;
assert.deepEqual(states.map((s) => s.digest()), expected, 'decoded state digests');
freeStates(states);
console.log(`whole stream: ${chunks.length} mesh chunks, ${states.length} meshes, digests equal the encoder's`);

// 2. Damaged copies (xorshift32, seeded: the same copies every run).
let seed = 0x9e3779b9;
const random = (n) => {
  seed ^= seed << 13; seed >>>= 0; seed ^= seed >>> 17; seed ^= seed << 5; seed >>>= 0;
  return seed % n;
};
const parts = chunks.flatMap((c) => {
  let at = c.offset;
  return c.parts.map((p) => { const r = { begin: at, end: at + p.bytes }; at += p.bytes; return r; });
});
let refused = 0, decoded = 0;
for (let k = 0; k < copies; k++) {
  const copy = bytes.slice(), part = parts[random(parts.length)], size = part.end - part.begin;
  const at = part.begin + random(size), kind = k % 3;
  if (kind === 0) copy[at] ^= 1 + random(255);                                // a byte changed
  else if (kind === 1) copy.fill(0, at, Math.min(part.end, at + 1 + random(16)));  // a run zeroed
  else { const other = part.begin + random(size); [copy[at], copy[other]] = [copy[other], copy[at]]; copy[at] ^= 0x5a; }
  const t0 = performance.now();
  const s = freshStates(table, bases);
  try {
    for (const c of chunks) applyChunk(s, copy, c);
    decoded++;
    for (const m of s) {
      const indices = m.indices, vertices = m.vertices;
      for (let i = 0; i < indices.length; i++) assert.ok(indices[i] < vertices, `copy ${k}: index past the vertices`);
    }
  } catch (e) {
    assert.ok(e instanceof Error && /^mesh \d+: /.test(e.message), `copy ${k}: ${e && e.stack ? e.stack : e}`);
    refused++;
  } finally {
    freeStates(s);
  }
  assert.ok(performance.now() - t0 < 5000, `copy ${k} took ${(performance.now() - t0).toFixed(0)} ms`);
}
console.log(`${copies} damaged copies: ${refused} refused with an Error naming the mesh, ${decoded} decoded to a valid state`);
console.log('PASS');
