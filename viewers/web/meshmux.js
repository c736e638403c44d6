// meshmux.js — the web client of meshmux stream packages (model.mmxp, version 2).
//
// A package is one file: a 12-byte header ("MMXP", version, JSON length), a JSON table, a base
// .glb any glTF viewer opens, each mesh's base faces, then chunks (mesh refinements and texture
// levels) in rate-distortion order. Everything is fetched with HTTP Range requests:
//
//   const stream = new MeshmuxStream('model.mmxp', { renderer });
//   scene.add(await stream.open());      // the base, shown at once
//   stream.addEventListener('chunk', render);
//   await stream.play();                 // refinements and texture levels, chunk by chunk
//
// Per package mesh the client keeps ONE BufferGeometry with the capacity of the full mesh: a
// vertex buffer that is only appended to and an index buffer of every face received so far
// (degenerate faces included; later updates may open them up). Each applied part writes into
// those arrays and marks only the changed ranges for upload. Everything is drawn with one shared
// shading (base colour × texture × two-sided Lambert with a light that follows the camera, no
// colour management), matching meshmux's offscreen renderer.
//
// Events (CustomEvent, detail = a copy of `stats` unless said): 'base' (the base is built),
// 'chunk' (one chunk applied; detail also has `chunk` and `kind`), 'progress' (bytes changed),
// 'complete' (every chunk applied), 'stopped' (budget reached or stop()), 'error'
// (detail {error, stats}).

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';

export const PACKAGE_VERSION = 2;
export const VERTEX_BYTES = 20;            // packed vertex: pos 3×u16 + pad, normal 4×i8, uv 2×u16, parent u32
const HEADER_BYTES = 12;
const PROBE_BYTES = 65536;                 // the first request: header, JSON and usually more
const MAX_ELEMENTS = 1 << 27;              // sanity cap on vertices / faces of one mesh
const RANGE_GAP = 1024;                    // index updates closer than this share one upload range
const LIGHT = new THREE.Vector3(0.4, 0.8, 0.45).normalize();  // view space, towards the light
export const ORDER_NAMES = ['rate-distortion', 'mesh-first', 'texture-first', 'constant-ratio'];

// ---- Scratch memory for decoding (grown on demand, never shrunk) -------------------------------

let scratch = new ArrayBuffer(1 << 16);
let scratchU8 = new Uint8Array(scratch);
let scratchU16 = new Uint16Array(scratch);
let scratchI8 = new Int8Array(scratch);
let scratchU32 = new Uint32Array(scratch);

function ensureScratch(bytes) {
  if (scratch.byteLength >= bytes) return;
  let size = scratch.byteLength;
  while (size < bytes) size *= 2;
  scratch = new ArrayBuffer(size);
  scratchU8 = new Uint8Array(scratch);
  scratchU16 = new Uint16Array(scratch);
  scratchI8 = new Int8Array(scratch);
  scratchU32 = new Uint32Array(scratch);
}

// ---- Hot loops (plain functions over typed arrays, warmed up once per page) -------------------

// Dequantizes `count` packed vertices (u16/i8 views of the decoded bytes) into the float
// attributes from vertex `first` on. Per vertex: u16 words 0..2 position (3 pad), bytes 8..10
// normal, u16 words 6..7 uv, words 8..9 parent (informational, unused here).
export function dequantize(u16, i8, count, bounds, P, N, T, first) {
  const x0 = bounds[0], y0 = bounds[1], z0 = bounds[2];
  const sx = (bounds[3] - x0) / 65535, sy = (bounds[4] - y0) / 65535, sz = (bounds[5] - z0) / 65535;
  const n = 1 / 127, t = 1 / 65535;
  let w = 0, p3 = 3 * first, p2 = 2 * first;
  for (let i = 0; i < count; i++) {
    P[p3] = x0 + u16[w] * sx;
    P[p3 + 1] = y0 + u16[w + 1] * sy;
    P[p3 + 2] = z0 + u16[w + 2] * sz;
    const b = 2 * w;
    N[p3] = i8[b + 8] * n;
    N[p3 + 1] = i8[b + 9] * n;
    N[p3 + 2] = i8[b + 10] * n;
    T[p2] = u16[w + 6] * t;
    T[p2 + 1] = u16[w + 7] * t;
    w += 10;
    p3 += 3;
    p2 += 2;
  }
}

// Counts the non-degenerate faces among corners [start, end) of I; returns -(k + 1) for the
// first face k·3 naming a vertex >= limit.
export function scanFaces(I, start, end, limit) {
  let solid = 0;
  for (let i = start; i < end; i += 3) {
    const a = I[i], b = I[i + 1], c = I[i + 2];
    if (a >= limit || b >= limit || c >= limit) return -(i + 1);
    if (a !== b && b !== c && a !== c) solid++;
  }
  return solid;
}

// Applies u corner updates (S[0..u) ascending positions, S[u..2u) values) to index buffer I,
// marking upload ranges on `attribute` (nearby faces share one). Returns the change of the
// non-degenerate face count, or UPDATE_ERROR (details in updateError).
const UPDATE_ERROR = -0x7fffffff;
const updateError = { i: 0, p: 0, v: 0 };
export function applyCornerUpdates(I, S, u, corners, limit, attribute) {
  let prev = -1, delta = 0, face = -1, rangeStart = -1, rangeEnd = -RANGE_GAP;
  for (let i = 0; i < u; i++) {
    const p = S[i], v = S[u + i];
    if (p <= prev || p >= corners || v >= limit) {
      updateError.i = i; updateError.p = p; updateError.v = v;
      return UPDATE_ERROR;
    }
    const f3 = p - (p % 3);
    if (f3 !== face) {
      // A new face: settle the previous one's status change, note this one's status before.
      if (face >= 0) {
        const a = I[face], b = I[face + 1], c = I[face + 2];
        if (a !== b && b !== c && a !== c) delta++;
      }
      const a = I[f3], b = I[f3 + 1], c = I[f3 + 2];
      if (a !== b && b !== c && a !== c) delta--;
      face = f3;
      // Upload ranges: faces closer than RANGE_GAP corners share one.
      if (f3 - rangeEnd >= RANGE_GAP) {
        if (rangeStart >= 0) attribute.addUpdateRange(rangeStart, rangeEnd - rangeStart);
        rangeStart = f3;
      }
      rangeEnd = f3 + 3;
    }
    I[p] = v;
    prev = p;
  }
  if (face >= 0) {
    const a = I[face], b = I[face + 1], c = I[face + 2];
    if (a !== b && b !== c && a !== c) delta++;
    attribute.addUpdateRange(rangeStart, rangeEnd - rangeStart);
  }
  return delta;
}

