// stream_mesh.js — the mesh side of a meshmux stream on the client: one growing geometry per
// package mesh and the compact vertex-split decoder (multiplex/vsplit.h, operation for
// operation: ring order, twins, fans, the uv predictor's double arithmetic). Used by meshmux.js.

import * as THREE from 'three';

import { PART_BYTES_PER_ELEMENT, PART_BYTES_CONSTANT } from './package_reader.js';

// ---- Decoding: compact vertex splits (multiplex/vsplit.h, operation for operation) -----------

const RING_LIMIT = 64;   // ring entries a new face's third vertex is coded against
const TWIN_LIMIT = 4;    // twin candidates a new vertex's position is matched against
const FAN_LIMIT = 32;    // corners a parent may have for a fan-coded split
const FAN_N1 = new Int32Array(FAN_LIMIT), FAN_N2 = new Int32Array(FAN_LIMIT), FAN_MOVED = new Uint8Array(FAN_LIMIT);
const UV_MAX = 4095;     // uv bits (scene/quantize.h)

// Inflates one part (a zlib stream) with the browser's DecompressionStream, refusing output past
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

// LEB128 varint (uint32) at d[p] before `end`: the value, or -1 when cut short or past 32
// bits; the position after it is left in `vpos` (no allocation on the hot path).
let vpos = 0;
function readVarint(d, p, end) {
  if (p >= end) return -1;
  let b = d[p++];
  if (b < 128) { vpos = p; return b; }
  let v = b & 0x7f, scale = 128;
  for (let shift = 7; ; shift += 7, scale *= 128) {
    if (p >= end || shift > 28) return -1;
    b = d[p++];
    if (shift === 28 && (b & 0x70)) return -1;
    v += (b & 0x7f) * scale;
    if (b < 128) break;
  }
  vpos = p;
  return v;
}
// round(sum / n), halves up: floor((2·sum + n) / (2n)).
const mean = (sum, n) => Math.floor((2 * sum + n) / (2 * n));
const PRED = new Int32Array(8);
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

// ---- One streaming mesh ----------------------------------------------------------------------

// Package mesh m on the client: arrays with the full mesh's capacity, the BufferGeometry that
// draws them, the counts received so far, and the state the vertex splits are coded against
// (quantized attributes, each vertex's list of corners: head, then next per corner).
export class StreamMesh {
  constructor(desc, index) {
    this.index = index;
    this.capacityVertices = desc.vertices;
    this.capacityFaces = desc.faces;
    this.bounds = Float64Array.from(desc.bounds);
    const q = desc.quantization || { origin: [0, 0, 0], step: 1 };
    this.origin = Float64Array.from(q.origin);
    this.step = q.step;
    this.quantized = true;  // positions in the grid's integers (the base .glb's nodes dequantize)
    this.vertices = 0;      // vertices received
    this.faces = 0;         // faces received (3 corners each in the index buffer)
    this.solid = 0;         // non-degenerate faces among them
    this.instances = 0;     // objects (× instances) that draw this mesh
    const V = desc.vertices, F = desc.faces;
    this.position = new Float32Array(3 * V);
    this.normal = new Float32Array(3 * V);
    this.uv = new Float32Array(2 * V);
    this.indices = new Uint32Array(3 * F);
    this.qp = new Uint16Array(3 * V);
    this.qn = new Int8Array(3 * V);
    this.qt = new Uint16Array(2 * V);
    this.head = new Int32Array(V).fill(-1);
    this.next = new Int32Array(3 * F);
    this.stamp = new Uint32Array(V);
    this.stampValue = 0;
    this.ring = new Int32Array(RING_LIMIT);
    // Twins (VsplitMesh::twins): an open-addressing table from a parent position to the newest
    // vertex split from a parent there (keys compared through parentOf), and per vertex the
    // twin before it.
    let slots = 1;
    while (slots < 2 * V + 2) slots *= 2;
    this.twinTable = new Int32Array(slots).fill(-1);
    this.twinPrevious = new Int32Array(V).fill(-1);
    this.parentOf = new Int32Array(V).fill(-1);
    // Commit the memory now (load time) rather than page by page while refining.
    for (const a of [this.position, this.normal, this.uv, this.indices, this.qp, this.qn, this.qt, this.next, this.stamp]) a.fill(0);
    const g = this.geometry = new THREE.BufferGeometry();
    g.name = `meshmux_mesh_${index}`;
    const attribute = (array, size) => new THREE.BufferAttribute(array, size).setUsage(THREE.DynamicDrawUsage);
    g.setAttribute('position', this.positionAttribute = attribute(this.position, 3));
    g.setAttribute('normal', this.normalAttribute = attribute(this.normal, 3));
    g.setAttribute('uv', this.uvAttribute = attribute(this.uv, 2));
    g.setIndex(this.indexAttribute = attribute(this.indices, 1));
    this._setBox(desc.bounds);
    g.setDrawRange(0, 0);
  }

