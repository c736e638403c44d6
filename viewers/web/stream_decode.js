// stream_decode.js — the compact vertex-split decoder of a meshmux stream (stream/vsplit.h,
// operation for operation: ring order, twins, fans, the uv predictor's double arithmetic) and
// the state it decodes against, one MeshState per package mesh. It imports nothing but the
// package reader's constants, so it runs in a Web Worker (stream_worker.js: the page's import
// map does not reach workers) as well as on the page (stream_mesh.js).

import { PART_ELEMENTS_PER_BYTE, PART_ELEMENTS_CONSTANT, PART_MIN_BYTES } from './package_reader.js';

// ---- Decoding: compact vertex splits (stream/vsplit.h, operation for operation) -----------

const RING_LIMIT = 64;   // ring entries a new face's third vertex is coded against
const TWIN_LIMIT = 4;    // twin candidates a new vertex's position is matched against
const FAN_LIMIT = 32;    // corners a parent may have for a fan-coded split
const FAN_N1 = new Int32Array(FAN_LIMIT), FAN_N2 = new Int32Array(FAN_LIMIT), FAN_MOVED = new Uint8Array(FAN_LIMIT);
const UV_MAX = 4095;     // uv bits (stream/quantize.h)

// ---- The adaptive binary range decoder (stream/range_coder.h, operation for operation) ---
// Module-level state: one part is decoded at a time. Every quantity is an integer below 2^32;
// the range and code live in a Uint32Array (RC[0], RC[1]) so that updating them never boxes a
// number past 2^31.
const PROB_BITS = 11, PROB_ONE = 2048, PROB_HALF = 1024, ADAPT_SHIFT = 4, TOP = 16777216;
const RC = new Uint32Array(2);
let rcData = null, rcPos = 0, rcEnd = 0, rcFailed = false;
function rcByte() {
  if (rcPos >= rcEnd) { rcFailed = true; return 0; }
  return rcData[rcPos++];
}
function rcStart(d, begin, end) {
  rcData = d; rcPos = begin; rcEnd = end; rcFailed = false;
  let code = 0;
  for (let i = 0; i < 5; i++) code = ((code * 256) + rcByte()) >>> 0;
  RC[0] = 0xFFFFFFFF; RC[1] = code;
}
// The coder's state is read into locals once per call and written back at its end; the bit
// decode is spelled out in each loop (V8 does not inline it into the big applySplits).
function getBit(probs, i) {
  const p = probs[i];
  let range = RC[0], code = RC[1], bit;
  const bound = (range >>> PROB_BITS) * p;
  if (code < bound) { range = bound; probs[i] = p + ((PROB_ONE - p) >> ADAPT_SHIFT); bit = 0; }
  else { code -= bound; range -= bound; probs[i] = p - (p >> ADAPT_SHIFT); bit = 1; }
  while (range < TOP) { range *= 256; code = ((code * 256) + rcByte()) >>> 0; }
  RC[0] = range; RC[1] = code;
  return bit;
}
// `bits` equiprobable bits, DIRECT_PIECE at a time (RangeDecoder::get_direct).
const DIRECT_PIECE = 16;
function getDirect(bits) {
  let value = 0, range = RC[0], code = RC[1];
  while (bits > 0) {
    const k = bits < DIRECT_PIECE ? bits : DIRECT_PIECE;
    bits -= k;
    range = range >>> k;
    let slice = Math.floor(code / range);  // exact: code < 2^32
    if (slice >= POW2[k]) { slice = POW2[k] - 1; rcFailed = true; }
    code -= slice * range;
    value = value * POW2[k] + slice;
    while (range < TOP) { range *= 256; code = ((code * 256) + rcByte()) >>> 0; }
  }
  RC[0] = range; RC[1] = code;
  return value;
}
const POW2 = new Float64Array(33).map((_, i) => 2 ** i);
// An integer through UIntContext `o` (RangeDecoder::get_uint): its bit length by a 4-level tree
// (15 escapes to 5 direct bits), up to `most` bits below the leading one by contexts per
// length, the rest direct.
function getUint(probs, o, most) {
  let range = RC[0], code = RC[1], node = 1;
  for (let i = 0; i < 4; i++) {
    const j = o + node, p = probs[j], bound = (range >>> PROB_BITS) * p;
    if (code < bound) { range = bound; probs[j] = p + ((PROB_ONE - p) >> ADAPT_SHIFT); node = node << 1; }
    else { code -= bound; range -= bound; probs[j] = p - (p >> ADAPT_SHIFT); node = (node << 1) | 1; }
    while (range < TOP) { range *= 256; code = ((code * 256) + rcByte()) >>> 0; }
  }
  let n = node - 16;
  if (n < 2) { RC[0] = range; RC[1] = code; return n; }
  if (n === LENGTH_ESCAPE) {
    RC[0] = range; RC[1] = code;
    n += getDirect(5);
    range = RC[0]; code = RC[1];
  }
  if (n > 32) { RC[0] = range; RC[1] = code; rcFailed = true; return 0; }
  const below = n - 1, modelled = below < most ? below : most, m = o + 16 + 8 * n;
  node = 1;
  for (let i = 0; i < modelled; i++) {
    const j = m + node, p = probs[j], bound = (range >>> PROB_BITS) * p;
    if (code < bound) { range = bound; probs[j] = p + ((PROB_ONE - p) >> ADAPT_SHIFT); node = node << 1; }
    else { code -= bound; range -= bound; probs[j] = p - (p >> ADAPT_SHIFT); node = (node << 1) | 1; }
    while (range < TOP) { range *= 256; code = ((code * 256) + rcByte()) >>> 0; }
  }
  RC[0] = range; RC[1] = code;
  let value = node * POW2[below - modelled];  // node holds the leading one and the modelled bits
  if (below > modelled) value += getDirect(below - modelled);
  return value;
}
function getTree(probs, o, bits) {
  let range = RC[0], code = RC[1], node = 1;
  for (let i = 0; i < bits; i++) {
    const j = o + node, p = probs[j], bound = (range >>> PROB_BITS) * p;
    if (code < bound) { range = bound; probs[j] = p + ((PROB_ONE - p) >> ADAPT_SHIFT); node = node << 1; }
    else { code -= bound; range -= bound; probs[j] = p - (p >> ADAPT_SHIFT); node = (node << 1) | 1; }
    while (range < TOP) { range *= 256; code = ((code * 256) + rcByte()) >>> 0; }
  }
  RC[0] = range; RC[1] = code;
  return node - (1 << bits);
}
// VsplitContexts' layout in one array: UIntContext = 280 probabilities (16 + 33 · 8).
const UINT = 280, EXTENT_CLASSES = 16, RESIDUAL_BITS = 1, LENGTH_ESCAPE = 15;
const C_PARENT = 0, C_FACES = UINT, C_FACE = 2 * UINT, C_ESCAPE = 3 * UINT, C_EXTRA = 4 * UINT;
const C_MODE = 5 * UINT, C_MASK = C_MODE + 2, C_FAN_START = C_MASK + 16;
const C_FAN_COUNT = C_FAN_START + 33 * 32, C_TWIN = C_FAN_COUNT + 33 * 32;
const C_POSITION = C_TWIN + 5 * 8, C_NORMAL = C_POSITION + 3 * EXTENT_CLASSES * UINT;
const C_UV = C_NORMAL + 3 * UINT, C_TOTAL = C_UV + 4 * UINT;
const bitLength = (x) => (x === 0 ? 0 : 32 - Math.clz32(x));

