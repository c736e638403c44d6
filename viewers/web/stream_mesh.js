// stream_mesh.js — the mesh side of a meshmux stream on the page: one growing geometry per
// package mesh (StreamMesh), decoded by the WebAssembly decoder (stream_decoder.js) either in a
// Web Worker (StreamWorker of worker_client.js, stream_worker.js) or, where no worker runs, on
// the page; either way the page only copies in what each chunk changed and uploads those
// ranges. Used by meshmux.js.

import * as THREE from 'three';

import { MeshDecoder } from './stream_decoder.js';
import { POSITION_MAX, UV_MAX } from './stream_format.js';
import { PixelImage, checkParts } from './worker_client.js';

export { loadDecoder } from './stream_decoder.js';
export { HeldBytes, PixelImage, StreamWorker, WorkerPool } from './worker_client.js';
// Index buffer uploads after a worker's chunk: the corners splits moved are uploaded in blocks
// of this many corners (64 kB), each dirty block once.
const INDEX_BLOCK = 16384;

// ---- One streaming mesh ----------------------------------------------------------------------

// Package mesh m on the page: arrays with the full mesh's capacity and the BufferGeometry that
// draws them, the counts received so far, and (decoding on the page: `{ decoder }`, a Decoder
// of stream_decoder.js loadDecoder) the MeshDecoder the vertex splits are coded against.
// Without a decoder a StreamWorker holds that state and this object only takes in its changes
// (applyChanges); with `{ deferCommit: true }` the caller commits the buffers' memory itself
// (commitPieces) before the first chunk. dispose() frees the decoder's state.
export class StreamMesh {
  constructor(desc, index, { decoder = null, deferCommit = false } = {}) {
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
    // The memory is committed at load time rather than page by page while refining: here, or
    // piece by piece by a caller that walks commitPieces() between tasks.
    if (!deferCommit) for (const a of [this.position, this.normal, this.uv, this.indices]) a.fill(0);
    this.state = decoder ? new MeshDecoder(decoder, desc, index) : null;
    this.base = null;  // decoding in a worker: the base's quantized vertices and faces to send it
    this._dirty = new Uint8Array(Math.ceil((3 * F) / INDEX_BLOCK));
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

  // Writes the buffers' pages (zeros, as allocated) `piece` elements at a time, yielding after
  // each: a large mesh's buffers are tens of megabytes, tens of milliseconds to commit at once.
  *commitPieces(piece = 1 << 18) {
    for (const a of [this.position, this.normal, this.uv, this.indices]) {
      for (let i = 0; i < a.length; i += piece) {
        a.fill(0, i, Math.min(a.length, i + piece));
        yield;
      }
    }
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
    for (const _ of this.baseVertexPieces(glbGeometry));
  }

  // setBaseVertices a piece of `piece` vertices at a time: the caller may yield the page at
  // each step (in one go it held traced world tasks of 25-34 ms).
  *baseVertexPieces(glbGeometry, piece = 1 << 14) {
    const pos = glbGeometry.getAttribute('position'), nrm = glbGeometry.getAttribute('normal');
    const uv = glbGeometry.getAttribute('uv');
    const count = pos.count;
    if (count > this.capacityVertices) throw new Error(`mesh ${this.index}: ${count} base vertices exceed its capacity ${this.capacityVertices}`);
    const P = this.position, N = this.normal, T = this.uv;
    const qp = new Uint16Array(3 * count), qn = new Int8Array(3 * count), qt = new Uint16Array(2 * count);
    const array = pos.array || (pos.data && pos.data.array);
    this.quantized = !pos.normalized && (array instanceof Uint16Array || array instanceof Uint8Array);
    this._setBox(this.bounds);
    const o = this.origin, s = this.step;
    const grid = (x, k) => Math.min(POSITION_MAX, Math.max(0, Math.round((x - o[k]) / s)));
    const uvNormalized = uv && uv.normalized;
    for (let i = 0; i < count; i++) {
      if (i > 0 && i % piece === 0) yield;
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
          // unorm16 → 12 bits exactly (stream/quantize.h unorm16_to_uv12), or a float quantized.
          qt[2 * i + k] = uvNormalized ? Math.floor((Math.round(t * 65535) * UV_MAX + 32767) / 65535)
            : (t >= 0 ? (t >= 1 ? UV_MAX : Math.round(t * UV_MAX)) : 0);
        }
      }
    }
    if (this.state) this.state.setBase(qp, qn, qt, count);
    else this.base = { qp, qn, qt, count, quantized: this.quantized, faces: [] };
    this.vertices = count;
  }

  // Appends base faces (`indices`: a glTF primitive's index array, 3 per face, as the base .glb
  // decoded them) to the index buffer and the decoder's state, which checks that every corner
  // names a vertex received (in a worker: at StreamWorker.setup, which sets `solid`).
  appendIndices(indices) {
    const start = 3 * this.faces;
    if (this.state) {
      this.state.appendFaces(indices);
      this.solid = this.state.solid;
    } else {
      if (start + indices.length > this.indices.length) throw new Error(`mesh ${this.index}: ${(start + indices.length) / 3} faces exceed its capacity ${this.capacityFaces}`);
      this.base.faces.push(Uint32Array.from(indices));
      for (let i = 0; i + 2 < indices.length; i += 3) {  // the figure shown until the worker's
        const a = indices[i], b = indices[i + 1], c = indices[i + 2];
        this.solid += a !== b && b !== c && a !== c ? 1 : 0;
      }
    }
    this.indices.set(indices, start);
    this.faces += indices.length / 3;
    this.indexAttribute.addUpdateRange(start, indices.length);
    this.indexAttribute.needsUpdate = true;
    this.geometry.setDrawRange(0, 3 * this.faces);
  }

  // Applies one part on the page (its coded bytes d[begin, end)): `splits` vertex splits and
  // `faces` new faces (stream/vsplit.h, in the page's WebAssembly decoder), then takes in what
  // changed as a worker's changes are; an Error names the split and the problem.
  // block: a block part's block (stream/format.h "Blocks"), or -1.
  applySplits(d, begin, end, splits, faces, block = -1) {
    if (!this.state) throw new Error(`mesh ${this.index}: decoded in a worker, not on the page`);
    const v0 = this.vertices, f0 = this.faces;
    this.state.beginChanges();
    if (block >= 0) this.state.applyBlockSplits(d, begin, end, block, splits, faces);
    else this.state.applySplits(d, begin, end, splits, faces);
    this.applyChanges(this.state.changes(v0, f0, this.quantized, this.origin, this.step));
  }

  // Takes in what a worker decoded (StreamWorker.applyChunk): the new vertices' float
  // attributes, the new faces, and the corners splits moved in faces received before, then
  // uploads only those ranges (the moved corners by INDEX_BLOCK blocks).
  applyChanges(c) {
    if (c.v0 !== this.vertices || c.f0 !== this.faces) throw new Error(`mesh ${this.index}: changes from vertex ${c.v0}, face ${c.f0} on ${this.vertices}, ${this.faces}`);
    this.position.set(c.position, 3 * c.v0);
    this.normal.set(c.normal, 3 * c.v0);
    this.uv.set(c.uv, 2 * c.v0);
    const I = this.indices, moved = c.moved, dirty = this._dirty;
    I.set(c.appended, 3 * c.f0);
    for (let i = 0; i < moved.length; i += 2) {
      I[moved[i]] = moved[i + 1];
      dirty[Math.floor(moved[i] / INDEX_BLOCK)] = 1;
    }
    this._uploadVertices(c.v0, c.vn);
    // Ranges add to those not uploaded yet (three.js merges them when it uploads, then clears).
    const index = this.indexAttribute, lastBlock = Math.floor((3 * c.f0) / INDEX_BLOCK);
    for (let b = 0; b <= lastBlock && b < dirty.length; b++) {
      if (!dirty[b]) continue;
      let e = b;
      while (e + 1 <= lastBlock && dirty[e + 1]) e++;
      const from = b * INDEX_BLOCK, to = Math.min((e + 1) * INDEX_BLOCK, 3 * c.f0);
      index.addUpdateRange(from, to - from);
      dirty.fill(0, b, e + 1);
      b = e;
    }
    if (c.nf > c.f0) index.addUpdateRange(3 * c.f0, 3 * (c.nf - c.f0));
    index.needsUpdate = true;
    this.vertices = c.vn;
    this.faces = c.nf;
    this.solid = c.solid;
    this.geometry.setDrawRange(0, 3 * this.faces);
  }

  // Takes in the completion (stream/format.h "Completion"): the full mesh decoded from its
  // single-rate bitstream (`decoded`, a BufferGeometry: positions on the mesh's grid as the
  // base's, normals and uv where the stream carries them), in place of the vertex and index
  // buffers the splits grew; no split follows. The splits' decoder state is kept as it stands
  // (its digest is the encoder's before the completion).
  // (Its faces' points checked first: checkCompletionFaces.)
  complete(decoded) {
    const pos = decoded.getAttribute('position'), index = decoded.getIndex();
    if (!pos || !index) throw new Error(`mesh ${this.index}: the completion has no positions or faces`);
    const count = pos.count;
    // The decoded arrays are this mesh's to keep (the decoder made them for it): taken as they
    // are where their type fits, not copied (a 1.2M-triangle completion's copies held the page's
    // thread for tens of milliseconds).
    const take = (a, Type, n) => (a && !a.isInterleavedBufferAttribute && a.array instanceof Type && a.array.length === n ? a.array : null);
    // An attribute's floats (size per point): taken, or read value by value, or `fill` where absent.
    const floats = (a, size, fill) => {
      const got = take(a, Float32Array, size * count);
      if (got) return got;
      const out = new Float32Array(size * count);
      for (let i = 0; i < size * count; i++) out[i] = a ? a.getComponent(Math.floor(i / size), i % size) : fill(i % size);
      return out;
    };
    const P = floats(pos, 3, () => 0);
    if (!this.quantized) {  // a base with float positions: stream vertices in mesh units
      const o = this.origin, s = this.step;
      for (let i = 0; i < 3 * count; i++) P[i] = o[i % 3] + P[i] * s;
    }
    const N = floats(decoded.getAttribute('normal'), 3, (k) => (k === 2 ? 1 : 0));  // +Z, as the stream without normals
    const T = floats(decoded.getAttribute('uv'), 2, () => 0);
    const I = take(index, Uint32Array, index.count) || Uint32Array.from(index.array);
    const g = this.geometry;
    g.dispose();  // the grown buffers leave the GPU; the new ones go up with the next frame
    const attribute = (array, size) => new THREE.BufferAttribute(array, size);
    g.setAttribute('position', this.positionAttribute = attribute(P, 3));
    g.setAttribute('normal', this.normalAttribute = attribute(N, 3));
    g.setAttribute('uv', this.uvAttribute = attribute(T, 2));
    g.setIndex(this.indexAttribute = attribute(I, 1));
    this.position = P, this.normal = N, this.uv = T, this.indices = I;
    this.vertices = count;
    this.faces = I.length / 3;
    this.solid = this.faces;
    this.completed = true;
    this._dirty = null;
    g.setDrawRange(0, I.length);
  }

  // Takes in a block mesh's whole state after detail was dropped (block_view.js
  // BlockMeshState.rebuild: buffers sized to this mesh's capacities, vertices in slots): new
  // buffers in place of the old ones, the blocks' or a completion's (the old leave the GPU; the
  // new go up with the next frame).
  replaceAll(w) {
    if (w.position.length !== 3 * this.capacityVertices || w.indices.length !== 3 * this.capacityFaces) {
      throw new Error(`mesh ${this.index}: whole buffers of ${w.position.length / 3} vertices and ${w.indices.length / 3} faces, the mesh holds ${this.capacityVertices} and ${this.capacityFaces}`);
    }
    const g = this.geometry;
    g.dispose();
    const attribute = (array, size) => new THREE.BufferAttribute(array, size).setUsage(THREE.DynamicDrawUsage);
    g.setAttribute('position', this.positionAttribute = attribute(w.position, 3));
    g.setAttribute('normal', this.normalAttribute = attribute(w.normal, 3));
    g.setAttribute('uv', this.uvAttribute = attribute(w.uv, 2));
    g.setIndex(this.indexAttribute = attribute(w.indices, 1));
    this.position = w.position, this.normal = w.normal, this.uv = w.uv, this.indices = w.indices;
    this._dirty = new Uint8Array(Math.ceil((3 * this.capacityFaces) / INDEX_BLOCK));
    this.completed = false;  // a completion's buffers given back for the blocks'
    this.vertices = w.vertices;
    this.faces = w.faces;
    this.solid = w.solid;
    g.setDrawRange(0, 3 * this.faces);
  }

  _uploadVertices(v0, vn) {
    if (vn <= v0) return;
    this.positionAttribute.addUpdateRange(3 * v0, 3 * (vn - v0));
    this.normalAttribute.addUpdateRange(3 * v0, 3 * (vn - v0));
    this.uvAttribute.addUpdateRange(2 * v0, 2 * (vn - v0));
    this.positionAttribute.needsUpdate = this.normalAttribute.needsUpdate = this.uvAttribute.needsUpdate = true;
  }

  dispose() {
    this.geometry.dispose();
    if (this.state) this.state.free();
    if (this.view) this.view.free();
    this.state = this.view = null;
  }
}