// Prepares the decode path before the first chunk is applied (called while its bytes are on
// their way): a cold first chunk runs several times slower than the rest.
//  - Grows the decoder's WebAssembly heap to `heapBytes` (the largest decode ahead) up front.
//    Growing detaches the heap's old ArrayBuffer, and V8 then discards all code it optimized on
//    the assumption that no ArrayBuffer was ever detached: better now than mid-stream.
//  - Runs the three decoders (compiled lazily) and the three loops (interpreted at first) on
//    synthetic data until the engine has optimized them.
// Costs a few milliseconds once per page, plus the heap growth.
let warmedUp = false, heapReserved = 0;
function warmUp(heapBytes) {
  if (heapBytes > heapReserved) {
    // A zero index sequence of n values needs 4n + n + 5 heap bytes.
    const n = Math.ceil(heapBytes / 5);
    const source = new Uint8Array(n + 5);
    source[0] = 0xd0;
    try {
      MeshoptDecoder.decodeIndexSequence(new Uint8Array(4 * n), n, 4, source);
      heapReserved = heapBytes;
    } catch (e) {
      // Only a reservation: the real decodes grow the heap themselves.
    }
  }
  if (warmedUp) return;
  warmedUp = true;
  try {
    // Valid codec streams of zeros: 1024 vertices (header 0xa0; per 256-vertex block and byte
    // channel 4 zero group headers; a 32-byte tail), 1024 sequence values (header 0xd0, one zero
    // byte each, 4-byte tail) and two triangles (0,1,2)(2,1,3) as meshoptimizer encodes them.
    const vertices = new Uint8Array(1 + 4 * 20 * 4 + 32), sequence = new Uint8Array(1 + 1024 + 4);
    vertices[0] = 0xa0;
    sequence[0] = 0xd0;
    const triangles = new Uint8Array([0xe0, 0xf0, 0x10, 0x00, 0x76, 0x87, 0x56, 0x67, 0x78, 0xa9, 0x86, 0x65, 0x89, 0x68, 0x98, 0x01, 0x69, 0x00, 0x00]);
    ensureScratch(1024 * VERTEX_BYTES);
    for (let k = 0; k < 64; k++) {
      MeshoptDecoder.decodeVertexBuffer(scratchU8.subarray(0, 1024 * VERTEX_BYTES), 1024, VERTEX_BYTES, vertices);
      MeshoptDecoder.decodeIndexSequence(scratchU8.subarray(0, 4096), 1024, 4, sequence);
      MeshoptDecoder.decodeIndexBuffer(scratchU8.subarray(0, 24), 6, 4, triangles);
    }
  } catch (e) {
    // Only a warm-up: a decoder that rejects these streams still decodes real ones.
  }
  const n = 2048, u16 = new Uint16Array(10 * n), i8 = new Int8Array(u16.buffer);
  for (let i = 0; i < u16.length; i++) u16[i] = (i * 7919) & 0xffff;
  const P = new Float32Array(3 * n), N = new Float32Array(3 * n), T = new Float32Array(2 * n);
  const I = new Uint32Array(3 * n), S = new Uint32Array(2 * n);
  let seed = 12345;
  const random = (m) => { seed = (Math.imul(seed, 1103515245) + 12345) >>> 0; return (seed >>> 8) % m; };
  for (let i = 0; i < I.length; i++) I[i] = random(n);
  // Mostly nearby corners, now and then a jump past RANGE_GAP (a new upload range).
  for (let i = 0, p = 0; i < n; i++) { p += 1 + (random(32) === 0 ? RANGE_GAP + random(64) : random(3)); S[i] = p; S[n + i] = random(n); }
  const corners = S[n - 1] + 1, J = new Uint32Array(corners + 3);  // whole faces
  const bounds = new Float64Array([-0.5, -0.5, -0.5, 0.5, 0.5, 0.5]);
  const sink = new THREE.BufferAttribute(new Uint32Array(3), 1);
  // Many short calls first (so each function is optimized whole, with feedback from every
  // branch, rather than mid-loop), then a few long ones.
  for (let k = 0; k < 400; k++) {
    const m = 16 + (k % 48), at = (k * 37) % (n - 64);
    dequantize(u16, i8, m, bounds, P, N, T, at);
    scanFaces(I, 3 * at, 3 * (at + m), n);
    const Sm = new Uint32Array(2 * m);
    for (let i = 0; i < m; i++) { Sm[i] = S[at + i]; Sm[m + i] = S[n + at + i]; }
    applyCornerUpdates(J, Sm, m, corners, n, sink);
    sink.clearUpdateRanges();
  }
  for (let k = 0; k < 4; k++) {
    dequantize(u16, i8, n, bounds, P, N, T, 0);
    scanFaces(I, 0, I.length, n);
    applyCornerUpdates(J, S, n, corners, n, sink);
    sink.clearUpdateRanges();
  }
}

// ---- One streaming mesh ----------------------------------------------------------------------

// The client-side state of package mesh m: typed arrays with the full mesh's capacity, the
// BufferGeometry drawing them, and the counts received so far. The three append/update methods
// are the whole refinement path (exported for tests); each validates what it decodes.
export class StreamMesh {
  constructor(desc, index) {
    this.index = index;
    this.capacityVertices = desc.vertices;
    this.capacityFaces = desc.faces;
    this.bounds = Float64Array.from(desc.bounds);
    this.vertices = 0;        // vertices received
    this.faces = 0;           // faces received (index buffer holds 3 × faces corners)
    this.solid = 0;           // non-degenerate faces among them
    this.instances = 0;       // objects (× instances) drawing this mesh in the scene
    this.position = new Float32Array(3 * desc.vertices);
    this.normal = new Float32Array(3 * desc.vertices);
    this.uv = new Float32Array(2 * desc.vertices);
    this.indices = new Uint32Array(3 * desc.faces);
    // Touch every page now (load time) rather than on first write while refining.
    for (const a of [this.position, this.normal, this.uv, this.indices]) a.fill(0);

    const g = new THREE.BufferGeometry();
    g.name = `meshmux_mesh_${index}`;
    this.positionAttribute = new THREE.BufferAttribute(this.position, 3).setUsage(THREE.DynamicDrawUsage);
    this.normalAttribute = new THREE.BufferAttribute(this.normal, 3).setUsage(THREE.DynamicDrawUsage);
    this.uvAttribute = new THREE.BufferAttribute(this.uv, 2).setUsage(THREE.DynamicDrawUsage);
    this.indexAttribute = new THREE.BufferAttribute(this.indices, 1).setUsage(THREE.DynamicDrawUsage);
    g.setAttribute('position', this.positionAttribute);
    g.setAttribute('normal', this.normalAttribute);
    g.setAttribute('uv', this.uvAttribute);
    g.setIndex(this.indexAttribute);
    // Bounds of every vertex the stream will ever hold, so culling never hides refined parts.
    const [x0, y0, z0, x1, y1, z1] = desc.bounds;
    g.boundingBox = new THREE.Box3(new THREE.Vector3(x0, y0, z0), new THREE.Vector3(x1, y1, z1));
    g.boundingSphere = g.boundingBox.getBoundingSphere(new THREE.Sphere());
    g.setDrawRange(0, 0);
    this.geometry = g;
  }