// Inflates the package's table or base (a zlib stream) with the browser's DecompressionStream, refusing output past
// `limit` bytes (a zlib bomb) and trailing or missing bytes.
export async function inflate(bytes, limit, format = 'deflate') {
  const stream = new DecompressionStream(format);
  const writer = stream.writable.getWriter();
  writer.write(bytes).catch(() => {});
  writer.close().catch(() => {});
  const reader = stream.readable.getReader();
  const pieces = [];
  let total = 0;
  try {
    for (;;) {
      const { done, value } = await reader.read();
      if (done) break;
      total += value.length;
      if (total > limit) throw new Error(`inflates past its limit of ${limit} bytes`);
      pieces.push(value);
    }
  } catch (e) {
    reader.cancel().catch(() => {});
    throw new Error(e.message.includes('limit') ? e.message : `not a complete ${format === 'deflate' ? 'zlib' : format} stream (${e.message})`);
  }
  if (pieces.length === 1) return pieces[0];
  const out = new Uint8Array(total);
  let at = 0;
  for (const p of pieces) { out.set(p, at); at += p.length; }
  return out;
}

// round(sum / n), halves up: floor((2·sum + n) / (2n)).
const mean = (sum, n) => Math.floor((2 * sum + n) / (2 * n));
const PRED = new Int32Array(8);
const NORMAL = new Float64Array(3);  // v's fan normal (exact integers below 2^53)
// v's prediction set, gathered per split (addNeighbour): the sums of its vertices' quantized
// positions [0, 3), normals [3, 6) and uvs [6, 8), their count [8], and the positions' extent,
// lows [9, 12) and highs [12, 15). Doubles: every sum an exact integer (below 2^53).
const NEAR = new Float64Array(15);
const NEAR_EMPTY = Float64Array.of(0, 0, 0, 0, 0, 0, 0, 0, 0, 65535, 65535, 65535, 0, 0, 0);
// Adds vertex w to the prediction set A (NEAR).
function addNeighbour(A, qp, qn, qt, w) {
  const x0 = qp[3 * w], x1 = qp[3 * w + 1], x2 = qp[3 * w + 2];
  A[0] += x0; A[1] += x1; A[2] += x2;
  A[3] += qn[3 * w]; A[4] += qn[3 * w + 1]; A[5] += qn[3 * w + 2];
  A[6] += qt[2 * w]; A[7] += qt[2 * w + 1];
  A[8]++;
  if (x0 < A[9]) A[9] = x0; if (x0 > A[12]) A[12] = x0;
  if (x1 < A[10]) A[10] = x1; if (x1 > A[13]) A[13] = x1;
  if (x2 < A[11]) A[11] = x2; if (x2 > A[14]) A[14] = x2;
}
// 1 when face f's three corners differ.
function faceSolid(I, f) {
  const a = I[f], b = I[f + 1], c = I[f + 2];
  return a !== b && b !== c && a !== c ? 1 : 0;
}
// v's uv predicted from its position (VsplitMesh::predict_uv, the same operations in the same
// order): w the third vertex of v's newest face with p, x the third vertex of p's first face
// with w but not v; v's offset along and off the edge p→w in 3D, relative to its length,
// carried to uv space away from x. Writes pred[6..7] and returns true, or leaves them.
function predictUv(I, head, next, qp, qt, v, p, pred) {
  let w = -1, x = -1;
  for (let c = head[v]; c >= 0 && w < 0; c = next[c]) {
    const f = c - (c % 3), a = I[f], b = I[f + 1], d = I[f + 2];
    if (a === p || b === p || d === p) w = a !== v && a !== p ? a : b !== v && b !== p ? b : d;
  }
  if (w < 0 || w === v || w === p) return false;
  for (let c = head[p]; c >= 0 && x < 0; c = next[c]) {
    const f = c - (c % 3), a = I[f], b = I[f + 1], d = I[f + 2];
    if (a === v || b === v || d === v || (a !== w && b !== w && d !== w)) continue;
    x = a !== w && a !== p ? a : b !== w && b !== p ? b : d;
  }
  if (x < 0 || x === p || x === w) return false;
  const ex = qp[3 * w] - qp[3 * p], ey = qp[3 * w + 1] - qp[3 * p + 1], ez = qp[3 * w + 2] - qp[3 * p + 2];
  const dx = qp[3 * v] - qp[3 * p], dy = qp[3 * v + 1] - qp[3 * p + 1], dz = qp[3 * v + 2] - qp[3 * p + 2];
  const ee = ex * ex + ey * ey + ez * ez;
  if (!(ee > 0)) return false;
  const s = (dx * ex + dy * ey + dz * ez) / ee;
  const rx = dx - s * ex, ry = dy - s * ey, rz = dz - s * ez;
  const t = Math.sqrt((rx * rx + ry * ry + rz * rz) / ee);
  const ux = qt[2 * w] - qt[2 * p], uy = qt[2 * w + 1] - qt[2 * p + 1];
  const side = ux * (qt[2 * x + 1] - qt[2 * p + 1]) - uy * (qt[2 * x] - qt[2 * p]);
  const k = side > 0 ? -t : t;
  const u0 = qt[2 * p] + s * ux - k * uy, u1 = qt[2 * p + 1] + s * uy + k * ux;
  const r0 = Math.floor(u0 + 0.5), r1 = Math.floor(u1 + 0.5);
  pred[6] = r0 < 0 ? 0 : r0 > UV_MAX ? UV_MAX : r0;
  pred[7] = r1 < 0 ? 0 : r1 > UV_MAX ? UV_MAX : r1;
  return true;
}