// Checks a decoded completion's faces before StreamMesh.complete takes it: every corner names
// one of its `count` points. In slices of a million corners, each in a task of its own (a
// 1.2M-triangle completion's 3.6M corners held the page's thread ~5-10 ms at once). Rejects
// naming the mesh, the face and the point.
export async function checkCompletionFaces(meshIndex, index, count) {
  const I = index.array, slice = 1 << 20;
  for (let at = 0; at < I.length; at += slice) {
    if (at > 0) await new Promise((resolve) => setTimeout(resolve, 0));
    for (let i = at, end = Math.min(I.length, at + slice); i < end; i++) {
      if (I[i] >= count) throw new Error(`mesh ${meshIndex}: the completion's face ${Math.floor(i / 3)} names point ${I[i]} of ${count}`);
    }
  }
}

// Applies one mesh chunk's payload on the page: its parts' coded bytes one after the other,
// each applied in order. Resolves with the faces added.
export async function applyMeshChunk(meshes, chunk, payload) {
  checkParts(meshes, chunk, payload);
  let added = 0, at = 0;
  for (const part of chunk.parts) {
    const faces = part.face_end - part.face_begin;
    meshes[part.mesh].applySplits(payload, at, at + part.bytes, part.vertex_end - part.vertex_begin, faces,
      part.block >= 0 ? part.block : -1);
    at += part.bytes;
    added += faces;
  }
  return added;
}

// A texture of a decoded map: an ImageBitmap's, or a PixelImage's (a DataTexture: three.js
// uploads its bytes), the image itself the texture's source (its close() lets it go).
export function textureOf(image) {
  if (image && image.isKtx2Image) return image.texture;  // transcoded: KTX2Loader's CompressedTexture
  if (!(image instanceof PixelImage)) return new THREE.Texture(image);
  const texture = new THREE.DataTexture();
  texture.source = new THREE.TextureSource(image);
  return texture;
}