  // Copies the base .glb's vertices (any accessor layout) into [0, count).
  setBaseVertices(glbGeometry) {
    const pos = glbGeometry.getAttribute('position');
    const nrm = glbGeometry.getAttribute('normal');
    const uv = glbGeometry.getAttribute('uv');
    const n = pos.count;
    for (let i = 0; i < n; i++) {
      this.position[3 * i] = pos.getX(i);
      this.position[3 * i + 1] = pos.getY(i);
      this.position[3 * i + 2] = pos.getZ(i);
      if (nrm) {
        this.normal[3 * i] = nrm.getX(i);
        this.normal[3 * i + 1] = nrm.getY(i);
        this.normal[3 * i + 2] = nrm.getZ(i);
      }
      if (uv) {
        this.uv[2 * i] = uv.getX(i);
        this.uv[2 * i + 1] = uv.getY(i);
      }
    }
    this.vertices = n;
  }

  // Decodes meshopt vertex-codec bytes of vertices [this.vertices, this.vertices + count) and
  // dequantizes them into the float attributes.
  appendVertices(source, count) {
    const a = this.vertices;
    if (a + count > this.capacityVertices) throw new Error(`mesh ${this.index}: ${a + count} vertices exceed the capacity ${this.capacityVertices}`);
    ensureScratch(count * VERTEX_BYTES);
    MeshoptDecoder.decodeVertexBuffer(scratchU8.subarray(0, count * VERTEX_BYTES), count, VERTEX_BYTES, source);
    dequantize(scratchU16, scratchI8, count, this.bounds, this.position, this.normal, this.uv, a);
    this.positionAttribute.addUpdateRange(3 * a, 3 * count);
    this.normalAttribute.addUpdateRange(3 * a, 3 * count);
    this.uvAttribute.addUpdateRange(2 * a, 2 * count);
    this.positionAttribute.needsUpdate = this.normalAttribute.needsUpdate = this.uvAttribute.needsUpdate = true;
    this.vertices = a + count;
  }

  // Decodes meshopt index-codec bytes of `faceCount` new faces straight into the index buffer
  // after the faces received so far. Every corner must name a vertex already received.
  appendFaces(source, faceCount) {
    const f = this.faces;
    if (f + faceCount > this.capacityFaces) throw new Error(`mesh ${this.index}: ${f + faceCount} faces exceed the capacity ${this.capacityFaces}`);
    const I = this.indices, start = 3 * f, corners = 3 * faceCount;
    MeshoptDecoder.decodeIndexBuffer(new Uint8Array(I.buffer, I.byteOffset + 4 * start, 4 * corners), corners, 4, source);
    const limit = this.vertices;
    const solid = scanFaces(I, start, start + corners, limit);
    if (solid < 0) {
      const i = -solid - 1;
      throw new Error(`mesh ${this.index}: face ${i / 3} names vertex ${Math.max(I[i], I[i + 1], I[i + 2])} but only ${limit} are received`);
    }
    this.solid += solid;
    this.faces = f + faceCount;
    this.indexAttribute.addUpdateRange(start, corners);
    this.indexAttribute.needsUpdate = true;
    this.geometry.setDrawRange(0, 3 * this.faces);
  }

  // Decodes meshopt index-sequence bytes of 2u uint32 (u ascending corner positions, then u
  // vertex values) and moves those corners; keeps the non-degenerate face count exact.
  applyUpdates(source, u) {
    ensureScratch(8 * u);
    MeshoptDecoder.decodeIndexSequence(scratchU8.subarray(0, 8 * u), 2 * u, 4, source);
    const delta = applyCornerUpdates(this.indices, scratchU32, u, 3 * this.faces, this.vertices, this.indexAttribute);
    if (delta === UPDATE_ERROR) {
      throw new Error(`mesh ${this.index}: update ${updateError.i} moves corner ${updateError.p} to vertex ${updateError.v} ` +
        `(${3 * this.faces} corners and ${this.vertices} vertices received; positions must ascend)`);
    }
    if (u > 0) this.indexAttribute.needsUpdate = true;
    this.solid += delta;
  }

  dispose() { this.geometry.dispose(); }
}

// Applies one mesh chunk's payload (bytes of exactly chunk.size) to the stream meshes, part by
// part: vertices, then updates, then new faces. Returns the faces touched (new + updated).
export function applyMeshChunk(meshes, chunk, payload) {
  let at = 0, touched = 0;
  for (const part of chunk.parts) {
    const mesh = meshes[part.mesh];
    if (part.vertex_begin !== mesh.vertices || part.face_begin !== mesh.faces) {
      throw new Error(`mesh ${part.mesh}: part starts at vertex ${part.vertex_begin}, face ${part.face_begin} ` +
        `but ${mesh.vertices} vertices and ${mesh.faces} faces are received`);
    }
    const nv = part.vertex_end - part.vertex_begin, nf = part.face_end - part.face_begin;
    if (part.vertex_bytes > 0) mesh.appendVertices(payload.subarray(at, at + part.vertex_bytes), nv);
    at += part.vertex_bytes;
    const indexBytes = payload.subarray(at, at + part.index_bytes);
    at += part.index_bytes;
    if (part.update_bytes > 0) mesh.applyUpdates(payload.subarray(at, at + part.update_bytes), part.updates);
    at += part.update_bytes;
    if (part.index_bytes > 0) mesh.appendFaces(indexBytes, nf);
    touched += nf + part.updates;
  }
  return touched;
}

// ---- The package table ---------------------------------------------------------------------

