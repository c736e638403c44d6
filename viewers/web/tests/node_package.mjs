// A converted package read in node, as the web client reads it (no browser): its validated
// table and, per package mesh, the base's quantized vertices and faces from the base .glb
// (EXT_meshopt_compression through three's meshopt decoder, values as GLTFLoader gives them and
// StreamMesh.setBaseVertices quantizes them), and fresh MeshDecoder states (the worker's
// decoder: stream_decoder.js over the WebAssembly module stream_decoder.wasm, loaded here from
// its file) holding those bases. Used by bench/decode_rate.mjs and decoder_test.mjs.
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { fileURLToPath } from 'node:url';

import { rawTableOf, validateTable } from '../package_reader.js';
import { MeshDecoder, loadDecoder } from '../stream_decoder.js';
import { POSITION_MAX, UV_MAX } from '../stream_format.js';

const here = path.dirname(fileURLToPath(import.meta.url));
const { MeshoptDecoder } = await import(path.join(here, '../../../node_modules/three/examples/jsm/libs/meshopt_decoder.module.js'));
await MeshoptDecoder.ready;
// The module as the client loads it (node's fetch reads no file: URL, so its bytes). Built by
// CMake where the WebAssembly toolchain is (scripts/setup.sh installs it); without it, a skip.
const wasmFile = path.join(here, '../stream_decoder.wasm');
if (!fs.existsSync(wasmFile)) {
  console.error(`SKIPPED: ${wasmFile} is not built (no WebAssembly toolchain: scripts/setup.sh)`);
  process.exit(77);
}
export const decoder = await loadDecoder(fs.readFileSync(wasmFile));

const COMPONENTS = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4 };
const TYPED = { 5120: Int8Array, 5121: Uint8Array, 5122: Int16Array, 5123: Uint16Array, 5125: Uint32Array, 5126: Float32Array };

// A GLB's JSON and binary chunk.
function parseGlb(bytes) {
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  let at = 12, doc = null, bin = null;
  while (at + 8 <= bytes.length) {
    const size = view.getUint32(at, true), kind = view.getUint32(at + 4, true);
    if (kind === 0x4E4F534A) doc = JSON.parse(Buffer.from(bytes.subarray(at + 8, at + 8 + size)).toString('utf8'));
    else if (kind === 0x004E4942) bin = bytes.subarray(at + 8, at + 8 + size);
    at += 8 + size;
  }
  return { doc, bin };
}

// Accessor `index` as a typed array of its components (meshopt-compressed views decoded).
function readAccessor({ doc, bin }, index, cache) {
  const a = doc.accessors[index], n = COMPONENTS[a.type], Typed = TYPED[a.componentType];
  const view = doc.bufferViews[a.bufferView];
  let data = cache.get(a.bufferView);
  if (!data) {
    const ext = view.extensions && view.extensions.EXT_meshopt_compression;
    if (ext) {
      data = new Uint8Array(ext.count * ext.byteStride);
      const source = bin.subarray(ext.byteOffset || 0, (ext.byteOffset || 0) + ext.byteLength);
      MeshoptDecoder.decodeGltfBuffer(data, ext.count, ext.byteStride, source, ext.mode, ext.filter);
    } else {
      data = bin.subarray(view.byteOffset || 0, (view.byteOffset || 0) + view.byteLength);
    }
    cache.set(a.bufferView, data);
  }
  const stride = view.byteStride || n * Typed.BYTES_PER_ELEMENT, out = new Typed(a.count * n);
  const dv = new DataView(data.buffer, data.byteOffset, data.byteLength);
  const get = { 5120: 'getInt8', 5121: 'getUint8', 5122: 'getInt16', 5123: 'getUint16', 5125: 'getUint32', 5126: 'getFloat32' }[a.componentType];
  for (let i = 0; i < a.count; i++)
    for (let k = 0; k < n; k++) out[i * n + k] = dv[get]((a.byteOffset || 0) + i * stride + k * Typed.BYTES_PER_ELEMENT, true);
  return { values: out, accessor: a };
}