  // Bounds of every vertex the stream will ever hold (in the space positions are kept in):
  // culling never hides refined parts.
  _setBox(b) {
    const box = new THREE.Box3().setFromArray(b);
    if (this.quantized) {
      const o = this.origin, s = this.step;
      box.min.set((b[0] - o[0]) / s, (b[1] - o[1]) / s, (b[2] - o[2]) / s);
      box.max.set((b[3] - o[0]) / s, (b[4] - o[1]) / s, (b[5] - o[2]) / s);
    }
    this.geometry.boundingBox = box;
    this.geometry.boundingSphere = box.getBoundingSphere(new THREE.Sphere());
  }

  // Takes the base .glb's vertices into [0, count): their quantized values (read back exactly
  // from the quantized attributes) and what the GPU draws. A base written with float positions
  // (no quantization) keeps mesh units, and stream vertices are dequantized to match.
  setBaseVertices(glbGeometry) {
    const pos = glbGeometry.getAttribute('position'), nrm = glbGeometry.getAttribute('normal');
    const uv = glbGeometry.getAttribute('uv');
    const P = this.position, N = this.normal, T = this.uv, qp = this.qp, qn = this.qn, qt = this.qt;
    const array = pos.array || (pos.data && pos.data.array);
    this.quantized = !pos.normalized && (array instanceof Uint16Array || array instanceof Uint8Array);
    this._setBox(this.bounds);
    const o = this.origin, s = this.step, max = 16383;
    const grid = (x, k) => Math.min(max, Math.max(0, Math.round((x - o[k]) / s)));
    const uvNormalized = uv && uv.normalized;
    for (let i = 0; i < pos.count; i++) {
      const x = pos.getX(i), y = pos.getY(i), z = pos.getZ(i);
      P[3 * i] = x; P[3 * i + 1] = y; P[3 * i + 2] = z;
      if (this.quantized) { qp[3 * i] = x; qp[3 * i + 1] = y; qp[3 * i + 2] = z; }
      else { qp[3 * i] = grid(x, 0); qp[3 * i + 1] = grid(y, 1); qp[3 * i + 2] = grid(z, 2); }
      if (nrm) {
        for (let k = 0; k < 3; k++) {
          const n = k === 0 ? nrm.getX(i) : k === 1 ? nrm.getY(i) : nrm.getZ(i);
          N[3 * i + k] = n;
          qn[3 * i + k] = Math.max(-127, Math.min(127, Math.round(n * 127)));
        }
      } else {
        N[3 * i + 2] = 1; qn[3 * i + 2] = 127;
      }
      if (uv) {
        for (let k = 0; k < 2; k++) {
          const t = k === 0 ? uv.getX(i) : uv.getY(i);
          T[2 * i + k] = t;
          // unorm16 → 12 bits exactly (scene/quantize.h unorm16_to_uv12), or a float quantized.
          qt[2 * i + k] = uvNormalized ? Math.floor((Math.round(t * 65535) * UV_MAX + 32767) / 65535)
            : (t >= 0 ? (t >= 1 ? UV_MAX : Math.round(t * UV_MAX)) : 0);
        }
      }
    }
    this.vertices = pos.count;
  }

  _pushCorner(c, v) {
    this.next[c] = this.head[v];
    this.head[v] = c;
  }