// Validates the parsed JSON table against the file and returns it normalized (numbers checked,
// per-order distortion lists filled in). `fail(message)` builds the Error to throw.
export function validateTable(t, { fileSize, dataStart, fail }) {
  const obj = (v, what) => { if (!v || typeof v !== 'object' || Array.isArray(v)) throw fail(`${what} must be an object`); return v; };
  const arr = (v, what) => { if (!Array.isArray(v)) throw fail(`${what} must be an array`); return v; };
  const int = (v, what, max = Number.MAX_SAFE_INTEGER) => {
    if (!Number.isSafeInteger(v) || v < 0 || v > max) throw fail(`${what} must be an integer in [0, ${max}] (got ${JSON.stringify(v)})`);
    return v;
  };
  const dist = (v, what) => {
    if (v === undefined || v === null) return NaN;
    if (typeof v !== 'number' || !Number.isFinite(v)) throw fail(`${what} must be a finite number`);
    return v;
  };
  const range = (r, what) => {
    const offset = int(r.offset, `${what}.offset`), size = int(r.size, `${what}.size`);
    if (size > 0 && offset < dataStart) throw fail(`${what} starts at ${offset}, inside the header/table (ends at ${dataStart})`);
    if (Number.isFinite(fileSize) && offset + size > fileSize) throw fail(`${what} [${offset}, ${offset + size}) runs past the end of the file (${fileSize} bytes)`);
    return { offset, size };
  };

  obj(t, 'the table');
  if (t.version !== PACKAGE_VERSION) throw fail(`table version ${JSON.stringify(t.version)} (expected ${PACKAGE_VERSION})`);
  const baseDef = obj(t.base, 'base');
  const base = { ...range(baseDef, 'base'), distortion: dist(baseDef.distortion, 'base.distortion') };
  if (base.size < 20) throw fail(`base .glb is ${base.size} bytes, too small to be a glb`);

  const meshes = arr(t.meshes, 'meshes').map((m, i) => {
    const w = `meshes[${i}]`;
    obj(m, w);
    const d = {
      vertices: int(m.vertices, `${w}.vertices`, MAX_ELEMENTS),
      faces: int(m.faces, `${w}.faces`, MAX_ELEMENTS),
      base_vertices: int(m.base_vertices, `${w}.base_vertices`),
      base_faces: int(m.base_faces, `${w}.base_faces`),
      bounds: arr(m.bounds, `${w}.bounds`),
      base_indices: range(obj(m.base_indices, `${w}.base_indices`), `${w}.base_indices`),
    };
    if (d.base_vertices > d.vertices) throw fail(`${w}: base_vertices ${d.base_vertices} > vertices ${d.vertices}`);
    if (d.base_faces > d.faces) throw fail(`${w}: base_faces ${d.base_faces} > faces ${d.faces}`);
    if (d.bounds.length !== 6 || !d.bounds.every(Number.isFinite)) throw fail(`${w}.bounds must be 6 finite numbers`);
    if ((d.base_faces > 0) !== (d.base_indices.size > 0)) throw fail(`${w}: ${d.base_faces} base faces but ${d.base_indices.size} base_indices bytes`);
    return d;
  });

  let texture = null;
  if (t.texture !== null && t.texture !== undefined) {
    obj(t.texture, 'texture');
    texture = { width: int(t.texture.width, 'texture.width'), height: int(t.texture.height, 'texture.height') };
  }

  // Chunks, with the mesh parts simulated in stream order: every part must continue exactly
  // where the previous one of its mesh ended.
  const held = meshes.map((m) => ({ vertices: m.base_vertices, faces: m.base_faces }));
  const chunks = arr(t.chunks, 'chunks').map((c, i) => {
    const w = `chunks[${i}]`;
    obj(c, w);
    const chunk = { kind: c.kind, ...range(c, w), distortion: dist(c.distortion, `${w}.distortion`) };
    if (c.kind === 'texture') {
      chunk.width = int(c.width, `${w}.width`);
      chunk.height = int(c.height, `${w}.height`);
      if (!/^image\/(jpeg|png|webp)$/.test(c.mime)) throw fail(`${w}.mime ${JSON.stringify(c.mime)} is not image/jpeg or image/png`);
      chunk.mime = c.mime;
      if (chunk.size === 0) throw fail(`${w}: empty texture chunk`);
      return chunk;
    }
    if (c.kind !== 'mesh') throw fail(`${w}.kind ${JSON.stringify(c.kind)} is neither "mesh" nor "texture"`);
    let bytes = 0;
    chunk.parts = arr(c.parts, `${w}.parts`).map((p, j) => {
      const pw = `${w}.parts[${j}]`;
      obj(p, pw);
      const part = {
        mesh: int(p.mesh, `${pw}.mesh`, meshes.length - 1),
        vertex_begin: int(p.vertex_begin, `${pw}.vertex_begin`), vertex_end: int(p.vertex_end, `${pw}.vertex_end`),
        face_begin: int(p.face_begin, `${pw}.face_begin`), face_end: int(p.face_end, `${pw}.face_end`),
        vertex_bytes: int(p.vertex_bytes, `${pw}.vertex_bytes`), index_bytes: int(p.index_bytes, `${pw}.index_bytes`),
        updates: int(p.updates ?? 0, `${pw}.updates`), update_bytes: int(p.update_bytes ?? 0, `${pw}.update_bytes`),
      };
      const m = meshes[part.mesh], h = held[part.mesh];
      if (part.vertex_begin !== h.vertices) throw fail(`${pw}: vertex_begin ${part.vertex_begin} but mesh ${part.mesh} holds ${h.vertices} vertices at that point`);
      if (part.face_begin !== h.faces) throw fail(`${pw}: face_begin ${part.face_begin} but mesh ${part.mesh} holds ${h.faces} faces at that point`);
      if (part.vertex_end < part.vertex_begin || part.vertex_end > m.vertices) throw fail(`${pw}: vertex_end ${part.vertex_end} outside [${part.vertex_begin}, ${m.vertices}]`);
      if (part.face_end < part.face_begin || part.face_end > m.faces) throw fail(`${pw}: face_end ${part.face_end} outside [${part.face_begin}, ${m.faces}]`);
      if (part.updates > 3 * h.faces) throw fail(`${pw}: ${part.updates} updates but only ${3 * h.faces} corners are held`);
      const pieces = [['vertices', part.vertex_end - part.vertex_begin, part.vertex_bytes],
        ['faces', part.face_end - part.face_begin, part.index_bytes], ['updates', part.updates, part.update_bytes]];
      for (const [name, count, size] of pieces) {
        if ((count > 0) !== (size > 0)) throw fail(`${pw}: ${count} ${name} stored in ${size} bytes`);
      }
      h.vertices = part.vertex_end;
      h.faces = part.face_end;
      bytes += part.vertex_bytes + part.index_bytes + part.update_bytes;
      return part;
    });
    if (bytes !== chunk.size) throw fail(`${w}: its parts hold ${bytes} bytes but the chunk is ${chunk.size}`);
    return chunk;
  });
  const n = chunks.length;

  // Orders: permutations of the chunks keeping mesh chunks in their relative order.
  let orders = t.orders === undefined ? [{ name: 'rate-distortion', chunks: chunks.map((_, i) => i) }] : arr(t.orders, 'orders');
  orders = orders.map((o, k) => {
    const w = `orders[${k}]`;
    obj(o, w);
    if (typeof o.name !== 'string' || !o.name) throw fail(`${w}.name must be a non-empty string`);
    const seq = arr(o.chunks, `${w}.chunks`);
    if (seq.length !== n) throw fail(`${w} ("${o.name}") lists ${seq.length} chunks, the package has ${n}`);
    const seen = new Uint8Array(n);
    let lastMesh = -1;
    for (let i = 0; i < n; i++) {
      const c = int(seq[i], `${w}.chunks[${i}]`, n - 1);
      if (seen[c]) throw fail(`${w} ("${o.name}") lists chunk ${c} twice`);
      seen[c] = 1;
      if (chunks[c].kind === 'mesh') {
        if (c < lastMesh) throw fail(`${w} ("${o.name}") reorders mesh chunks (${c} after ${lastMesh})`);
        lastMesh = c;
      }
    }
    let distortion;
    if (o.distortion === undefined) distortion = seq.map((c) => chunks[c].distortion);
    else {
      distortion = arr(o.distortion, `${w}.distortion`).map((d, i) => dist(d, `${w}.distortion[${i}]`));
      if (distortion.length !== n) throw fail(`${w} ("${o.name}") has ${distortion.length} distortion values for ${n} chunks`);
    }
    return { name: o.name, chunks: seq.slice(), distortion };
  });
  if (orders.length === 0) throw fail('orders is empty');
  if (orders[0].chunks.some((c, i) => c !== i)) throw fail(`orders[0] ("${orders[0].name}") is not the file order 0..${n - 1}`);

  // Informational: a complete stream should end on the full mesh sizes.
  const notes = [];
  held.forEach((h, i) => {
    if (h.vertices !== meshes[i].vertices || h.faces !== meshes[i].faces) {
      notes.push(`mesh ${i}: the stream ends at ${h.vertices} vertices / ${h.faces} faces, the table says ${meshes[i].vertices} / ${meshes[i].faces}`);
    }
  });
  // The largest decode ahead, in decoder heap bytes (target rounded up to 4 items + source).
  let heapBytes = 0;
  for (const m of meshes) heapBytes = Math.max(heapBytes, 4 * (3 * m.base_faces + 3) + m.base_indices.size);
  for (const c of chunks) {
    for (const p of c.parts || []) {
      heapBytes = Math.max(heapBytes, VERTEX_BYTES * (p.vertex_end - p.vertex_begin + 3) + p.vertex_bytes,
        4 * (3 * (p.face_end - p.face_begin) + 3) + p.index_bytes, 4 * (2 * p.updates + 3) + p.update_bytes);
    }
  }
  return { version: t.version, base, meshes, texture, chunks, orders, notes, heapBytes };
}

