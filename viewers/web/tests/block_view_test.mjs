// A block package played by view, without a browser (block_view.js over the WebAssembly
// decoder in node), on a package converted here from --model (a mesh big enough for blocks):
//   1. BlockMeshState takes random dependency-closed sets of blocks in random orders: the page's
//      buffers built from its changes (as StreamMesh.applyChanges takes them) equal its whole
//      buffers and hold the same triangles as a plain decoder given those blocks in block order
//      (in block order, its digest is that decoder's: the digest counts faces in the order
//      applied);
//   2. dropping blocks (rebuild) returns the earlier state: the triangles of the blocks kept as
//      they were when only those were held, the digest of those blocks in block order;
//   3. a block without its dependency, a block twice, a block past the page's capacity: refused
//      naming the block, nothing applied;
//   4. planBlocks for a moving point of interest under a budget: faces held never above the
//      budget, every block after its dependencies, the region looked at refined to the
//      tolerance, and detail left behind dropped to make room for the next region;
//   5. blocks a completion cut off are not held from the start and their error counts.
// usage: node block_view_test.mjs --meshmux BIN --work DIR --model FILE
// Exit: 0 pass, 1 fail, 77 skipped (no renderer or WebAssembly decoder).
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';

import { BlockMeshState, blockChildren, heldFromStart, isEmptyBlock, planBlocks } from '../block_view.js';
import { opt, skip } from './harness.mjs';
import { decoder, freeStates, freshStates, readPackage } from './node_package.mjs';

const meshmux = opt('--meshmux'), work = opt('--work'), model = opt('--model');
if (!meshmux || !work || !model) {
  console.error('usage: node block_view_test.mjs --meshmux BIN --work DIR --model FILE');
  process.exit(2);
}
fs.rmSync(work, { recursive: true, force: true });
fs.mkdirSync(work, { recursive: true });
const out = path.join(work, 'out');
const converted = spawnSync(meshmux, ['convert', model, '-o', out, '-q'], { encoding: 'utf8' });
assert.equal(converted.status, 0, converted.stderr);
if (!fs.existsSync(path.join(out, 'model.mmxp'))) skip('convert wrote no package here (no offscreen renderer)');
const { bytes, table, bases } = readPackage(path.join(out, 'model.mmxp'));
const mi = table.meshes.findIndex((d) => d.blocks.length > 0);
assert.ok(mi >= 0, 'the model converts to a block package');
const desc = table.meshes[mi], blocks = desc.blocks, base = bases[mi];

// Each block's part: its bytes in the package (stored once, by the part naming it).
const partOf = new Map();
for (const c of table.chunks) {
  if (c.kind !== 'mesh') continue;
  let at = c.offset;
  for (const p of c.parts) {
    if (p.mesh === mi && p.block >= 0) partOf.set(p.block, bytes.subarray(at, at + p.bytes));
    at += p.bytes;
  }
}
const sent = blocks.map((_, k) => partOf.has(k));
// Blocks that send nothing (wholly in the base) are held from the start.
const empty = blocks.flatMap((b, k) => (isEmptyBlock(b) ? [k] : []));
console.log(`mesh ${mi}: ${blocks.length} blocks (${partOf.size} sent), ${desc.faces} faces, base ${desc.base_faces}`);

// xorshift32, seeded: the same sets every run.
let seed = 0x2545f491;
const random = () => { seed ^= seed << 13; seed ^= seed >>> 17; seed ^= seed << 5; return (seed >>> 0) / 4294967296; };

// A random dependency-closed set of about `share` of the sent blocks, as a random order in
// which each block comes after its dependencies.
function closedOrder(share, start = []) {
  const held = new Set([...empty, ...start]), order = [];
  const goal = Math.round(share * partOf.size);
  while (held.size - empty.length < goal) {
    const ready = [];
    blocks.forEach((b, k) => { if (sent[k] && !held.has(k) && b.deps.every((d) => held.has(d))) ready.push(k); });
    if (!ready.length) break;
    const k = ready[Math.floor(random() * ready.length)];
    held.add(k);
    order.push(k);
  }
  return order;
}