// Writes face (a, b, c) at corner f and pushes its corners to their vertices' lists (slot 0
// first); returns 1 when it is not degenerate.
function addFace(I, head, next, f, a, b, c) {
  I[f] = a; I[f + 1] = b; I[f + 2] = c;
  next[f] = head[a]; head[a] = f;
  next[f + 1] = head[b]; head[b] = f + 1;
  next[f + 2] = head[c]; head[c] = f + 2;
  return a !== b && b !== c && a !== c ? 1 : 0;
}


// Checks base faces (a glTF primitive's index array) for mesh `index` holding `vertices`
// vertices and `faces` of `capacity` faces: whole faces, within the capacity, every corner naming
// a vertex received. Returns how many are non-degenerate; throws an Error naming the problem.
export function validateFaces(indices, index, vertices, faces, capacity) {
  const corners = indices.length;
  if (corners % 3 !== 0) throw new Error(`mesh ${index}: ${corners} base indices are not whole faces`);
  if (faces + corners / 3 > capacity) throw new Error(`mesh ${index}: ${faces + corners / 3} faces exceed its capacity ${capacity}`);
  let solid = 0;
  for (let i = 0; i < corners; i += 3) {
    const a = indices[i], b = indices[i + 1], c = indices[i + 2];
    if (a >= vertices || b >= vertices || c >= vertices) {
      throw new Error(`mesh ${index}: base face ${faces + i / 3} names vertex ${Math.max(a, b, c)}, only ${vertices} are received`);
    }
    solid += a !== b && b !== c && a !== c ? 1 : 0;
  }
  return solid;
}