// ---- HTTP ranges ---------------------------------------------------------------------------

// Reads byte ranges of one URL. Falls back to the whole body when the server ignores Range.
class RangeReader {
  constructor(url) {
    this.url = url;
    this.whole = null;    // the entire file, when a server answered 200
    this.prefix = null;   // the first bytes (the probe), reused when later ranges fall inside
    this.size = NaN;      // file size, when known
  }

  _error(message) { return new Error(`meshmux: ${this.url}: ${message}`); }

  async _fetch(start, end, signal) {
    let res;
    try {
      res = await fetch(this.url, { headers: { Range: `bytes=${start}-${end - 1}` }, signal });
    } catch (e) {
      if (e.name === 'AbortError') throw e;
      throw this._error(`cannot fetch bytes ${start}-${end - 1} (${e.message})`);
    }
    if (res.status === 200) {
      this.whole = new Uint8Array(await res.arrayBuffer());
      this.size = this.whole.length;
      return { bytes: this.whole.subarray(start, Math.min(end, this.size)), whole: true };
    }
    if (res.status !== 206) {
      throw this._error(`HTTP ${res.status}${res.statusText ? ' ' + res.statusText : ''} for bytes ${start}-${end - 1}`);
    }
    const cr = /^bytes (\d+)-(\d+)\/(\d+|\*)$/.exec(res.headers.get('Content-Range') || '');
    if (cr) {
      if (Number(cr[1]) !== start) throw this._error(`asked for bytes from ${start}, the server sent ${cr[0]}`);
      if (cr[3] !== '*') this.size = Number(cr[3]);
    }
    return { bytes: new Uint8Array(await res.arrayBuffer()), whole: false };
  }

  // The first `n` bytes or the whole file if shorter.
  async probe(n, signal) {
    const { bytes } = await this._fetch(0, n, signal);
    if (!Number.isFinite(this.size) && bytes.length < n) this.size = bytes.length;
    this.prefix = bytes;
    return bytes;
  }

  // Exactly bytes [start, end).
  async read(start, end, signal) {
    if (end <= start) return new Uint8Array(0);
    if (this.whole) {
      if (end > this.whole.length) throw this._error(`bytes ${start}-${end - 1} are past the end of the file (${this.whole.length} bytes)`);
      return this.whole.subarray(start, end);
    }
    if (this.prefix && end <= this.prefix.length) return this.prefix.subarray(start, end);
    const { bytes } = await this._fetch(start, end, signal);
    if (bytes.length < end - start) throw this._error(`short read: bytes ${start}-${end - 1} returned ${bytes.length} bytes`);
    return bytes.subarray(0, end - start);
  }
}

// ---- Textures and material -----------------------------------------------------------------

// Texels are used as stored bytes (no colour management), glTF uv convention, trilinear +
// anisotropic filtering, clamped.
function configureTexture(texture, anisotropy) {
  texture.colorSpace = THREE.NoColorSpace;
  texture.flipY = false;
  texture.minFilter = THREE.LinearMipmapLinearFilter;
  texture.magFilter = THREE.LinearFilter;
  texture.generateMipmaps = true;
  texture.wrapS = texture.wrapT = THREE.ClampToEdgeWrapping;
  texture.anisotropy = anisotropy;
  texture.needsUpdate = true;
  return texture;
}

const VERTEX_SHADER = /* glsl */ `
out vec3 vNormal;
out vec2 vUv;
flat out float vMirror;   // -1 for instances whose matrix mirrors (winding flips on screen)
void main() {
  vec4 p = vec4(position, 1.0);
  vec3 n = normal;
  float mirror = 1.0;
#ifdef USE_INSTANCING
  p = instanceMatrix * p;
  mat3 im = mat3(instanceMatrix);
  n = im * n;
  if (determinant(im) < 0.0) mirror = -1.0;
#endif
  gl_Position = projectionMatrix * viewMatrix * modelMatrix * p;
  vNormal = normalMatrix * n;  // view space
  vUv = uv;
  vMirror = mirror;
}`;

