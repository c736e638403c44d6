// The web client's mesh decoder (stream_decoder.js over stream_decoder.wasm: the C++ decoder
// compiled to WebAssembly, what the library's worker runs) in node, on a package converted here
// (the built-in sample, or --model FILE):
//   1. the whole stream decodes to exactly the encoder's state (report.json's stream_digests);
//   2. 1,000 copies with a mesh part damaged (bytes flipped, zeroed or swapped, seeded) are each
//      either refused with an Error naming the mesh, or decode to a state whose every index
//      names a vertex held; nothing else is thrown and nothing runs away (each copy under 5 s);
//   3. a block package's table with a damaged hierarchy (a cycle, a missing block, a box that is
//      not a number, ...) is refused by the reader's validation, naming the block.
// usage: node decoder_test.mjs --meshmux BIN --work DIR [--model FILE] [--copies 1000]
// Exit: 0 pass, 1 fail, 77 skipped (no renderer: convert wrote no package).
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';

import { rawTableOf, validateTable } from '../package_reader.js';
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

// 3. A block package (stream/format.h "Blocks"): damaged hierarchies in its table refused by the
// web reader's validation, naming the block, before anything is used.
if (table.meshes.some((m) => m.blocks.length > 0)) {
  const { raw, dataStart } = rawTableOf(bytes, zlib.inflateSync);  // the block index merged in
  const n = raw.meshes[0].blocks.length, k = Math.floor(n / 2);
  const partOf = (t, b) => t.chunks.flatMap((c) => c.parts || []).find((p) => p[4] === b);
  const cases = [
    ['a dependency cycle', (t) => { t.meshes[0].blocks[k][3] = [n - 1]; }, `blocks[${k}]: depends on block ${n - 1}, not an earlier one (a dependency cycle)`],
    ['a block on itself', (t) => { t.meshes[0].blocks[k][3] = [k]; }, 'not an earlier one'],
    ['a missing block', (t) => { t.meshes[0].blocks[k][3] = [0, n]; }, `blocks[${k}]: depends on block ${n}, which is missing`],
    ['a box of NaN (null)', (t) => { t.meshes[0].blocks[k][2][2] = null; }, `blocks[${k}]: box`],
    ['an infinite error', (t) => { t.meshes[0].blocks[k][1] = 'inf'; }, `blocks[${k}][1] (error)`],
    ['a part ending before its block', (t) => { const p = partOf(t, k); if (p) { p[1] = 0; p[2] = 0; } }, `blocks[${k}] ends at vertex 0`],
    ['blocks in a version 15 table', (t) => { t.version = 15; delete t.index; }, 'blocks in a version 15 package'],
  ];
  for (const [what, edit, expect] of cases) {
    const t = JSON.parse(JSON.stringify(raw));
    edit(t);
    assert.throws(() => validateTable(t, { fileSize: bytes.length, dataStart, fail: (m) => new Error(m) }),
      (e) => e instanceof Error && e.message.includes(expect), `${what}: not refused with "${expect}"`);
  }
  console.log(`block table: ${cases.length} damaged hierarchies refused by name`);
}
console.log('PASS');
