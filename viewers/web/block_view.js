// block_view.js — a block mesh refined by view (stream/format.h "Blocks"): the decoding state
// that takes block parts in any dependency-closed order and gives back what the page draws in
// compact buffers (BlockMeshState, run in the worker or on the page), and the choice of the
// next blocks for a camera under a triangle budget (planBlocks). After Ponchio and Dellepiane's
// Nexus (multiresolution patches refined front to back by projected error, coarsened to make
// room); the stream's blocks carry our vertex splits (stream/vsplit.h). Imports only the
// decoder wrapper (stream_decoder.js), so that it runs in a Worker, on the page and in node.

import { MeshDecoder } from './stream_decoder.js';

// ---- The decoding state ----------------------------------------------------------------------

// Whether block b sends nothing (stream/format.h "Blocks": a block no part names ends where it
// begins, wholly in the base): such a block is held from the start. A block the parts stop
// short of (a completion ended them) has a range and is never held.
export function isEmptyBlock(b) {
  return b.vertex_end === b.vertex_begin && b.face_end === b.face_begin;
}

// One block mesh's state, held in the page's budget: the decoder (stream/vsplit.h VsplitMesh in
// the WebAssembly module) with the base and the blocks applied so far, and per stream vertex its
// slot in the page's buffers. Block parts place their vertices at their stream numbers, which
// run to the full mesh's count; the page's buffers hold only what is resident: slots are given
// in the order vertices arrive (the base's first, as numbered), so the page's vertex buffer
// grows at its end as a chain's does and needs only the budget's capacity.
//   decoder: a Decoder (stream_decoder.js loadDecoder); desc: the validated table's mesh (its
//   blocks with their ranges); index: the mesh's number (messages); base: {qp, qn, qt, count,
//   faces: [Uint32Array]} (the base's quantized vertices and faces, as StreamMesh gives them);
//   quantized, origin, step: how positions go to floats (StreamMesh's); capacityVertices,
//   capacityFaces: the page's buffers (apply refuses a block past them).
// Errors are thrown as Error "mesh <index>: ..." (a block whose dependency is not held, a
// block applied twice, the decoder's own message naming the split); after one, the state is not
// used again. Memory: the decoder's (growing to the highest stream vertex placed), one int per
// stream vertex (slots), and the coded bytes of the blocks held (kept to rebuild).
// The blocks a client holds before any is applied: those that send nothing (wholly in the
// base), except those after the last block a part sends (`sent`: per block, whether a part
// carries it), which a completion cut off (their detail is in it): those stay wanted, so their
// error counts on screen, and never come. A Set of block indices. O(blocks).
export function heldFromStart(blocks, sent) {
  let last = -1;
  for (let k = 0; k < blocks.length; k++) if (sent[k]) last = k;
  const held = new Set();
  blocks.forEach((b, k) => { if (isEmptyBlock(b) && k < last) held.add(k); });
  return held;
}

const EMPTY = new Uint8Array(0);

export class BlockMeshState {
  constructor(decoder, desc, index, base, { quantized = true, origin = [0, 0, 0], step = 1, capacityVertices, capacityFaces }) {
    this.decoder = decoder;
    this.desc = desc;
    this.index = index;
    this.base = base;
    this.quantized = quantized;
    this.origin = origin;
    this.step = step;
    this.capacityVertices = capacityVertices;
    this.capacityFaces = capacityFaces;
    this.slotOf = new Int32Array(desc.vertices).fill(-1);
    this.held = new Map();  // block → {bytes (its coded part), vertexBegin, splits, faces}
    this.order = [];        // the blocks held, in the order they were applied
    this.slots = 0;         // vertices held (the page's vertex count)
    this.state = null;
    this._fresh();
  }

  _fail(message) { return new Error(`mesh ${this.index}: ${message}`); }