const FRAGMENT_SHADER = /* glsl */ `
uniform vec4 baseColorFactor;
uniform sampler2D map;
uniform bool textured;
uniform vec3 lightDirection;   // view space, unit, towards the light
in vec3 vNormal;
in vec2 vUv;
flat in float vMirror;
out vec4 fragColor;
void main() {
  vec4 base = baseColorFactor;
  if (textured) {
    // Anisotropic trilinear where the pixel footprint spans more than one texel; plain
    // bilinear of level 0 where the texture is magnified (as meshmux's offscreen renderer does:
    // some software rasterizers blur magnified texels under anisotropic filtering).
    vec2 t = vUv * vec2(textureSize(map, 0));
    vec2 dx = dFdx(t), dy = dFdy(t);
    bool minified = max(dot(dx, dx), dot(dy, dy)) > 1.0;
    vec4 filtered = texture(map, vUv);
    vec4 plain = textureLod(map, vUv, 0.0);
    base *= minified ? filtered : plain;
  }
  float len = length(vNormal);
  vec3 n = len > 1e-20 ? vNormal / len : vec3(0.0, 0.0, 1.0);
  bool front = vMirror < 0.0 ? !gl_FrontFacing : gl_FrontFacing;
  if (!front) n = -n;  // two-sided lighting
  fragColor = vec4(base.rgb * (0.35 + 0.65 * max(dot(n, lightDirection), 0.0)), 1.0);
}`;

// One ShaderMaterial per distinct glTF material (normally exactly one: the atlas); all share
// the texture uniform so a streamed level reaches every material at once.
function makeMaterial(source, mapUniform) {
  const color = source.color || new THREE.Color(1, 1, 1);
  const opacity = source.opacity ?? 1;
  return new THREE.ShaderMaterial({
    name: `meshmux(${source.name || 'material'})`,
    glslVersion: THREE.GLSL3,
    side: THREE.DoubleSide,
    uniforms: {
      baseColorFactor: { value: new THREE.Vector4(color.r, color.g, color.b, opacity) },
      map: mapUniform,
      textured: { value: !!source.map },
      lightDirection: { value: LIGHT.clone() },
    },
    vertexShader: VERTEX_SHADER,
    fragmentShader: FRAGMENT_SHADER,
  });
}

// Resolves at the next animation frame (or after 50 ms when frames stall, e.g. a hidden page).
const nextFrame = () => new Promise((resolve) => {
  const timer = setTimeout(resolve, 50);
  requestAnimationFrame(() => { clearTimeout(timer); resolve(); });
});

const nextTask = () => new Promise((resolve) => {
  const ch = new MessageChannel();
  ch.port1.onmessage = () => { ch.port1.close(); resolve(); };
  ch.port2.postMessage(0);
});

// ---- The stream ----------------------------------------------------------------------------

export class MeshmuxStream extends EventTarget {
  constructor(url, options = {}) {
    super();
    this.url = String(url);
    this.options = { order: 'rate-distortion', budgetBytes: Infinity, chunkBatchBytes: 256 * 1024, renderer: null, ...options };
    this.object = new THREE.Group();
    this.object.name = 'meshmux';
    this.table = null;
    this.order = null;             // the chosen order from the table
    this.meshes = [];              // StreamMesh per package mesh
    this.materials = [];
    this.notes = [];               // non-fatal findings about the package
    this._reader = new RangeReader(this.url);
    this._map = { value: null };   // shared texture uniform
    this._ownedTextures = [];
    this._state = 'idle';
    this._abort = null;
    this._playing = null;
    this._position = 0;            // chunks of the order applied
    this._bytes = 0;
    this._textureSize = [0, 0];
    this._trianglesApplied = 0;
    this._applySeconds = 0;
  }

  _fail(message) { return new Error(`meshmux: ${this.url}: ${message}`); }

  // Between two chunks: 'frame' waits for the next animation frame (one chunk per frame: the
  // page renders each step, and the renderer's work on a frame is done before the next chunk
  // is decoded), 'task' only yields to the event loop (fastest), 'none' does not yield.
  _pause() {
    const pace = this.options.pace ?? (typeof requestAnimationFrame === 'function' ? 'frame' : 'task');
    if (pace === 'frame') return nextFrame();
    if (pace === 'task') return nextTask();
    return Promise.resolve();
  }

  get budgetBytes() { return this.options.budgetBytes; }
  set budgetBytes(bytes) { this.options.budgetBytes = bytes; }
  get state() { return this._state; }
  get playing() { return this._playing !== null; }

  get stats() {
    const distortion = this._position === 0 ? (this.table ? this.table.base.distortion : NaN)
      : this.order.distortion[this._position - 1];
    let triangles = 0, vertices = 0;
    for (const m of this.meshes) { triangles += m.solid * m.instances; vertices += m.vertices; }
    return {
      bytesReceived: this._bytes,
      bytesTotal: this._reader.size,
      chunksApplied: this._position,
      chunkCount: this.table ? this.table.chunks.length : 0,
      triangles, vertices,
      textureWidth: this._textureSize[0], textureHeight: this._textureSize[1],
      distortion,
      order: this.order ? this.order.name : this.options.order,
      trianglesApplied: this._trianglesApplied,
      applySeconds: this._applySeconds,
      state: this._state,
    };
  }

  _emit(type, extra) { this.dispatchEvent(new CustomEvent(type, { detail: { ...this.stats, ...extra } })); }