const full = { capacityVertices: desc.vertices, capacityFaces: desc.faces };
const fresh = (caps = full) => new BlockMeshState(decoder, desc, mi, base, { quantized: true, origin: [0, 0, 0], step: 1, ...caps });

// The page's buffers as StreamMesh.applyChanges builds them from a state's changes.
class Page {
  constructor(state) {
    const w = state.whole();
    Object.assign(this, { position: w.position, indices: w.indices, vertices: w.vertices, faces: w.faces });
  }

  take(c) {
    assert.equal(c.v0, this.vertices, 'changes start at the page\'s vertex count');
    assert.equal(c.f0, this.faces, 'changes start at the page\'s face count');
    this.position.set(c.position, 3 * c.v0);
    this.indices.set(c.appended, 3 * c.f0);
    for (let i = 0; i < c.moved.length; i += 2) this.indices[c.moved[i]] = c.moved[i + 1];
    this.vertices = c.vn;
    this.faces = c.nf;
  }
}

// The triangles of buffers as sorted position triples (a multiset, independent of numbering),
// degenerate faces dropped (they draw nothing).
function triangles(position, indices, faces) {
  const out = [];
  for (let f = 0; f < faces; f++) {
    const a = indices[3 * f], b = indices[3 * f + 1], c = indices[3 * f + 2];
    if (a === b || b === c || a === c) continue;
    const p = [a, b, c].map((v) => `${position[3 * v]},${position[3 * v + 1]},${position[3 * v + 2]}`);
    // Rotated to start at the least (winding kept).
    const r = p.indexOf([...p].sort()[0]);
    out.push([p[r], p[(r + 1) % 3], p[(r + 2) % 3]].join('|'));
  }
  return out.sort();
}

// A plain decoder given blocks in block order: its digest and triangles.
function plain(set) {
  const [s] = freshStates({ meshes: [desc] }, [base]);
  for (const k of [...set].sort((a, b) => a - b)) {
    const b = blocks[k], part = partOf.get(k);
    s.applyBlockSplits(part, 0, part.length, k, b.vertex_end - b.vertex_begin, b.face_end - b.face_begin);
  }
  const position = new Float32Array(3 * s.vertices);
  const c = s.changes(0, 0, true, [0, 0, 0], 1);
  position.set(c.position);
  const result = { digest: s.digest(), triangles: triangles(position, s.indices.slice(), s.faces) };
  freeStates([s]);
  return result;
}

// 1. Random closed sets in random orders.
for (const share of [0.15, 0.5, 1]) {
  const state = fresh(), page = new Page(state), order = closedOrder(share);
  for (const k of order) page.take(state.apply(k, partOf.get(k).slice()));
  const w = state.whole(), p = plain(order);
  assert.deepEqual(page.position.subarray(0, 3 * w.vertices), w.position.subarray(0, 3 * w.vertices), 'page vertices from the changes');
  assert.deepEqual(page.indices.subarray(0, 3 * w.faces), w.indices.subarray(0, 3 * w.faces), 'page faces from the changes');
  const t = triangles(w.position, w.indices, w.faces);
  assert.equal(t.length, p.triangles.length, 'triangles held');
  assert.ok(t.every((x, i) => x === p.triangles[i]), 'the page draws the plain decoder\'s triangles');
  // In block order, the state itself (digest: faces in the order applied) is the plain one's.
  const ordered = fresh();
  for (const k of [...order].sort((a, b) => a - b)) ordered.apply(k, partOf.get(k).slice());
  assert.equal(ordered.digest(), p.digest, `${order.length} blocks in block order: the plain decoder's digest`);
  ordered.free();
  console.log(`closed set of ${order.length} blocks in a random order (${w.faces} faces, ${w.vertices} slots of ${desc.vertices} stream vertices): the plain decoder's triangles`);
  state.free();
}