  // Appends base faces (`indices`: a glTF primitive's index array, 3 per face, as the base .glb
  // decoded them) to the index buffer and the corner lists; every corner must name a vertex
  // already received.
  appendIndices(indices) {
    const f = this.faces, I = this.indices, start = 3 * f, corners = indices.length;
    if (corners % 3 !== 0) throw new Error(`mesh ${this.index}: ${corners} base indices are not whole faces`);
    if (f + corners / 3 > this.capacityFaces) throw new Error(`mesh ${this.index}: ${f + corners / 3} faces exceed its capacity ${this.capacityFaces}`);
    let solid = 0;
    for (let i = 0; i < corners; i += 3) {
      const a = indices[i], b = indices[i + 1], c = indices[i + 2], j = start + i;
      if (a >= this.vertices || b >= this.vertices || c >= this.vertices) {
        throw new Error(`mesh ${this.index}: base face ${(j / 3)} names vertex ${Math.max(a, b, c)}, only ${this.vertices} are received`);
      }
      solid += addFace(I, this.head, this.next, j, a, b, c);
    }
    this.solid += solid;
    this.faces = f + corners / 3;
    this.indexAttribute.addUpdateRange(start, corners);
    this.indexAttribute.needsUpdate = true;
    this.geometry.setDrawRange(0, 3 * this.faces);
  }