  // Fetches the header, table, base and base faces; builds the scene. Returns this.object.
  async open() {
    if (this.table) return this.object;
    this._state = 'opening';
    try {
      this._abort = new AbortController();
      const signal = this._abort.signal;
      const probe = this._reader.probe(PROBE_BYTES, signal);
      probe.catch(() => {});  // awaited below; no unhandled rejection meanwhile
      await MeshoptDecoder.ready;
      const head = await probe;
      if (head.length < HEADER_BYTES) throw this._fail(`${head.length} bytes: too small to be a meshmux package`);
      const magic = String.fromCharCode(head[0], head[1], head[2], head[3]);
      if (magic !== 'MMXP') throw this._fail(`not a meshmux package (magic ${JSON.stringify(magic)}, expected "MMXP")`);
      const dv = new DataView(head.buffer, head.byteOffset, head.byteLength);
      const version = dv.getUint32(4, true), jsonLength = dv.getUint32(8, true);
      if (version !== PACKAGE_VERSION) throw this._fail(`package version ${version} is not supported (this client reads version ${PACKAGE_VERSION})`);
      const dataStart = HEADER_BYTES + jsonLength;
      const size = this._reader.size;
      if (Number.isFinite(size) && dataStart > size) throw this._fail(`JSON table of ${jsonLength} bytes runs past the end of the file (${size} bytes)`);
      const json = head.length >= dataStart ? head.subarray(HEADER_BYTES, dataStart)
        : concat(head.subarray(HEADER_BYTES), await this._reader.read(head.length, dataStart, signal));
      let raw;
      try {
        raw = JSON.parse(new TextDecoder('utf-8', { fatal: true }).decode(json));
      } catch (e) {
        throw this._fail(`the JSON table cannot be parsed (${e.message})`);
      }
      const table = validateTable(raw, { fileSize: this._reader.size, dataStart, fail: (m) => this._fail(m) });
      if (!Number.isFinite(this._reader.size)) {
        // The server hid the file size: the table's furthest byte stands in for it.
        let end = table.base.offset + table.base.size;
        for (const m of table.meshes) end = Math.max(end, m.base_indices.offset + m.base_indices.size);
        for (const c of table.chunks) end = Math.max(end, c.offset + c.size);
        this._reader.size = end;
      }
      this.notes.push(...table.notes);
      const order = table.orders.find((o) => o.name === this.options.order);
      if (!order) throw this._fail(`no order "${this.options.order}" (the package has ${table.orders.map((o) => o.name).join(', ')})`);

      // The base .glb and the base faces: one request when they lie together.
      const ranges = [table.base, ...table.meshes.map((m) => m.base_indices).filter((r) => r.size > 0)];
      const lo = Math.min(...ranges.map((r) => r.offset)), hi = Math.max(...ranges.map((r) => r.offset + r.size));
      const sum = ranges.reduce((s, r) => s + r.size, 0);
      let slice;
      if (hi - lo <= sum + PROBE_BYTES) {
        const block = await this._reader.read(lo, hi, signal);
        slice = (r) => block.subarray(r.offset - lo, r.offset - lo + r.size);
      } else {
        const parts = await Promise.all(ranges.map((r) => this._reader.read(r.offset, r.offset + r.size, signal)));
        slice = (r) => parts[ranges.indexOf(r)];
      }
      await this._buildBase(table, slice);
      this.table = table;
      this.order = order;
      this._bytes = dataStart + sum;
      this._state = 'base';
      this._emit('base');
      this._emit('progress');
      return this.object;
    } catch (error) {
      this._state = 'error';
      this._emit('error', { error });
      throw error;
    } finally {
      this._abort = null;
    }
  }

  // Parses the base .glb, swaps in the streaming geometries and the shared shading.
  async _buildBase(table, slice) {
    const glbBytes = slice(table.base);
    const glb = glbBytes.buffer.slice(glbBytes.byteOffset, glbBytes.byteOffset + glbBytes.byteLength);
    const loader = new GLTFLoader().setMeshoptDecoder(MeshoptDecoder);
    let gltf;
    try {
      gltf = await new Promise((resolve, reject) => loader.parse(glb, '', resolve, reject));
    } catch (e) {
      throw this._fail(`the base .glb cannot be loaded (${e && e.message ? e.message : e})`);
    }
    const root = gltf.scene || (gltf.scenes && gltf.scenes[0]);
    if (!root) throw this._fail('the base .glb has no scene');

    this.meshes = table.meshes.map((d, i) => new StreamMesh(d, i));
    const filled = new Uint8Array(this.meshes.length);
    const oldGeometries = new Set(), oldMaterials = new Set(), materialFor = new Map();
    const anisotropy = this.options.renderer ? Math.min(16, this.options.renderer.capabilities.getMaxAnisotropy()) : 1;
    const objects = [];
    root.traverse((o) => { if (o.isMesh) objects.push(o); });
    for (const o of objects) {
      const m = o.userData.meshmux_mesh;
      if (m === undefined) { this.notes.push(`base .glb object "${o.name}" has no meshmux_mesh tag: drawn as is`); }
      else if (!Number.isInteger(m) || m < 0 || m >= this.meshes.length) {
        throw this._fail(`base .glb object "${o.name}" names meshmux_mesh ${JSON.stringify(m)} (the package has ${this.meshes.length} meshes)`);
      }
      const source = Array.isArray(o.material) ? o.material[0] : o.material;
      if (!materialFor.has(source)) {
        if (source.map && !this._map.value) {
          this._map.value = configureTexture(source.map, anisotropy);
          this._textureSize = [source.map.image?.width || 0, source.map.image?.height || 0];
        }
        materialFor.set(source, makeMaterial(source, this._map));
      }
      (Array.isArray(o.material) ? o.material : [o.material]).forEach((x) => oldMaterials.add(x));
      o.material = materialFor.get(source);
      if (m === undefined) continue;

      const mesh = this.meshes[m];
      if (!filled[m]) {
        const g = o.geometry, d = table.meshes[m];
        const pos = g.getAttribute('position');
        if (!pos || pos.count !== d.base_vertices) {
          throw this._fail(`base .glb mesh ${m} has ${pos ? pos.count : 0} vertices, the table says base_vertices ${d.base_vertices}`);
        }
        mesh.setBaseVertices(g);
        const f0 = d.base_faces;
        if (f0 > 0) {
          try {
            mesh.appendFaces(slice(d.base_indices), f0);
          } catch (e) {
            throw this._fail(`mesh ${m}: base_indices: ${e.message}`);
          }
        }
        // The glb's own index (degenerate faces dropped, perhaps) should not hold more faces.
        if (g.index && g.index.count / 3 > f0) this.notes.push(`base .glb mesh ${m} has ${g.index.count / 3} faces, base_faces is ${f0}`);
        filled[m] = 1;
      }
      oldGeometries.add(o.geometry);
      o.geometry = mesh.geometry;
      if (o.isInstancedMesh) {
        o.boundingBox = null;
        o.boundingSphere = null;
        o.computeBoundingSphere();
        mesh.instances += o.count;
      } else {
        mesh.instances += 1;
      }
    }
    if (!objects.length) throw this._fail('the base .glb holds no mesh');
    filled.forEach((f, m) => { if (!f) this.notes.push(`package mesh ${m} is drawn by no object of the base .glb`); });
    for (const g of oldGeometries) g.dispose();
    for (const mat of oldMaterials) {
      for (const key of ['map', 'normalMap', 'roughnessMap', 'metalnessMap', 'emissiveMap', 'aoMap']) {
        const tex = mat[key];
        if (tex && tex !== this._map.value) tex.dispose();
      }
      mat.dispose();
    }
    this.materials = [...materialFor.values()];
    this.object.add(root);
    this.object.updateMatrixWorld(true);
  }

