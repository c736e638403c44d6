// stream_decoder.js — the web client's mesh stream decoder: stream/'s C++ vertex-split decoder
// (stream/vsplit.h, its range coder stream/range_coder.h) compiled to WebAssembly
// (stream_decoder.wasm beside this module, built by CMake from stream/decoder_api.h's C API),
// and the thin wrapper that calls it. There is no JavaScript decoder: this module only moves
// bytes in and out of the module's memory. It imports nothing, so it runs in a Web Worker
// (stream_worker.js: the page's import map does not reach workers) and on the page (stream_mesh.js,
// when no worker runs).

// The module beside this file.
export const DECODER_URL = new URL('./stream_decoder.wasm', import.meta.url);

const loaded = new Map();  // URL → the Promise of its Decoder (one instance per realm and URL)

// Loads the module once (later calls share it): `source` is its URL (fetched; streamed where the
// server sends application/wasm, else compiled from the whole body) or its bytes. Resolves with
// a Decoder; rejects with an Error naming the URL.
export function loadDecoder(source = DECODER_URL) {
  if (!(source instanceof URL || typeof source === 'string')) return instantiate(source, 'bytes');
  const key = String(source);
  if (!loaded.has(key)) {
    const promise = instantiate(key, key);
    loaded.set(key, promise);
    promise.catch(() => loaded.delete(key));  // a later call may try again
  }
  return loaded.get(key);
}

async function instantiate(source, name) {
  let result = null;
  try {
    if (typeof source !== 'string') {
      result = await WebAssembly.instantiate(source, {});
    } else {
      if (typeof WebAssembly.instantiateStreaming === 'function') {
        // Fails on a server that sends another MIME type; the whole body then compiles below.
        try { result = await WebAssembly.instantiateStreaming(fetch(source), {}); } catch { result = null; }
      }
      if (!result) {
        const response = await fetch(source);
        if (!response.ok) throw new Error(`HTTP ${response.status} ${response.statusText}`);
        result = await WebAssembly.instantiate(await response.arrayBuffer(), {});
      }
    }
  } catch (e) {
    throw new Error(`the stream decoder ${name} cannot be loaded (${e && e.message ? e.message : e})`);
  }
  result.instance.exports._initialize();
  return new Decoder(result.instance.exports);
}

// One instance of the module: its exports and a scratch buffer for the bytes handed in.
export class Decoder {
  constructor(exports) {
    this.x = exports;
    this.scratch = 0;      // mmx_alloc'd input buffer
    this.scratchSize = 0;
  }

  // The module's memory as bytes (a fresh view: growing the memory detaches the old one).
  bytes() { return new Uint8Array(this.x.memory.buffer); }

  // Copies `data` into the scratch buffer (grown as needed); returns its address.
  input(data) {
    if (data.length > this.scratchSize) {
      if (this.scratch) this.x.mmx_free(this.scratch);
      this.scratchSize = Math.max(data.length, 2 * this.scratchSize, 65536);
      this.scratch = this.x.mmx_alloc(this.scratchSize) >>> 0;
      if (!this.scratch) { this.scratchSize = 0; throw new Error(`no memory for ${data.length} bytes`); }
    }
    this.bytes().set(data, this.scratch);
    return this.scratch;
  }

  // The last failure's message.
  error() {
    const x = this.x;
    const at = x.mmx_error() >>> 0;
    return new TextDecoder().decode(this.bytes().subarray(at, at + (x.mmx_error_length() >>> 0)));
  }
}

// Package mesh `index` as the decoder holds it (stream/vsplit.h VsplitMesh in the module's
// memory) with the table's full counts (`desc`: {vertices, faces}) as capacities, and its blocks
// (desc.blocks with their ranges, when it has any) for block parts. Every call
// that fails throws an Error "mesh <index>: <what>" (the decoder's message, which names the
// split); a state whose call failed is not used again. free() gives its memory back.
export class MeshDecoder {
  constructor(decoder, desc, index) {
    this.decoder = decoder;
    this.index = index;
    this.handle = this._call(() => decoder.x.mmx_mesh_new(desc.vertices, desc.faces)) >>> 0;
    if (!this.handle) throw this._fail(decoder.error());
    if (desc.blocks && desc.blocks.length) this.setBlocks(desc.blocks);
  }

  // The mesh's blocks (stream/format.h "Blocks": box, deps; the ranges package_reader.js
  // derived), which its block parts' parents are read against (stream/decoder_api.h
  // mmx_set_blocks).
  setBlocks(blocks) {
    const words = [];
    for (const b of blocks) words.push(...b.box, b.vertex_begin, b.vertex_end, b.deps.length, ...b.deps);
    const u32 = Uint32Array.from(words);
    const at = this.decoder.input(new Uint8Array(u32.buffer));
    this._check(this._call(() => this.decoder.x.mmx_set_blocks(this.handle, at, u32.length)));
  }

  _fail(message) { return new Error(`mesh ${this.index}: ${message}`); }