  // Applies one inflated part: `splits` vertex splits and `faces` new faces (multiplex/vsplit.h).
  // Everything read is checked; an Error names the split and the problem. The hot loop keeps
  // its cursors in locals and calls only small module-level functions (no closures).
  applySplits(d, splits, faces) {
    const I = this.indices, head = this.head, next = this.next, qp = this.qp, qn = this.qn, qt = this.qt;
    const stamp = this.stamp, ring = this.ring, pred = PRED;
    const fail = (message) => new Error(`mesh ${this.index}: ${message}`);
    const len = [];
    let at = 0, total = 0;
    for (let k = 0; k < 10; k++) {
      const l = readVarint(d, at, d.length);
      if (l < 0) throw fail('stream lengths cut short');
      at = vpos;
      len.push(l);
      total += l;
    }
    if (total !== d.length - at) throw fail(`stream lengths add up to ${total} bytes, ${d.length - at} follow`);
    // Streams Z K F M E W P N T A (multiplex/vsplit.h).
    let zp = at; const ze = zp + len[0];
    let kp = ze; const ke = kp + len[1];
    let cp = ke; const ce = cp + len[2];
    const maskStart = ce, maskBits = 8 * len[3];
    let ep = maskStart + len[3]; const ee = ep + len[4];
    let wp = ee; const we = wp + len[5];
    let pp = we; const pe = pp + len[6];
    let np = pe; const ne = np + len[7];
    const normals = len[7] > 0;  // an empty N stream: the mesh carries no normals (flat-shaded)
    let tp = ne; const te = tp + len[8];
    let ap = te; const ae = ap + len[9];
    const table = this.twinTable, tmask = table.length - 1, twinPrevious = this.twinPrevious, parentOf = this.parentOf;
    let maskAt = 0;
    const v0 = this.vertices, f0 = this.faces;
    if (v0 + splits > this.capacityVertices || f0 + faces > this.capacityFaces) throw fail('more vertices or faces than the mesh holds');
    const faceGoal = f0 + faces;
    let nf = f0, solid = this.solid, previous = 0, stampValue = this.stampValue;
    if (stampValue > 0x7fffffff - 2 * splits) { stamp.fill(0); stampValue = 0; }
    for (let i = 0; i < splits; i++) {
      const z = readVarint(d, zp, ze); zp = vpos;
      if (z < 0 || maskAt >= maskBits) throw fail(`split ${i}: connectivity cut short`);
      const fanMode = (d[maskStart + (maskAt >> 3)] >> (maskAt & 7)) & 1;
      maskAt++;
      let k = 2;
      if (!fanMode) { k = readVarint(d, kp, ke); kp = vpos; }
      if (k < 0) throw fail(`split ${i}: face count cut short`);
      const p = previous + (z % 2 ? -(z + 1) / 2 : z / 2), v = v0 + i;
      if (!(p >= 0 && p < v)) throw fail(`split ${i}: parent ${p} of ${v} vertices`);
      previous = p;
      head[v] = -1;
      // Hoppe's split on p's manifold fan (VsplitMesh::fan): the corners from vl's on, each to
      // the one whose first neighbour is its second, `count` of them.
      let vl = -1, vr = -1;
      if (fanMode) {
        // One byte: start << 3 | min(count - 1, 7); a varint count - 8 follows a 7.
        if (ap >= ae) throw fail(`split ${i}: fan arguments cut short`);
        const start = d[ap] >> 3;
        let count = (d[ap++] & 7) + 1;
        if (count === 8) {
          const more = readVarint(d, ap, ae); ap = vpos;
          if (more < 0 || more > FAN_LIMIT) throw fail(`split ${i}: fan arguments cut short`);
          count += more;
        }
        if (start < 0 || count <= 0) throw fail(`split ${i}: fan arguments cut short`);
        let nd = 0, ok = true;
        for (let c = head[p]; c >= 0 && ok; c = next[c]) {
          if (nd === FAN_LIMIT) { ok = false; break; }
          const f = c - (c % 3), slot = c - f, a = I[f + (slot + 1) % 3], b = I[f + (slot + 2) % 3];
          if (a === p || b === p || a === b) ok = false;
          for (let j = 0; j < nd && ok; j++) if (FAN_N1[j] === a) ok = false;
          FAN_N1[nd] = a; FAN_N2[nd] = b; FAN_MOVED[nd] = 0; nd++;
        }
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
      }
      // The corners of p in list order that move to v: the fan's, or the mask's 1 bits.
      for (let c = head[p], prev = -1, position = 0; c >= 0; position++) {
        const after = next[c];
        let take;
        if (fanMode) take = FAN_MOVED[position];
        else {
          if (maskAt >= maskBits) throw fail(`split ${i}: corner mask cut short`);
          take = (d[maskStart + (maskAt >> 3)] >> (maskAt & 7)) & 1;
          maskAt++;
        }
        if (take) {
          if (prev < 0) head[p] = after; else next[prev] = after;
          const f = c - (c % 3);
          solid -= faceSolid(I, f);
          I[c] = v;
          solid += faceSolid(I, f);
          next[c] = head[v]; head[v] = c;
        } else {
          prev = c;
        }
        c = after;
      }
      // One walk of v's corners (the moved ones) gives both the start of the ring (v's
      // neighbours, then p's: see VsplitMesh::ring) and most of the prediction set (every
      // neighbour of v after the split: these, p when a face joins them, the new faces' third
      // vertices); p's corners are walked only as far as a face code reaches into the ring.
      const sA = ++stampValue, sB = ++stampValue;
      stamp[v] = stamp[p] = sA;
      let ringSize = 0, n = 0, s0 = 0, s1 = 0, s2 = 0, n0 = 0, n1 = 0, n2 = 0, t0 = 0, t1 = 0, pNear = k > 0;
      for (let c = head[v]; c >= 0; c = next[c]) {
        const f = c - (c % 3), slot = c - f;
        for (let j = 1; j <= 2; j++) {
          const w = I[f + (slot + j) % 3];
          if (stamp[w] === sA) { if (w === p) pNear = true; continue; }
          stamp[w] = sA;
          if (ringSize < RING_LIMIT) ring[ringSize++] = w;
          s0 += qp[3 * w]; s1 += qp[3 * w + 1]; s2 += qp[3 * w + 2];
          n0 += qn[3 * w]; n1 += qn[3 * w + 1]; n2 += qn[3 * w + 2];
          t0 += qt[2 * w]; t1 += qt[2 * w + 1];
          n++;
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
          const code = readVarint(d, cp, ce); cp = vpos;
          if (code < 0) throw fail(`split ${i}: face codes cut short`);
          const index = code >>> 1;
          flip = code & 1;
          while (index >= ringSize && ringSize < RING_LIMIT && pc >= 0) {
            const f = pc - (pc % 3), u = I[f + (pc - f + pSlot) % 3];
            if (pSlot === 2) { pSlot = 1; pc = next[pc]; } else pSlot = 2;
            if (stamp[u] === sA || stamp[u] === sB) continue;
            stamp[u] = sB;
            ring[ringSize++] = u;
          }
          if (index < ringSize) w = ring[index];
          else if (index === ringSize && (ringSize >= RING_LIMIT || pc < 0)) {
            w = readVarint(d, ep, ee); ep = vpos;
            if (w < 0) throw fail(`split ${i}: escaped vertices cut short`);
            if (w >= v || w === p) throw fail(`split ${i}: face names vertex ${w}`);
          } else throw fail(`split ${i}: ring position ${index} of ${ringSize}`);
        }
        solid += flip ? addFace(I, head, next, 3 * nf, v, w, p) : addFace(I, head, next, 3 * nf, v, p, w);
        nf++;
        if (stamp[w] !== sA) {  // a neighbour of v not met among the moved corners
          stamp[w] = sA;
          s0 += qp[3 * w]; s1 += qp[3 * w + 1]; s2 += qp[3 * w + 2];
          n0 += qn[3 * w]; n1 += qn[3 * w + 1]; n2 += qn[3 * w + 2];
          t0 += qt[2 * w]; t1 += qt[2 * w + 1];
          n++;
        }
      }
      if (pNear) {
        s0 += qp[3 * p]; s1 += qp[3 * p + 1]; s2 += qp[3 * p + 2];
        n0 += qn[3 * p]; n1 += qn[3 * p + 1]; n2 += qn[3 * p + 2];
        t0 += qt[2 * p]; t1 += qt[2 * p + 1];
        n++;
      }
      // Attributes: the mean of v's neighbours (or p's values) plus the residuals.
      if (n === 0) {
        pred[0] = qp[3 * p]; pred[1] = qp[3 * p + 1]; pred[2] = qp[3 * p + 2];
        pred[3] = qn[3 * p]; pred[4] = qn[3 * p + 1]; pred[5] = qn[3 * p + 2];
        pred[6] = qt[2 * p]; pred[7] = qt[2 * p + 1];
      } else {
        pred[0] = mean(s0, n); pred[1] = mean(s1, n); pred[2] = mean(s2, n);
        pred[3] = mean(n0, n); pred[4] = mean(n1, n); pred[5] = mean(n2, n);
        pred[6] = mean(t0, n); pred[7] = mean(t1, n);
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
        pick = readVarint(d, wp, we); wp = vpos;
        let t = table[slot], n = 1;
        for (; n < pick && t >= 0 && n < TWIN_LIMIT; n++) t = twinPrevious[t];
        if (pick < 0 || pick > TWIN_LIMIT || (pick > 0 && (t < 0 || n !== pick))) throw fail(`split ${i}: twin index missing or past the candidates`);
        if (pick > 0) { qp[3 * v] = qp[3 * t]; qp[3 * v + 1] = qp[3 * t + 1]; qp[3 * v + 2] = qp[3 * t + 2]; }
      }
      for (let j = 0; j < 3 && pick === 0; j++) {
        const r = readVarint(d, pp, pe); pp = vpos;
        if (r < 0) throw fail(`split ${i}: positions cut short`);
        const x = pred[j] + (r % 2 ? -(r + 1) / 2 : r / 2);
        if (x < 0 || x > 65535) throw fail(`split ${i}: attribute out of range`);
        qp[3 * v + j] = x;
      }
      for (let j = 0; j < 3 && !normals; j++) qn[3 * v + j] = j === 2 ? 127 : 0;  // flat: +Z
      for (let j = 0; j < 3 && normals; j++) {
        const r = readVarint(d, np, ne); np = vpos;
        if (r < 0) throw fail(`split ${i}: normals cut short`);
        const x = pred[3 + j] + (r % 2 ? -(r + 1) / 2 : r / 2);
        if (x < -128 || x > 127) throw fail(`split ${i}: attribute out of range`);
        qn[3 * v + j] = x;
      }
      predictUv(I, head, next, qp, qt, v, p, pred);  // from v's position, when a face allows
      for (let j = 0; j < 2; j++) {
        const r = readVarint(d, tp, te); tp = vpos;
        if (r < 0) throw fail(`split ${i}: texture coordinates cut short`);
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
    const extra = readVarint(d, kp, ke); kp = vpos;
    if (extra < 0) throw fail('extra face count missing');
    if (nf + extra !== faceGoal) throw fail(`${faceGoal - nf} faces expected, ${extra} extra faces follow the splits`);
    const vn = v0 + splits;
    for (let j = 0; j < extra; j++) {
      const a = readVarint(d, ep, ee); ep = vpos;
      const b = readVarint(d, ep, ee); ep = vpos;
      const c = readVarint(d, ep, ee); ep = vpos;
      if (a < 0 || b < 0 || c < 0) throw fail('extra faces cut short');
      if (a >= vn || b >= vn || c >= vn) throw fail(`extra face ${j} names a vertex not received`);
      solid += addFace(I, head, next, 3 * nf, a, b, c);
      nf++;
    }
    if (zp !== ze || kp !== ke || cp !== ce || ep !== ee || wp !== we || pp !== pe || np !== ne || tp !== te || ap !== ae) throw fail('a stream has bytes left over');
    if (maskBits - maskAt >= 8) throw fail('corner mask has bytes left over');
    // What the GPU draws: the new vertices, and the whole index buffer (corners moved anywhere).
    const P = this.position, N = this.normal, T = this.uv, o = this.origin, st = this.step;
    for (let v = v0; v < vn; v++) {
      if (this.quantized) { P[3 * v] = qp[3 * v]; P[3 * v + 1] = qp[3 * v + 1]; P[3 * v + 2] = qp[3 * v + 2]; }
      else { P[3 * v] = o[0] + qp[3 * v] * st; P[3 * v + 1] = o[1] + qp[3 * v + 1] * st; P[3 * v + 2] = o[2] + qp[3 * v + 2] * st; }
      N[3 * v] = qn[3 * v] / 127; N[3 * v + 1] = qn[3 * v + 1] / 127; N[3 * v + 2] = qn[3 * v + 2] / 127;
      T[2 * v] = qt[2 * v] / UV_MAX; T[2 * v + 1] = qt[2 * v + 1] / UV_MAX;
    }
    this.vertices = vn;
    this.faces = nf;
    this.solid = solid;
    if (splits > 0) {
      this.positionAttribute.addUpdateRange(3 * v0, 3 * splits);
      this.normalAttribute.addUpdateRange(3 * v0, 3 * splits);
      this.uvAttribute.addUpdateRange(2 * v0, 2 * splits);
      this.positionAttribute.needsUpdate = this.normalAttribute.needsUpdate = this.uvAttribute.needsUpdate = true;
    }
    this.indexAttribute.clearUpdateRanges();
    this.indexAttribute.addUpdateRange(0, 3 * nf);
    this.indexAttribute.needsUpdate = true;
    this.geometry.setDrawRange(0, 3 * nf);
  }

  dispose() { this.geometry.dispose(); }
}

// Applies one mesh chunk's payload to the stream meshes: every part's zlib stream is inflated
// at once (the browser works on them together), then the parts' splits are applied in order.
// Resolves with the faces added.
export async function applyMeshChunk(meshes, chunk, payload) {
  // The payload is one raw deflate stream of every part's bytes (n each, inflated).
  let total = 0;
  for (const part of chunk.parts) {
    const limit = PART_BYTES_PER_ELEMENT * (part.vertex_end - part.vertex_begin + part.face_end - part.face_begin) + PART_BYTES_CONSTANT;
    if (part.bytes > limit) throw new Error(`mesh ${part.mesh}: a part of ${part.bytes} bytes is more than its splits may take`);
    total += part.bytes;
  }
  let plain;
  try {
    plain = total > 0 ? await inflate(payload, total, 'deflate-raw') : new Uint8Array(0);
  } catch (e) {
    throw new Error(`mesh chunk: ${e.message}`);
  }
  if (plain.length !== total) throw new Error(`mesh chunk: inflates to ${plain.length} bytes, its parts hold ${total}`);
  let added = 0, at = 0;
  for (let k = 0; k < chunk.parts.length; k++) {
    const part = chunk.parts[k], mesh = meshes[part.mesh];
    if (part.vertex_begin !== mesh.vertices || part.face_begin !== mesh.faces) {
      throw new Error(`mesh ${part.mesh}: part starts at vertex ${part.vertex_begin}, face ${part.face_begin}, ` +
        `but ${mesh.vertices} vertices and ${mesh.faces} faces are received`);
    }
    const d = plain.subarray(at, at += part.bytes);
    const faces = part.face_end - part.face_begin;
    mesh.applySplits(d, part.vertex_end - part.vertex_begin, faces);
    added += faces;
  }
  return added;
}