  // The decoder holding the base alone; slots of the base's vertices as numbered.
  _fresh() {
    if (this.state) this.state.free();
    this.state = null;
    const b = this.base;
    if (b.count > this.capacityVertices) throw this._fail(`its base's ${b.count} vertices exceed the ${this.capacityVertices} the page holds`);
    this.state = new MeshDecoder(this.decoder, this.desc, this.index);
    this.state.setBase(b.qp, b.qn, b.qt, b.count);
    for (const f of b.faces) this.state.appendFaces(f);
    if (this.state.faces > this.capacityFaces) throw this._fail(`its base's ${this.state.faces} faces exceed the ${this.capacityFaces} the page holds`);
    this.slotOf.fill(-1);
    for (let v = 0; v < b.count; v++) this.slotOf[v] = v;
    this.slots = b.count;
    this.held.clear();
    this.order = [];
    this.desc.blocks.forEach((b, k) => { if (isEmptyBlock(b)) this.held.set(k, EMPTY); });
  }

  get faces() { return this.state.faces; }
  get solid() { return this.state.solid; }

  // Whether block k is held.
  holds(k) { return this.held.has(k); }

  // Applies block k's part (`bytes`: its coded bytes; the block's range from the table) and
  // returns what changed on the page, in slots: {v0, vn, f0, nf, solid, position, normal, uv
  // (the new vertices' floats), appended (the new faces, in slots), moved ([corner, slot]
  // pairs)} — StreamMesh.applyChanges takes it as a chain's. Keeps the bytes (rebuild).
  // O(the block's splits + the corners they move).
  apply(k, bytes) {
    const b = this.desc.blocks[k];
    if (!b) throw this._fail(`block ${k} is not in the table (${this.desc.blocks.length} blocks)`);
    if (this.held.has(k)) throw this._fail(`block ${k} is held already`);
    for (const d of b.deps) if (!this.held.has(d)) throw this._fail(`block ${k} depends on block ${d}, which is not held`);
    const splits = b.vertex_end - b.vertex_begin, faces = b.face_end - b.face_begin;
    if (this.slots + splits > this.capacityVertices || this.state.faces + faces > this.capacityFaces) {
      throw this._fail(`block ${k} would hold ${this.slots + splits} vertices and ${this.state.faces + faces} faces, past the page's ${this.capacityVertices} and ${this.capacityFaces}`);
    }
    const s0 = this.slots, f0 = this.state.faces;
    this.state.beginChanges();
    this.state.applyBlockSplits(bytes, 0, bytes.length, k, splits, faces);
    for (let v = b.vertex_begin; v < b.vertex_end; v++) this.slotOf[v] = this.slots++;
    this.held.set(k, bytes);
    this.order.push(k);
    const { position, normal, uv } = this._floats(b.vertex_begin, b.vertex_end);
    const x = this.decoder.x, indices = this.state.indices, nf = this.state.faces;
    const appended = this._slotted(indices.subarray(3 * f0, 3 * nf));
    const count = x.mmx_moved_count(this.state.handle);
    const corners = new Uint32Array(x.memory.buffer, x.mmx_moved(this.state.handle) >>> 0, count);
    const moved = new Uint32Array(2 * count), slotOf = this.slotOf;
    for (let i = 0; i < count; i++) {
      moved[2 * i] = corners[i];
      moved[2 * i + 1] = slotOf[indices[corners[i]]];
    }
    return { v0: s0, vn: this.slots, f0, nf, solid: this.state.solid, position, normal, uv, appended, moved };
  }