// Per package mesh, its base: quantized vertices and the faces of its primitives in order.
export function readBase(glb, table) {
  const cache = new Map(), bases = [];
  for (const mesh of glb.doc.meshes || []) {
    const m = mesh.extras && mesh.extras.meshmux_mesh;
    if (!Number.isInteger(m) || bases[m]) continue;
    const d = table.meshes[m], first = mesh.primitives[0].attributes;
    const P = readAccessor(glb, first.POSITION, cache), count = P.accessor.count;
    const qp = new Uint16Array(3 * count), qn = new Int8Array(3 * count), qt = new Uint16Array(2 * count);
    const q = d.quantization || { origin: [0, 0, 0], step: 1 }, float = P.accessor.componentType === 5126;
    for (let i = 0; i < 3 * count; i++) {
      qp[i] = float ? Math.min(POSITION_MAX, Math.max(0, Math.round((P.values[i] - q.origin[i % 3]) / q.step))) : P.values[i];
    }
    // As StreamMesh.setBaseVertices reads what GLTFLoader gives: normalized integers or floats.
    const real = (r, i) => {
      const a = r.accessor;
      if (!a.normalized) return r.values[i];
      return a.componentType === 5120 ? Math.max(r.values[i] / 127, -1) : a.componentType === 5122
        ? Math.max(r.values[i] / 32767, -1) : a.componentType === 5121 ? r.values[i] / 255 : r.values[i] / 65535;
    };
    if (first.NORMAL !== undefined) {
      const N = readAccessor(glb, first.NORMAL, cache);
      for (let i = 0; i < 3 * count; i++) qn[i] = Math.max(-127, Math.min(127, Math.round(real(N, i) * 127)));
    } else for (let i = 0; i < count; i++) qn[3 * i + 2] = 127;
    if (first.TEXCOORD_0 !== undefined) {
      const T = readAccessor(glb, first.TEXCOORD_0, cache), unorm16 = T.accessor.normalized && T.accessor.componentType === 5123;
      for (let i = 0; i < 2 * count; i++) {
        const t = real(T, i);
        qt[i] = unorm16 ? Math.floor((Math.round(t * 65535) * UV_MAX + 32767) / 65535) : t >= 0 ? (t >= 1 ? UV_MAX : Math.round(t * UV_MAX)) : 0;
      }
    }
    const faces = mesh.primitives.map((p) => (p.indices === undefined ? new Uint32Array(0) : Uint32Array.from(readAccessor(glb, p.indices, cache).values)));
    bases[m] = { qp, qn, qt, count, faces };
  }
  return bases;
}


// The package `file` (model.mmxp): { bytes, table, bases } (bases: none when the base is the
// whole model). Throws an Error naming what is wrong.
export function readPackage(file) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const { raw, dataStart } = rawTableOf(bytes, zlib.inflateSync);
  const table = validateTable(raw, { fileSize: bytes.length, dataStart, fail: (m) => new Error(m) });
  if (table.base.whole) return { bytes, table, bases: null };
  const stored = bytes.subarray(table.base.offset, table.base.offset + table.base.size);  // validated offsets are absolute
  const glb = parseGlb(table.base.deflated ? new Uint8Array(zlib.inflateSync(stored)) : stored);
  return { bytes, table, bases: readBase(glb, table) };
}

// One MeshDecoder per package mesh holding its base (what a client holds before any chunk);
// freeStates gives their memory back.
export function freshStates(table, bases) {
  return table.meshes.map((d, i) => {
    const s = new MeshDecoder(decoder, d, i), b = bases[i];
    if (b) { s.setBase(b.qp, b.qn, b.qt, b.count); for (const f of b.faces) s.appendFaces(f); }
    return s;
  });
}

export function freeStates(states) {
  for (const s of states) s.free();
}

// Applies mesh chunk `c` (from `bytes`, the whole package) to `states`, its parts in order.
export function applyChunk(states, bytes, c) {
  let at = c.offset;
  for (const p of c.parts) {
    // A block part (stream/format.h "Blocks"): its vertices placed at its block's stream numbers.
    if (p.block >= 0) states[p.mesh].applyBlockSplits(bytes, at, at + p.bytes, p.block, p.vertex_end - p.vertex_begin, p.face_end - p.face_begin);
    else states[p.mesh].applySplits(bytes, at, at + p.bytes, p.vertex_end - p.vertex_begin, p.face_end - p.face_begin);
    at += p.bytes;
  }
}