// ---- One mesh's decoding state ----------------------------------------------------------------

// Package mesh m as the decoder holds it: its quantized attributes, the index buffer, each
// vertex's list of corners (head, then next per corner), the twins and the coder's contexts,
// with the full mesh's capacity; the counts received so far. `indices` may be shared with a
// geometry (the page decoding in place) or owned (a Web Worker). Corners of faces received
// before beginChanges() that a split moves are listed (movedCorners) so that a worker can send
// the page only what changed.
export class MeshState {
  constructor(desc, index, indices = null) {
    this.index = index;
    this.capacityVertices = desc.vertices;
    this.capacityFaces = desc.faces;
    this.vertices = 0;  // vertices received
    this.faces = 0;     // faces received (3 corners each in the index buffer)
    this.solid = 0;     // non-degenerate faces among them
    const V = desc.vertices, F = desc.faces;
    this.indices = indices || new Uint32Array(3 * F);
    if (this.indices.length !== 3 * F) throw new Error(`mesh ${index}: an index buffer of ${this.indices.length} for ${F} faces`);
    this.qp = new Uint16Array(3 * V);
    this.qn = new Int8Array(3 * V);
    this.qt = new Uint16Array(2 * V);
    this.head = new Int32Array(V).fill(-1);
    this.next = new Int32Array(3 * F);
    this.stamp = new Uint32Array(V);
    this.stampValue = 0;
    this.ring = new Int32Array(RING_LIMIT);
    // The range coder's contexts: fresh with the base, carried from part to part.
    this.contexts = new Uint16Array(C_TOTAL).fill(PROB_HALF);
    // Twins (VsplitMesh::twins): an open-addressing table from a parent position to the newest
    // vertex split from a parent there (keys compared through parentOf), and per vertex the
    // twin before it.
    let slots = 1;
    while (slots < 2 * V + 2) slots *= 2;
    this.twinTable = new Int32Array(slots).fill(-1);
    this.twinPrevious = new Int32Array(V).fill(-1);
    this.parentOf = new Int32Array(V).fill(-1);
    this.movedFloor = 0;  // corners below this that splits move are listed
    this.movedCount = 0;
    this.movedCorners = new Uint32Array(0);
    // Commit the memory now (load time) rather than page by page while refining.
    for (const a of [this.qp, this.qn, this.qt, this.next, this.stamp]) a.fill(0);
  }

  // The base's vertices, quantized (stream/quantize.h): `count` of them from qp (3 per vertex),
  // qn (3) and qt (2).
  setBase(qp, qn, qt, count) {
    if (count > this.capacityVertices) throw new Error(`mesh ${this.index}: ${count} base vertices exceed its capacity ${this.capacityVertices}`);
    this.qp.set(qp.subarray(0, 3 * count));
    this.qn.set(qn.subarray(0, 3 * count));
    this.qt.set(qt.subarray(0, 2 * count));
    this.vertices = count;
  }

  // Appends base faces (`indices`: a glTF primitive's index array, 3 per face, as the base .glb
  // decoded them) to the index buffer and the corner lists; every corner must name a vertex
  // already received. Returns the faces added.
  appendFaces(indices) {
    const start = 3 * this.faces;
    validateFaces(indices, this.index, this.vertices, this.faces, this.capacityFaces);
    for (let i = 0; i < indices.length; i += 3) {
      this.solid += addFace(this.indices, this.head, this.next, start + i, indices[i], indices[i + 1], indices[i + 2]);
    }
    this.faces += indices.length / 3;
    return indices.length / 3;
  }