  // The world-space box of everything the stream will draw: each mesh's package bounds through
  // each object's world matrix (and instance matrices). Call after adding this.object.
  worldBounds(target = new THREE.Box3()) {
    target.makeEmpty();
    this.object.updateWorldMatrix(true, true);
    const m4 = new THREE.Matrix4(), box = new THREE.Box3();
    this.object.traverse((o) => {
      const m = o.userData.meshmux_mesh;
      if (!o.isMesh || !this.meshes[m]) return;
      const bb = this.meshes[m].geometry.boundingBox;
      const count = o.isInstancedMesh ? o.count : 1;
      for (let i = 0; i < count; i++) {
        if (o.isInstancedMesh) { o.getMatrixAt(i, m4); m4.premultiply(o.matrixWorld); } else m4.copy(o.matrixWorld);
        target.union(box.copy(bb).applyMatrix4(m4));
      }
    });
    return target;
  }

  // The next batch from order position `pos`: chunks consecutive in the file, up to
  // chunkBatchBytes (at least one chunk), none past the budget. null when nothing fits.
  _planBatch(pos, planned) {
    const seq = this.order.chunks, chunks = this.table.chunks;
    const budget = this.options.budgetBytes, cap = this.options.chunkBatchBytes;
    if (pos >= seq.length) return null;
    const first = chunks[seq[pos]];
    let bytes = planned + first.size;
    if (bytes > budget) return null;
    const batch = { indices: [seq[pos]], start: first.offset, end: first.offset + first.size };
    for (let k = pos + 1; k < seq.length; k++) {
      const c = chunks[seq[k]];
      if (c.offset !== batch.end || batch.end + c.size - batch.start > cap || bytes + c.size > budget) break;
      batch.indices.push(seq[k]);
      batch.end += c.size;
      bytes += c.size;
    }
    batch.bytes = bytes;
    return batch;
  }

  // Fetches and applies chunks in the chosen order until the end or the budget. Resolves with
  // the stats; calling it again while playing returns the same promise.
  play() {
    if (!this.table) return Promise.reject(this._fail('play() before open()'));
    if (this._state === 'error' || this._state === 'disposed') return Promise.reject(this._fail(`cannot play in state ${this._state}`));
    if (!this._playing) this._playing = this._run().finally(() => { this._playing = null; });
    return this._playing;
  }

  async _run() {
    const abort = this._abort = new AbortController();
    const signal = abort.signal;
    this._state = 'streaming';
    const pending = [];
    try {
      let pos = this._position;
      let batch = this._planBatch(pos, this._bytes);
      let fetching = batch && this._reader.read(batch.start, batch.end, signal);
      if (fetching) fetching.catch(() => {});  // awaited below
      warmUp(this.table.heapBytes);  // while the first batch is on its way
      while (batch) {
        const data = await fetching;
        // Prefetch the next batch while this one is applied.
        const next = this._planBatch(pos + batch.indices.length, batch.bytes);
        const nextFetch = next && this._reader.read(next.start, next.end, signal);
        if (nextFetch) { nextFetch.catch(() => {}); pending.push(nextFetch); }
        for (const ci of batch.indices) {
          if (signal.aborted) throw new DOMException('stopped', 'AbortError');
          const chunk = this.table.chunks[ci];
          if (this._bytes + chunk.size > this.options.budgetBytes) { batch = null; break; }  // budget lowered meanwhile
          const payload = data.subarray(chunk.offset - batch.start, chunk.offset - batch.start + chunk.size);
          await this._applyChunk(ci, chunk, payload);
          if (signal.aborted) throw new DOMException('stopped', 'AbortError');
          this._position = ++pos;
          this._bytes += chunk.size;
          this._emit('chunk', { chunk: ci, kind: chunk.kind });
          this._emit('progress');
          await this._pause();  // let the page render and handle input between chunks
        }
        if (!batch) break;
        batch = next;
        fetching = nextFetch;
      }
      abort.abort();  // drops a prefetch the budget made useless
      this._state = this._position === this.table.chunks.length ? 'complete' : 'stopped';
      this._emit(this._state);
      return this.stats;
    } catch (error) {
      if (error && error.name === 'AbortError' && signal.aborted) {
        if (this._state === 'disposed') return this.stats;
        this._state = 'stopped';
        this._emit('stopped');
        return this.stats;
      }
      this._state = 'error';
      this._emit('error', { error });
      throw error;
    } finally {
      if (this._abort === abort) this._abort = null;
    }
  }

  async _applyChunk(index, chunk, payload) {
    if (chunk.kind === 'mesh') {
      const t0 = performance.now();
      try {
        this._trianglesApplied += applyMeshChunk(this.meshes, chunk, payload);
      } catch (e) {
        throw this._fail(`chunk ${index}: ${e.message}`);
      } finally {
        this._applySeconds += (performance.now() - t0) / 1000;
      }
      return;
    }
    // A texture level: a complete JPEG/PNG, decoded off the main thread, bytes as stored.
    let bitmap;
    try {
      bitmap = await createImageBitmap(new Blob([payload], { type: chunk.mime }),
        { imageOrientation: 'from-image', premultiplyAlpha: 'none', colorSpaceConversion: 'none' });
    } catch (e) {
      throw this._fail(`chunk ${index}: the ${chunk.mime} texture level cannot be decoded (${e.message})`);
    }
    if (this._state === 'disposed') { bitmap.close(); return; }
    if (bitmap.width !== chunk.width || bitmap.height !== chunk.height) {
      this.notes.push(`chunk ${index}: texture is ${bitmap.width}×${bitmap.height}, the table says ${chunk.width}×${chunk.height}`);
    }
    const anisotropy = this.options.renderer ? Math.min(16, this.options.renderer.capabilities.getMaxAnisotropy()) : 1;
    const texture = configureTexture(new THREE.Texture(bitmap), anisotropy);
    texture.name = `meshmux level ${bitmap.width}x${bitmap.height}`;
    const old = this._map.value;
    this._map.value = texture;
    this._ownedTextures.push(texture);
    if (old) this._releaseTexture(old);
    this._textureSize = [bitmap.width, bitmap.height];
  }

  _releaseTexture(texture) {
    texture.dispose();
    const k = this._ownedTextures.indexOf(texture);
    if (k >= 0) {
      this._ownedTextures.splice(k, 1);
      if (texture.image && typeof texture.image.close === 'function') texture.image.close();
    }
  }

  // Aborts fetching; play() then resolves with state 'stopped'.
  stop() {
    if (this._abort) this._abort.abort();
  }

  dispose() {
    this.stop();
    this._state = 'disposed';
    if (this.object.parent) this.object.parent.remove(this.object);
    for (const m of this.meshes) m.dispose();
    for (const mat of this.materials) mat.dispose();
    if (this._map.value) this._releaseTexture(this._map.value);
    this._map.value = null;
    this.meshes = [];
    this.materials = [];
  }
}

function concat(a, b) {
  const out = new Uint8Array(a.length + b.length);
  out.set(a, 0);
  out.set(b, a.length);
  return out;
}