  // Drops every block not in `keep` (those kept must be dependency-closed: each one's
  // dependencies kept too) by decoding the base and the kept blocks again, in block order (a
  // topological order: every dependency is an earlier block), from the bytes held. Returns the
  // page's whole buffers, sized to its capacities: {replace: true, vertices, faces, solid,
  // position, normal, uv, indices}. The state afterwards is the one those blocks give in any
  // order (stream/format.h "Blocks"; its digest says so). O(the kept blocks' splits).
  rebuild(keep) {
    const kept = [...new Set(keep)].sort((a, b) => a - b), bytes = new Map();
    for (const k of kept) {
      if (!this.held.has(k)) throw this._fail(`block ${k} is kept but not held`);
      bytes.set(k, this.held.get(k));
    }
    const keepSet = new Set(kept);
    this.desc.blocks.forEach((b, k) => { if (isEmptyBlock(b)) keepSet.add(k); });
    for (const k of kept) {
      for (const d of this.desc.blocks[k].deps) if (!keepSet.has(d)) throw this._fail(`block ${k} is kept without block ${d}, which it depends on`);
    }
    this._fresh();
    for (const k of kept) {
      const b = this.desc.blocks[k], part = bytes.get(k);
      if (isEmptyBlock(b)) continue;  // held from the start
      this.state.beginChanges();
      this.state.applyBlockSplits(part, 0, part.length, k, b.vertex_end - b.vertex_begin, b.face_end - b.face_begin);
      for (let v = b.vertex_begin; v < b.vertex_end; v++) this.slotOf[v] = this.slots++;
      this.held.set(k, part);
      this.order.push(k);
    }
    return this.whole();
  }

  // The page's whole buffers for what is held now (sized to the capacities; see rebuild).
  whole() {
    const V = this.capacityVertices, F = this.capacityFaces;
    const position = new Float32Array(3 * V), normal = new Float32Array(3 * V), uv = new Float32Array(2 * V);
    const put = (v0, vn) => {
      const s = this.slotOf[v0], f = this._floats(v0, vn);
      position.set(f.position, 3 * s);
      normal.set(f.normal, 3 * s);
      uv.set(f.uv, 2 * s);
    };
    if (this.base.count > 0) put(0, this.base.count);
    for (const k of this.order) {
      const b = this.desc.blocks[k];
      if (b.vertex_end > b.vertex_begin) put(b.vertex_begin, b.vertex_end);
    }
    const nf = this.state.faces, indices = new Uint32Array(3 * F);
    indices.set(this._slotted(this.state.indices.subarray(0, 3 * nf)));
    return { replace: true, vertices: this.slots, faces: nf, solid: this.state.solid, position, normal, uv, indices };
  }

  // stream/vsplit.h state_digest of the decoder's state.
  digest() { return this.state.digest(); }

  free() {
    if (this.state) this.state.free();
    this.state = null;
  }

  // Stream vertices' indices as slots (a fresh array).
  _slotted(indices) {
    const out = new Uint32Array(indices.length), slotOf = this.slotOf;
    for (let i = 0; i < indices.length; i++) {
      const s = slotOf[indices[i]];
      if (s < 0) throw this._fail(`a face names vertex ${indices[i]}, which is not held`);
      out[i] = s;
    }
    return out;
  }

  // Stream vertices [v0, vn)'s float attributes (positions as the grid's integers when
  // quantized, else origin + q·step), each its own buffer.
  _floats(v0, vn) {
    const x = this.decoder.x, n = vn - v0;
    const at = x.mmx_alloc(32 * n + 4) >>> 0;
    if (!at) throw this._fail(`no memory for ${n} vertices' attributes`);
    try {
      const o = this.origin;
      x.mmx_dequantize(this.state.handle, v0, vn, at, at + 12 * n, at + 24 * n, this.quantized ? 1 : 0, o[0], o[1], o[2], this.step);
      const buffer = x.memory.buffer;
      return { position: new Float32Array(buffer, at, 3 * n).slice(), normal: new Float32Array(buffer, at + 12 * n, 3 * n).slice(),
        uv: new Float32Array(buffer, at + 24 * n, 2 * n).slice() };
    } finally {
      x.mmx_free(at);
    }
  }
}

// ---- The choice of blocks --------------------------------------------------------------------

// Per block mesh, what the choice needs besides the table: the blocks that depend on each one
// (children) and the largest error among them (what is left where the block is applied).
// Computed once per mesh: O(blocks + dependencies).
export function blockChildren(blocks) {
  const children = blocks.map(() => []);
  blocks.forEach((b, k) => { for (const d of b.deps) children[d].push(k); });
  const childError = children.map((c) => c.reduce((e, k) => Math.max(e, blocks[k].error), 0));
  return { children, childError };
}