  // Starts listing moved corners: those of the faces received so far.
  beginChanges() {
    this.movedFloor = 3 * this.faces;
    this.movedCount = 0;
  }

  _recordMove(c, count) {
    if (count === this.movedCorners.length) {
      const grown = new Uint32Array(Math.max(1024, 2 * count));
      grown.set(this.movedCorners);
      this.movedCorners = grown;
    }
    this.movedCorners[count] = c;
    return count + 1;
  }

  // Float attributes of vertices [v0, vn) into P (3 per vertex), N (3) and T (2) from index
  // `at` on: positions as the grid's integers (`quantized`: the base .glb's nodes dequantize)
  // or in mesh units (origin + q·step); normals q/127; uvs q/4095.
  dequantize(v0, vn, P, N, T, at, quantized, origin, step) {
    const qp = this.qp, qn = this.qn, qt = this.qt;
    for (let v = v0, i = at; v < vn; v++, i++) {
      if (quantized) { P[3 * i] = qp[3 * v]; P[3 * i + 1] = qp[3 * v + 1]; P[3 * i + 2] = qp[3 * v + 2]; }
      else { P[3 * i] = origin[0] + qp[3 * v] * step; P[3 * i + 1] = origin[1] + qp[3 * v + 1] * step; P[3 * i + 2] = origin[2] + qp[3 * v + 2] * step; }
      N[3 * i] = qn[3 * v] / 127; N[3 * i + 1] = qn[3 * v + 1] / 127; N[3 * i + 2] = qn[3 * v + 2] / 127;
      T[2 * i] = qt[2 * v] / UV_MAX; T[2 * i + 1] = qt[2 * v + 1] / UV_MAX;
    }
  }

  // FNV-1a over the state (stream/vsplit.h state_digest): per vertex its position, normal and
  // uv bytes, then every index.
  digest() {
    let h = 2166136261;
    const byte = (b) => { h = Math.imul(h ^ (b & 0xff), 16777619) >>> 0; };
    for (let i = 0; i < this.vertices; i++) {
      for (let k = 0; k < 3; k++) { byte(this.qp[3 * i + k]); byte(this.qp[3 * i + k] >> 8); }
      for (let k = 0; k < 3; k++) byte(this.qn[3 * i + k]);
      for (let k = 0; k < 2; k++) { byte(this.qt[2 * i + k]); byte(this.qt[2 * i + k] >> 8); }
    }
    for (let i = 0; i < 3 * this.faces; i++) { const x = this.indices[i]; byte(x); byte(x >> 8); byte(x >> 16); byte(x >>> 24); }
    return h;
  }