  // Runs a call into the module; a trap (out of memory) becomes an Error naming the mesh.
  _call(f) {
    try {
      return f();
    } catch (e) {
      throw this._fail(`the decoder stopped (${e && e.message ? e.message : e})`);
    }
  }

  _check(status) { if (status !== 0) throw this._fail(this.decoder.error()); }

  get vertices() { return this.decoder.x.mmx_vertices(this.handle); }
  get faces() { return this.decoder.x.mmx_faces(this.handle); }
  get solid() { return this.decoder.x.mmx_solid(this.handle); }

  // The base's vertices, quantized (stream/quantize.h): `count` of them from qp (3 per vertex),
  // qn (3) and qt (2).
  setBase(qp, qn, qt, count) {
    const d = this.decoder, x = d.x;
    const p = new Uint8Array(qp.buffer, qp.byteOffset, 6 * count), n = new Uint8Array(qn.buffer, qn.byteOffset, 3 * count);
    const t = new Uint8Array(qt.buffer, qt.byteOffset, 4 * count);
    const all = new Uint8Array(14 * count + 8);
    all.set(p, 0); all.set(t, 6 * count); all.set(n, 10 * count);  // u16s first (aligned), then i8s
    const at = d.input(all);
    this._check(this._call(() => x.mmx_set_base(this.handle, at, at + 10 * count, at + 6 * count, count)));
  }

  // Appends base faces (a glTF primitive's index array, 3 per face) to the state; the decoder
  // checks every corner. Returns the faces added.
  appendFaces(indices) {
    const d = this.decoder, u32 = Uint32Array.from(indices);
    const at = d.input(new Uint8Array(u32.buffer));
    this._check(this._call(() => d.x.mmx_append_faces(this.handle, at, u32.length)));
    return u32.length / 3;
  }

  // The index buffer (3 per face): a view of the module's memory, valid until the next call.
  get indices() {
    const x = this.decoder.x;
    return new Uint32Array(x.memory.buffer, x.mmx_indices(this.handle) >>> 0, 3 * this.faces);
  }

  // Starts listing the corners of the faces held now that later splits move (changes().moved).
  beginChanges() { this.decoder.x.mmx_begin_changes(this.handle); }

  // Applies one part (its coded bytes d[begin, end)): `splits` vertex splits and `faces` new
  // faces.
  applySplits(d, begin, end, splits, faces) {
    const at = this.decoder.input(d.subarray(begin, end));
    this._check(this._call(() => this.decoder.x.mmx_apply_part(this.handle, at, end - begin, splits, faces)));
  }

  // Applies the part of block `block` (stream/format.h "Blocks"): its contexts fresh, its
  // `splits` vertices placed at the block's stream numbers.
  applyBlockSplits(d, begin, end, block, splits, faces) {
    const at = this.decoder.input(d.subarray(begin, end));
    this._check(this._call(() => this.decoder.x.mmx_apply_block_part(this.handle, at, end - begin, block, splits, faces)));
  }

  // What changed since vertex v0 and face f0 (the counts at beginChanges): {v0, vn, f0, nf,
  // solid, position, normal, uv (the new vertices' float attributes: positions as the grid's
  // integers when `quantized`, else origin + q·step), appended (the new faces' indices), moved
  // ([corner, vertex] pairs: corners of earlier faces the splits moved)}, each array its own
  // buffer (transferable).
  changes(v0, f0, quantized, origin, step) {
    const d = this.decoder, x = d.x, h = this.handle, vn = this.vertices, nf = this.faces, n = vn - v0;
    const floats = x.mmx_alloc(32 * n + 4) >>> 0;
    if (!floats) throw this._fail(`no memory for ${n} vertices' attributes`);
    let position, normal, uv;
    try {
      this._call(() => x.mmx_dequantize(h, v0, vn, floats, floats + 12 * n, floats + 24 * n, quantized ? 1 : 0,
        origin[0], origin[1], origin[2], step));
      const buffer = x.memory.buffer;
      position = new Float32Array(buffer, floats, 3 * n).slice();
      normal = new Float32Array(buffer, floats + 12 * n, 3 * n).slice();
      uv = new Float32Array(buffer, floats + 24 * n, 2 * n).slice();
    } finally {
      x.mmx_free(floats);
    }
    const buffer = x.memory.buffer, indices = new Uint32Array(buffer, x.mmx_indices(h) >>> 0, 3 * nf);
    const appended = indices.slice(3 * f0, 3 * nf);
    const count = x.mmx_moved_count(h), corners = new Uint32Array(buffer, x.mmx_moved(h) >>> 0, count);
    const moved = new Uint32Array(2 * count);
    for (let i = 0; i < count; i++) {
      const c = corners[i];
      moved[2 * i] = c;
      moved[2 * i + 1] = indices[c];
    }
    return { v0, vn, f0, nf, solid: this.solid, position, normal, uv, appended, moved };
  }

  // stream/vsplit.h state_digest of the state: report.json's "stream_digests".
  digest() { return this.decoder.x.mmx_digest(this.handle) >>> 0; }

  free() {
    if (this.handle) this.decoder.x.mmx_mesh_free(this.handle);
    this.handle = 0;
  }
}