// 2. Dropping returns the earlier state.
{
  const state = fresh(), first = closedOrder(0.3);
  for (const k of first) state.apply(k, partOf.get(k).slice());
  const before = plain(first).digest, w0 = state.whole(), t0 = triangles(w0.position, w0.indices, w0.faces);
  const more = closedOrder(0.8, first);
  for (const k of more) state.apply(k, partOf.get(k).slice());
  assert.notEqual(state.digest(), before, 'more blocks change the state');
  const w = state.rebuild(first);
  assert.equal(state.digest(), before, 'dropping the later blocks: the digest of the earlier blocks (in block order)');
  assert.deepEqual(triangles(w.position, w.indices, w.faces), t0, 'dropping the later blocks: the earlier triangles');
  assert.equal(w.faces, w0.faces);
  // And refining again from there takes the same blocks as before.
  const page = new Page(state);
  for (const k of more) page.take(state.apply(k, partOf.get(k).slice()));
  console.log(`dropped ${more.length} of ${first.length + more.length} blocks: the earlier state (digest, ${t0.length} triangles); refined again`);
  state.free();
}

// 3. Refusals, naming the block.
{
  const state = fresh();
  const child = blocks.findIndex((b, k) => sent[k] && b.deps.some((d) => !empty.includes(d)));
  assert.throws(() => state.apply(child, partOf.get(child).slice()), new RegExp(`block ${child} depends on block \\d+, which is not held`));
  const root = blocks.findIndex((b, k) => sent[k] && b.deps.every((d) => empty.includes(d)));
  state.apply(root, partOf.get(root).slice());
  const d = state.digest();
  assert.throws(() => state.apply(root, partOf.get(root).slice()), new RegExp(`block ${root} is held already`));
  assert.equal(state.digest(), d, 'a refused block changes nothing');
  state.free();
  const small = fresh({ capacityVertices: desc.base_vertices + 1, capacityFaces: desc.base_faces + 1 });
  assert.throws(() => small.apply(root, partOf.get(root).slice()), new RegExp(`block ${root} would hold .* past the page's`));
  small.free();
  assert.throws(() => fresh().rebuild([child]), new RegExp(`block ${child} is kept but not held`));
  console.log('a block without its dependency, twice, past the capacity: refused by name');
}