// The next blocks to fetch for a view, and the held blocks to drop first to make room.
//   meshes: per package mesh, null (not a block mesh) or {blocks (the table's, with ranges),
//     children, childError (blockChildren), held (a Set of blocks applied), pending (a Set of
//     blocks being fetched: counted as held), sent (per block: whether a part carries it),
//     bytes (per block: its part's bytes), faces (faces held now), capacityVertices,
//     capacityFaces, vertices (vertices held now)}
//   resident: faces held now over every mesh (the budget's count), with pending blocks' faces
//   budget: faces at most (the triangle budget)
//   scale(m, k): pixels per unit of error (the errors' units: the scene's diagonal) at block k
//     of mesh m from the camera, and its box's area on screen in pixels: {pixels, area}; pixels
//     0 where the box is outside the view
//   options: tolerance (pixels of screen-space error that need no refinement, default 1),
//     max (blocks at most, default 4), slack (the share of the budget an eviction frees
//     beyond what the next block needs, default 0.1: a run of blocks fits before the next one)
// A block is a candidate once every block it depends on is held, when its projected error
// (error × pixels) is above the tolerance; its gain is the screen-space error it removes (its
// own minus its children's, in pixels) × its area on screen, per byte. Candidates are taken by
// gain while they fit the budget; when the best does not fit, held blocks no held block depends
// on are dropped, the least projected error first, as long as theirs is below the candidate's
// (Nexus's cut: detail that left the view or went far makes room for detail in view).
// Returns {fetch: [{mesh, block, pixels (its projected error)}], evict: [{mesh, blocks: [...]}],
// error (the largest projected error of a block in view whose dependencies are held, sent or
// not: the screen-space error of what is drawn, at most the tolerance once the view is refined
// as far as the package allows)}. O(blocks · log blocks) per call.
export function planBlocks(meshes, resident, budget, scale, { tolerance = 1, max = 4, slack = 0.1 } = {}) {
  const candidates = [];
  let error = 0;
  meshes.forEach((m, mi) => {
    if (!m) return;
    m.blocks.forEach((b, k) => {
      if (m.held.has(k) || m.pending.has(k)) return;
      for (const d of b.deps) if (!m.held.has(d)) return;
      const s = scale(mi, k);
      const pixels = b.error * s.pixels;
      if (pixels > error) error = pixels;  // a block no part sends (after a completion) counts too
      if (!m.sent[k] || !(pixels > tolerance)) return;
      const drop = pixels - m.childError[k] * s.pixels;
      const faces = b.face_end - b.face_begin;
      candidates.push({ mesh: mi, block: k, pixels, faces, vertices: b.vertex_end - b.vertex_begin,
        gain: (Math.max(drop, 0.05 * pixels) * Math.max(s.area, 1)) / Math.max(m.bytes[k], 1) });
    });
  });
  candidates.sort((a, b) => b.gain - a.gain || a.mesh - b.mesh || a.block - b.block);
  const fetch = [], evict = [];
  if (resident > budget) {
    // Over the budget (it was lowered): held leaves dropped, the least projected error first.
    const first = meshes.findIndex((m) => m);
    const none = { mesh: first, faces: 0, vertices: 0, pixels: Infinity };
    const dropped = first < 0 ? null : dropForRoom(meshes, none, resident, budget, meshes.map((m) => (m ? m.faces : 0)),
      meshes.map((m) => (m ? m.vertices : 0)), scale, slack);
    if (dropped) for (const [mi, blocks] of dropped.byMesh) evict.push({ mesh: mi, blocks });
    return { fetch, evict, error };
  }
  const facesOf = meshes.map((m) => (m ? m.faces : 0)), verticesOf = meshes.map((m) => (m ? m.vertices : 0));
  const fits = (c) => resident + c.faces <= budget && facesOf[c.mesh] + c.faces <= meshes[c.mesh].capacityFaces
    && verticesOf[c.mesh] + c.vertices <= meshes[c.mesh].capacityVertices;
  const take = (c) => {
    fetch.push({ mesh: c.mesh, block: c.block, pixels: c.pixels });
    resident += c.faces;
    facesOf[c.mesh] += c.faces;
    verticesOf[c.mesh] += c.vertices;
  };
  for (const c of candidates) {
    if (fetch.length >= max) break;
    if (fits(c)) { take(c); continue; }
    if (fetch.length > 0) break;  // the next plan drops what this one would
    // The best does not fit: drop held leaves of lower projected error (pending blocks are not
    // held yet; nothing is dropped while some are, see the caller).
    const dropped = dropForRoom(meshes, c, resident, budget, facesOf, verticesOf, scale, slack);
    if (!dropped) break;
    for (const [mi, blocks] of dropped.byMesh) evict.push({ mesh: mi, blocks });
    resident = dropped.resident;
    take(c);
    break;
  }
  return { fetch, evict, error };
}