  // Applies one part (its coded bytes d[begin, end)): `splits` vertex splits and `faces` new
  // faces (stream/vsplit.h). Everything read is checked; an Error names the split and the
  // problem. The hot loop keeps its cursors in locals and calls only small module-level
  // functions (no closures).
  applySplits(d, begin, end, splits, faces) {
    const I = this.indices, head = this.head, next = this.next, qp = this.qp, qn = this.qn, qt = this.qt;
    const stamp = this.stamp, ring = this.ring, pred = PRED, near = NEAR, X = this.contexts;
    const fail = (message) => new Error(`mesh ${this.index}: ${message}`);
    if (end - begin < PART_MIN_BYTES || splits + faces > PART_ELEMENTS_PER_BYTE * (end - begin) + PART_ELEMENTS_CONSTANT) {
      throw fail(`${end - begin} bytes cannot hold ${splits} splits and ${faces} faces`);
    }
    let moved = this.movedCount;
    const movedFloor = this.movedFloor;
    const table = this.twinTable, tmask = table.length - 1, twinPrevious = this.twinPrevious, parentOf = this.parentOf;
    const v0 = this.vertices, f0 = this.faces;
    if (v0 + splits > this.capacityVertices || f0 + faces > this.capacityFaces) throw fail('more vertices or faces than the mesh holds');
    rcStart(d, begin, end);
    const normals = getDirect(1) === 1;  // 0: the mesh carries no normals (flat-shaded)
    const uvs = getDirect(1) === 1;      // 0: nor texture coordinates
    const faceGoal = f0 + faces;
    let nf = f0, solid = this.solid, previous = 0, previousMode = 1, stampValue = this.stampValue;
    if (stampValue > 0x7fffffff - 2 * splits) { stamp.fill(0); stampValue = 0; }
    for (let i = 0; i < splits; i++) {
      if (rcFailed) throw fail(`split ${i}: the part's bytes end early`);
      const z = getUint(X, C_PARENT, 3);
      const p = previous + (z % 2 ? -(z + 1) / 2 : z / 2), v = v0 + i;
      if (!(p >= 0 && p < v)) throw fail(`split ${i}: parent ${p} of ${v} vertices`);
      previous = p;
      const fanMode = getBit(X, C_MODE + previousMode);
      previousMode = fanMode;
      head[v] = -1;
      // Hoppe's split on p's manifold fan (VsplitMesh::fan): the corners from vl's on, each to
      // the one whose first neighbour is its second, `count` of them.
      let vl = -1, vr = -1, k = 2;
      if (fanMode) {
        // One walk of p's corners: the fan's neighbours and their count, min(d, FAN_LIMIT), which
        // picks the contexts of the fan's arguments.
        let nd = 0, ok = true;
        for (let c = head[p]; c >= 0; c = next[c]) {
          if (nd === FAN_LIMIT) { ok = false; break; }
          const f = c - (c % 3), slot = c - f, a = I[f + (slot + 1) % 3], b = I[f + (slot + 2) % 3];
          if (a === p || b === p || a === b) ok = false;
          for (let j = 0; j < nd && ok; j++) if (FAN_N1[j] === a) ok = false;
          FAN_N1[nd] = a; FAN_N2[nd] = b; FAN_MOVED[nd] = 0; nd++;
        }
        const start = getTree(X, C_FAN_START + 32 * nd, 5), count = getTree(X, C_FAN_COUNT + 32 * nd, 5) + 1;
        if (!ok || start >= nd || count > nd) throw fail(`split ${i}: parent ${p} has no such fan`);
        let at = start;
        for (let j = 0; ; j++) {
          if (FAN_MOVED[at]) throw fail(`split ${i}: parent ${p} has no such fan`);
          FAN_MOVED[at] = 1;
          if (j + 1 === count) break;
          let m = 0;
          while (m < nd && FAN_N1[m] !== FAN_N2[at]) m++;
          if (m === nd) throw fail(`split ${i}: parent ${p} has no such fan`);
          at = m;
        }
        vl = FAN_N1[start]; vr = FAN_N2[at];
        if (vl === vr) throw fail(`split ${i}: parent ${p} has no such fan`);
      } else {
        k = getUint(X, C_FACES, 3);
      }
      // The corners of p in list order that move to v: the fan's, or the mask's 1 bits.
      let last = 0;
      for (let c = head[p], prev = -1, position = 0; c >= 0; position++) {
        const after = next[c];
        let take;
        if (fanMode) take = FAN_MOVED[position];
        else take = last = getBit(X, C_MASK + 2 * (position < 7 ? position : 7) + last);
        if (take) {
          if (prev < 0) head[p] = after; else next[prev] = after;
          const f = c - (c % 3);
          solid -= faceSolid(I, f);
          I[c] = v;
          if (c < movedFloor) moved = this._recordMove(c, moved);
          solid += faceSolid(I, f);
          next[c] = head[v]; head[v] = c;
        } else {
          prev = c;
        }
        c = after;
      }
      if (rcFailed) throw fail(`split ${i}: the part's bytes end early`);
      // One walk of v's corners (the moved ones) gives both the start of the ring (v's
      // neighbours, then p's: see VsplitMesh::ring) and most of the prediction set (every
      // neighbour of v after the split: these, p when a face joins them, the new faces' third
      // vertices, with their extent); p's corners are walked only as far as a face code reaches
      // into the ring.
      const sA = ++stampValue, sB = ++stampValue;
      stamp[v] = stamp[p] = sA;
      let ringSize = 0, pNear = k > 0;
      near.set(NEAR_EMPTY);
      for (let c = head[v]; c >= 0; c = next[c]) {
        const f = c - (c % 3), slot = c - f;
        for (let j = 1; j <= 2; j++) {
          const w = I[f + (slot + j) % 3];
          if (stamp[w] === sA) { if (w === p) pNear = true; continue; }
          stamp[w] = sA;
          if (ringSize < RING_LIMIT) ring[ringSize++] = w;
          addNeighbour(near, qp, qn, qt, w);
        }
      }
      let pc = head[p], pSlot = 1;  // where the ring's walk of p's corners stands
      if (nf + k > faceGoal) throw fail(`split ${i}: more than the part's ${faces} faces`);
      for (let j = 0; j < k; j++) {
        // The face's third vertex w and its winding: the fan's (v, p, vl) then (v, vr, p), or a
        // ring code (walking p's corners into the ring only as far as the code reaches).
        let w, flip;
        if (fanMode) {
          w = j === 0 ? vl : vr;
          flip = j;
        } else {
          const code = getUint(X, C_FACE, 3);
          if (rcFailed) throw fail(`split ${i}: the part's bytes end early`);
          const index = Math.floor(code / 2);
          flip = code % 2;
          while (index >= ringSize && ringSize < RING_LIMIT && pc >= 0) {
            const f = pc - (pc % 3), u = I[f + (pc - f + pSlot) % 3];
            if (pSlot === 2) { pSlot = 1; pc = next[pc]; } else pSlot = 2;
            if (stamp[u] === sA || stamp[u] === sB) continue;
            stamp[u] = sB;
            ring[ringSize++] = u;
          }
          if (index < ringSize) w = ring[index];
          else if (index === ringSize && (ringSize >= RING_LIMIT || pc < 0)) {
            w = getUint(X, C_ESCAPE, 3);
            if (w >= v || w === p) throw fail(`split ${i}: face names vertex ${w}`);
          } else throw fail(`split ${i}: ring position ${index} of ${ringSize}`);
        }
        solid += flip ? addFace(I, head, next, 3 * nf, v, w, p) : addFace(I, head, next, 3 * nf, v, p, w);
        nf++;
        if (stamp[w] !== sA) {  // a neighbour of v not met among the moved corners
          stamp[w] = sA;
          addNeighbour(near, qp, qn, qt, w);
        }
      }
      if (pNear) addNeighbour(near, qp, qn, qt, p);
      // Attributes: the mean of v's neighbours (or p's values) plus the residuals; the position
      // residuals' contexts by the bit length of the neighbours' largest extent.
      let extentClass = 0;
      const n = near[8];
      if (n === 0) {
        pred[0] = qp[3 * p]; pred[1] = qp[3 * p + 1]; pred[2] = qp[3 * p + 2];
        pred[3] = qn[3 * p]; pred[4] = qn[3 * p + 1]; pred[5] = qn[3 * p + 2];
        pred[6] = qt[2 * p]; pred[7] = qt[2 * p + 1];
      } else {
        pred[0] = mean(near[0], n); pred[1] = mean(near[1], n); pred[2] = mean(near[2], n);
        pred[3] = mean(near[3], n); pred[4] = mean(near[4], n); pred[5] = mean(near[5], n);
        pred[6] = mean(near[6], n); pred[7] = mean(near[7], n);
        const e = Math.max(near[12] - near[9], near[13] - near[10], near[14] - near[11]), b = bitLength(e);
        extentClass = b < EXTENT_CLASSES - 1 ? b : EXTENT_CLASSES - 1;
      }
      // Twins: the vertices split from parents at p's position, newest first.
      const px = qp[3 * p], py = qp[3 * p + 1], pz = qp[3 * p + 2];
      let slot = (Math.imul(px, 73856093) ^ Math.imul(py, 19349663) ^ Math.imul(pz, 83492791)) & tmask;
      for (;; slot = (slot + 1) & tmask) {
        const u = table[slot];
        if (u < 0) break;
        const q = 3 * parentOf[u];
        if (qp[q] === px && qp[q + 1] === py && qp[q + 2] === pz) break;
      }
      let pick = 0;
      if (table[slot] >= 0) {
        let candidates = 0;
        for (let t = table[slot]; t >= 0 && candidates < TWIN_LIMIT; t = twinPrevious[t]) candidates++;
        pick = getTree(X, C_TWIN + 8 * candidates, 3);
        if (pick > candidates) throw fail(`split ${i}: twin index past the candidates`);
        if (pick > 0) {
          let t = table[slot];
          for (let m = 1; m < pick; m++) t = twinPrevious[t];
          qp[3 * v] = qp[3 * t]; qp[3 * v + 1] = qp[3 * t + 1]; qp[3 * v + 2] = qp[3 * t + 2];
        }
      }
      if (pick === 0) {
        // Two axes along v's fan from the ring's mean, the third lifted onto the fan's plane
        // (VsplitMesh::fan_normal, plane_axes, plane_predict).
        let m0 = 0, m1 = 0, m2 = 0;
        const c0 = pred[0], c1 = pred[1], c2 = pred[2];
        for (let c = head[v]; c >= 0; c = next[c]) {
          const f = c - (c % 3), slot = c - f, b = 3 * I[f + (slot + 1) % 3], e = 3 * I[f + (slot + 2) % 3];
          const b0 = qp[b] - c0, b1 = qp[b + 1] - c1, b2 = qp[b + 2] - c2;
          const e0 = qp[e] - c0, e1 = qp[e + 1] - c1, e2 = qp[e + 2] - c2;
          m0 += b1 * e2 - b2 * e1; m1 += b2 * e0 - b0 * e2; m2 += b0 * e1 - b1 * e0;
        }
        while (Math.abs(m0) >= 2147483648 || Math.abs(m1) >= 2147483648 || Math.abs(m2) >= 2147483648) {
          m0 = Math.floor(m0 / 2); m1 = Math.floor(m1 / 2); m2 = Math.floor(m2 / 2);
        }
        NORMAL[0] = m0; NORMAL[1] = m1; NORMAL[2] = m2;
        let a = 0;
        if (Math.abs(m1) > Math.abs(NORMAL[a])) a = 1;
        if (Math.abs(m2) > Math.abs(NORMAL[a])) a = 2;
        const plane = NORMAL[a] !== 0;
        const ax = plane ? (a === 0 ? 1 : 0) : 0, bx = plane ? (a === 2 ? 1 : 2) : 1, cx = plane ? a : 2;
        const pos = C_POSITION + extentClass * UINT, stride = EXTENT_CLASSES * UINT;
        let r = getUint(X, pos, RESIDUAL_BITS);
        const xa = pred[ax] + (r % 2 ? -(r + 1) / 2 : r / 2);
        r = getUint(X, pos + stride, RESIDUAL_BITS);
        const xb = pred[bx] + (r % 2 ? -(r + 1) / 2 : r / 2);
        let base = pred[cx];
        if (plane) {
          let num = -(NORMAL[ax] * (xa - pred[ax]) + NORMAL[bx] * (xb - pred[bx])), den = NORMAL[cx];
          if (den < 0) { num = -num; den = -den; }
          base += Math.floor((2 * num + den) / (2 * den));
        }
        r = getUint(X, pos + 2 * stride, RESIDUAL_BITS);
        const xc = base + (r % 2 ? -(r + 1) / 2 : r / 2);
        if (xa < 0 || xa > 65535 || xb < 0 || xb > 65535 || xc < 0 || xc > 65535) throw fail(`split ${i}: attribute out of range`);
        qp[3 * v + ax] = xa; qp[3 * v + bx] = xb; qp[3 * v + cx] = xc;
      }
      for (let j = 0; j < 3 && !normals; j++) qn[3 * v + j] = j === 2 ? 127 : 0;  // flat: +Z
      for (let j = 0; j < 3 && normals; j++) {
        const r = getUint(X, C_NORMAL + j * UINT, RESIDUAL_BITS);
        const x = pred[3 + j] + (r % 2 ? -(r + 1) / 2 : r / 2);
        if (x < -128 || x > 127) throw fail(`split ${i}: attribute out of range`);
        qn[3 * v + j] = x;
      }
      // From v's position, when a face allows; which predictor applied picks the contexts.
      const uvPredicted = uvs && predictUv(I, head, next, qp, qt, v, p, pred) ? 1 : 0;
      if (!uvs) { qt[2 * v] = 0; qt[2 * v + 1] = 0; }
      for (let j = 0; j < 2 && uvs; j++) {
        const r = getUint(X, C_UV + (2 * j + uvPredicted) * UINT, RESIDUAL_BITS);
        const x = pred[6 + j] + (r % 2 ? -(r + 1) / 2 : r / 2);
        if (x < 0 || x > 65535) throw fail(`split ${i}: attribute out of range`);
        qt[2 * v + j] = x;
      }
      // v is now the newest twin at p's position.
      parentOf[v] = p;
      twinPrevious[v] = table[slot];
      table[slot] = v;
    }
    this.stampValue = stampValue;
    const extra = getUint(X, C_EXTRA, 3);
    if (rcFailed) throw fail('extra face count missing');
    if (nf + extra !== faceGoal) throw fail(`${faceGoal - nf} faces expected, ${extra} extra faces follow the splits`);
    const vn = v0 + splits;
    for (let j = 0; j < extra; j++) {
      const a = getUint(X, C_ESCAPE, 3), b = getUint(X, C_ESCAPE, 3), c = getUint(X, C_ESCAPE, 3);
      if (rcFailed) throw fail('extra faces cut short');
      if (a >= vn || b >= vn || c >= vn) throw fail(`extra face ${j} names a vertex not received`);
      solid += addFace(I, head, next, 3 * nf, a, b, c);
      nf++;
    }
    if (rcFailed) throw fail("the part's bytes end early");
    if (rcPos !== end) throw fail(`${end - rcPos} of the part's bytes left over`);
    this.vertices = vn;
    this.faces = nf;
    this.solid = solid;
    this.movedCount = moved;
  }
}