// 4. The choice under a budget for a point of interest moving across the mesh. Pixels per
// unit of error fall with the distance from the point to a block's box (a camera close to the
// surface there); the area is the box's, larger near the point.
{
  const { children, childError } = blockChildren(blocks);
  let budget = desc.faces;
  const lo = [0, 1, 2].map((a) => Math.min(...blocks.map((b) => b.box[a]))), hi = [0, 1, 2].map((a) => Math.max(...blocks.map((b) => b.box[3 + a])));
  const span = Math.max(...[0, 1, 2].map((a) => hi[a] - lo[a]));
  const tolerance = 1;
  let poi;
  const distance = (b) => Math.hypot(...[0, 1, 2].map((a) => Math.max(b.box[a] - poi[a], 0, poi[a] - b.box[3 + a])));
  // A close-up: 10^5 pixels per diagonal at the point (a hundredth of the model across 1000
  // pixels), falling off with the distance as a perspective camera's.
  const scale = (m, k) => { const d = distance(blocks[k]); return { pixels: 1e5 / (1 + (100 * d) / span), area: 1e6 / (1 + (100 * d) / span) ** 2 }; };
  let held, faces, vertices, peak, evictions, taken;
  const reset = () => { held = new Set(empty); faces = desc.base_faces; vertices = desc.base_vertices; peak = faces; evictions = taken = 0; };
  const view = () => [{ blocks, children, childError, held, pending: new Set(), sent, bytes: blocks.map((_, k) => (partOf.get(k) || []).length),
    faces, vertices, capacityFaces: budget, capacityVertices: desc.base_vertices + budget }];
  const settle = () => {
    for (let step = 0; step < 10000; step++) {
      const plan = planBlocks(view(), faces, budget, scale, { tolerance });
      for (const e of plan.evict) {
        for (const k of e.blocks) {
          for (const j of children[k]) assert.ok(!held.has(j), `block ${k} dropped while block ${j}, which depends on it, is held`);
          held.delete(k);
          faces -= blocks[k].face_end - blocks[k].face_begin;
          vertices -= blocks[k].vertex_end - blocks[k].vertex_begin;
          evictions++;
        }
      }
      for (const f of plan.fetch) {
        for (const d of blocks[f.block].deps) assert.ok(held.has(d), `block ${f.block} chosen before block ${d}, which it depends on`);
        held.add(f.block);
        faces += blocks[f.block].face_end - blocks[f.block].face_begin;
        vertices += blocks[f.block].vertex_end - blocks[f.block].vertex_begin;
        taken++;
      }
      assert.ok(faces <= budget, `${faces} faces held, over the budget of ${budget}`);
      peak = Math.max(peak, faces);
      if (!plan.fetch.length && !plan.evict.length) return plan.error;
    }
    throw new Error('the choice does not settle');
  };
  const near = (r) => [0, 1, 2].map((a) => lo[a] + r[a] * (hi[a] - lo[a]));
  // What each region needs alone, without a budget; the budget then holds either one and a
  // fifth more, not both (the second must make room).
  const alone = [0.2, 0.8].map((x) => { reset(); poi = near([x, 0.5, 0.5]); settle(); return faces; });
  reset();
  const both = (() => { poi = near([0.2, 0.5, 0.5]); settle(); poi = near([0.8, 0.5, 0.5]); settle(); return faces; })();
  budget = Math.round(1.2 * Math.max(...alone));
  assert.ok(budget < both, `the regions alone need ${alone.join(' and ')} faces, both ${both}: a budget of ${budget} holds both`);
  reset();
  poi = near([0.2, 0.5, 0.5]);
  settle();
  // The region looked at: every block near the point is held or below the tolerance.
  const unrefined = () => blocks.filter((b, k) => sent[k] && !held.has(k) && distance(b) < 0.05 * span && b.error * scale(0, k).pixels > tolerance && b.deps.every((d) => held.has(d)));
  assert.equal(unrefined().length, 0, 'the region looked at is refined to the tolerance');
  const first = new Set(held);
  poi = near([0.8, 0.5, 0.5]);
  settle();
  assert.equal(unrefined().length, 0, 'the next region is refined to the tolerance');
  const left = [...first].filter((k) => !held.has(k)).length;
  assert.ok(evictions > 0 && left > 0, 'detail left behind was dropped to make room');
  console.log(`choice under a budget of ${budget} faces (${desc.faces} in all): ${taken} blocks taken, ${evictions} dropped, peak ${peak} faces; both regions refined to ${tolerance} px`);
}
// 5. A completion that cut the parts short (stream/format.h "Blocks": the blocks after it are
// sent by no part and end where they begin): those blocks are not held from the start, unlike
// the ones wholly in the base, and their error still counts on screen, though none can come.
{
  const sentBlocks = blocks.flatMap((b, k) => (sent[k] ? [k] : []));
  const cut = sentBlocks[Math.floor(sentBlocks.length / 2)];
  const cutBlocks = blocks.map((b, k) => (k > cut ? { ...b, vertex_begin: b.vertex_end, face_begin: b.face_end } : b));
  const cutSent = sent.map((x, k) => x && k <= cut);
  const start = heldFromStart(cutBlocks, cutSent);
  assert.deepEqual([...heldFromStart(blocks, sent)].sort((a, b) => a - b), empty, 'without a cut: the blocks wholly in the base');
  for (let k = cut + 1; k < blocks.length; k++) assert.ok(!start.has(k), `block ${k}, cut off, is not held from the start`);
  // Everything sent held: what is left is the cut blocks' error, not zero.
  const held = new Set([...start, ...sentBlocks.filter((k) => k <= cut)]);
  const { children, childError } = blockChildren(cutBlocks);
  const plan = planBlocks([{ blocks: cutBlocks, children, childError, held, pending: new Set(), sent: cutSent, bytes: blocks.map(() => 1),
    faces: desc.faces, vertices: desc.vertices, capacityFaces: desc.faces, capacityVertices: desc.vertices }], desc.faces, desc.faces,
    () => ({ pixels: 1e5, area: 1 }));
  assert.equal(plan.fetch.length, 0, 'nothing after the cut can be fetched');
  const left = Math.max(...cutBlocks.filter((b, k) => k > cut && b.deps.every((d) => held.has(d))).map((b) => b.error * 1e5));
  assert.ok(plan.error > 0 && plan.error === left, `the screen error left is the cut blocks' (${plan.error} px)`);
  console.log(`a completion after block ${cut}: ${blocks.length - cut - 1} blocks cut off, not held; ${plan.error.toFixed(1)} px left on screen`);
}
console.log('PASS');