// Held blocks to drop so that candidate c fits with `slack` of the budget to spare: leaves
// (no held block depends on them) by projected error, lowest first, each below c's; null when
// not enough can go. Updates facesOf and verticesOf for what it drops.
function dropForRoom(meshes, c, resident, budget, facesOf, verticesOf, scale, slack) {
  const target = Math.max(0, Math.min(budget - c.faces - slack * budget, budget - c.faces));
  const dependents = meshes.map((m) => {
    if (!m) return null;
    const n = new Int32Array(m.blocks.length);
    for (const k of m.held) for (const d of m.blocks[k].deps) n[d]++;
    return n;
  });
  const projected = (mi, k) => meshes[mi].blocks[k].error * scale(mi, k).pixels;
  const leaves = [];
  const droppable = (m, k) => !isEmptyBlock(m.blocks[k]);  // an empty block frees nothing
  meshes.forEach((m, mi) => { if (m) for (const k of m.held) if (dependents[mi][k] === 0 && droppable(m, k)) leaves.push({ mi, k, p: projected(mi, k) }); });
  const byMesh = new Map();
  const faces = facesOf.slice(), vertices = verticesOf.slice();
  const fitsNow = () => resident <= target && faces[c.mesh] + c.faces <= meshes[c.mesh].capacityFaces
    && vertices[c.mesh] + c.vertices <= meshes[c.mesh].capacityVertices;
  while (!fitsNow()) {
    let best = -1;
    for (let i = 0; i < leaves.length; i++) if (best < 0 || leaves[i].p < leaves[best].p || (leaves[i].p === leaves[best].p && leaves[i].k > leaves[best].k)) best = i;
    if (best < 0 || !(leaves[best].p < c.pixels)) {
      // Enough for c itself (without the slack) is enough.
      if (resident + c.faces <= budget && faces[c.mesh] + c.faces <= meshes[c.mesh].capacityFaces
        && vertices[c.mesh] + c.vertices <= meshes[c.mesh].capacityVertices && byMesh.size) break;
      return null;
    }
    const { mi, k } = leaves[best];
    leaves.splice(best, 1);
    const m = meshes[mi], b = m.blocks[k], f = b.face_end - b.face_begin;
    if (!byMesh.has(mi)) byMesh.set(mi, []);
    byMesh.get(mi).push(k);
    resident -= f;
    faces[mi] -= f;
    vertices[mi] -= b.vertex_end - b.vertex_begin;
    for (const d of b.deps) if (--dependents[mi][d] === 0 && m.held.has(d) && droppable(m, d)) leaves.push({ mi, k: d, p: projected(mi, d) });
  }
  if (!byMesh.size) return null;
  for (let i = 0; i < faces.length; i++) { facesOf[i] = faces[i]; verticesOf[i] = vertices[i]; }
  return { byMesh, resident };
}
