// meshmux.js — web client of meshmux stream packages (model.mmxp, version 3).
//
// A package is one file: a 12-byte header ("MMXP", version, JSON length), a JSON table, a base
// .glb any glTF viewer opens, each mesh's base faces, then chunks (mesh refinements and texture
// levels) stored in rate-distortion order. Everything is fetched with HTTP Range requests:
//
//   const stream = new MeshmuxStream('model.mmxp', { renderer });
//   scene.add(await stream.open());      // the base, ready to show
//   stream.addEventListener('chunk', render);
//   await stream.play();                 // refinements and texture levels, chunk by chunk
//
// Per package mesh the client keeps ONE BufferGeometry with the capacity of the full mesh: a
// vertex buffer that is only appended to and an index buffer of every face received so far
// (degenerate faces included: later corner updates may open them up). Each part writes into
// those arrays and marks only the changed ranges for upload. Everything is drawn with one shared
// shading (base colour × texture × two-sided Lambert, light following the camera, no colour
// management), as meshmux's offscreen renderer draws it.
//
// Events (CustomEvent; detail = a copy of `stats`, plus what is said): 'base' (base built),
// 'chunk' (one chunk applied; + chunk, kind), 'progress' (bytes changed), 'complete' (every
// chunk applied), 'stopped' (budget reached or stop()), 'error' (+ error).

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';

import { PACKAGE_VERSION, VERTEX_BYTES, RangeReader, validateTable } from './package_reader.js';

export { PACKAGE_VERSION, VERTEX_BYTES, validateTable };
const HEADER_BYTES = 12;
const PROBE_BYTES = 65536;       // the first request: header, table and often the base too
const RANGE_GAP = 1024;          // corner updates closer than this share one upload range

// ---- Decoding: scratch memory and the hot loops ----------------------------------------------

let scratch = new ArrayBuffer(1 << 16);  // decoded vertices / updates (grown, never shrunk)
let scratchU8, scratchU16, scratchI8, scratchU32;
function ensureScratch(bytes) {
  if (scratchU8 && scratch.byteLength >= bytes) return;
  let size = scratch.byteLength;
  while (size < bytes) size *= 2;
  if (size !== scratch.byteLength) scratch = new ArrayBuffer(size);
  scratchU8 = new Uint8Array(scratch);
  scratchU16 = new Uint16Array(scratch);
  scratchI8 = new Int8Array(scratch);
  scratchU32 = new Uint32Array(scratch);
}
ensureScratch(0);

// Dequantizes `count` packed vertices (u16 and i8 views of the decoded bytes) into the float
// attributes from vertex `first` on: per vertex, u16 words 0..2 the position over `bounds`
// (min + q/65535·extent), bytes 8..10 the normal (/127), u16 words 6..7 the uv (/65535).
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

// Counts the non-degenerate faces among corners [start, end) of I. Returns -(i + 1) for the
// first face (corner i) naming a vertex >= limit.
export function scanFaces(I, start, end, limit) {
  let solid = 0;
  for (let i = start; i < end; i += 3) {
    const a = I[i], b = I[i + 1], c = I[i + 2];
    if (a >= limit || b >= limit || c >= limit) return -(i + 1);
    if (a !== b && b !== c && a !== c) solid++;
  }
  return solid;
}

// Applies u corner updates (S[0..u): ascending positions < corners, S[u..2u): vertices < limit)
// to the index buffer I and marks upload ranges on `attribute` (nearby faces share one).
// Returns the change of the non-degenerate face count, or UPDATE_ERROR (see updateError).
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
      // A new face: settle the previous one's status, subtract this one's status before.
      if (face >= 0) {
        const a = I[face], b = I[face + 1], c = I[face + 2];
        if (a !== b && b !== c && a !== c) delta++;
      }
      const a = I[f3], b = I[f3 + 1], c = I[f3 + 2];
      if (a !== b && b !== c && a !== c) delta--;
      face = f3;
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

// ---- One streaming mesh ----------------------------------------------------------------------

// Package mesh m on the client: arrays with the full mesh's capacity, the BufferGeometry that
// draws them, the counts received so far. appendVertices / applyUpdates / appendFaces are the
// whole refinement path; each validates what it decodes.
export class StreamMesh {
  constructor(desc, index) {
    this.index = index;
    this.capacityVertices = desc.vertices;
    this.capacityFaces = desc.faces;
    this.bounds = Float64Array.from(desc.bounds);
    this.vertices = 0;   // vertices received
    this.faces = 0;      // faces received (3 corners each in the index buffer)
    this.solid = 0;      // non-degenerate faces among them
    this.instances = 0;  // objects (× instances) that draw this mesh
    this.position = new Float32Array(3 * desc.vertices);
    this.normal = new Float32Array(3 * desc.vertices);
    this.uv = new Float32Array(2 * desc.vertices);
    this.indices = new Uint32Array(3 * desc.faces);
    // Commit the memory now (load time) rather than page by page while refining.
    for (const a of [this.position, this.normal, this.uv, this.indices]) a.fill(0);
    const g = this.geometry = new THREE.BufferGeometry();
    g.name = `meshmux_mesh_${index}`;
    const attribute = (array, size) => new THREE.BufferAttribute(array, size).setUsage(THREE.DynamicDrawUsage);
    g.setAttribute('position', this.positionAttribute = attribute(this.position, 3));
    g.setAttribute('normal', this.normalAttribute = attribute(this.normal, 3));
    g.setAttribute('uv', this.uvAttribute = attribute(this.uv, 2));
    g.setIndex(this.indexAttribute = attribute(this.indices, 1));
    // Bounds of every vertex the stream will ever hold: culling never hides refined parts.
    g.boundingBox = new THREE.Box3().setFromArray(desc.bounds);
    g.boundingSphere = g.boundingBox.getBoundingSphere(new THREE.Sphere());
    g.setDrawRange(0, 0);
  }

  // Copies the base .glb's vertices (any accessor layout) into [0, count).
  setBaseVertices(glbGeometry) {
    const pos = glbGeometry.getAttribute('position'), nrm = glbGeometry.getAttribute('normal');
    const uv = glbGeometry.getAttribute('uv');
    const P = this.position, N = this.normal, T = this.uv;
    for (let i = 0; i < pos.count; i++) {
      P[3 * i] = pos.getX(i); P[3 * i + 1] = pos.getY(i); P[3 * i + 2] = pos.getZ(i);
      if (nrm) { N[3 * i] = nrm.getX(i); N[3 * i + 1] = nrm.getY(i); N[3 * i + 2] = nrm.getZ(i); }
      if (uv) { T[2 * i] = uv.getX(i); T[2 * i + 1] = uv.getY(i); }
    }
    this.vertices = pos.count;
  }

  // Decodes meshopt vertex-codec bytes of `count` new vertices and dequantizes them.
  appendVertices(source, count) {
    const a = this.vertices;
    if (a + count > this.capacityVertices) throw new Error(`mesh ${this.index}: ${a + count} vertices exceed its capacity ${this.capacityVertices}`);
    ensureScratch(count * VERTEX_BYTES);
    MeshoptDecoder.decodeVertexBuffer(scratchU8.subarray(0, count * VERTEX_BYTES), count, VERTEX_BYTES, source);
    dequantize(scratchU16, scratchI8, count, this.bounds, this.position, this.normal, this.uv, a);
    this.positionAttribute.addUpdateRange(3 * a, 3 * count);
    this.normalAttribute.addUpdateRange(3 * a, 3 * count);
    this.uvAttribute.addUpdateRange(2 * a, 2 * count);
    this.positionAttribute.needsUpdate = this.normalAttribute.needsUpdate = this.uvAttribute.needsUpdate = true;
    this.vertices = a + count;
  }

  // Decodes meshopt index-codec bytes of `count` new faces straight into the index buffer after
  // the faces received so far; every corner must name a vertex already received.
  appendFaces(source, count) {
    const f = this.faces, I = this.indices, start = 3 * f, corners = 3 * count;
    if (f + count > this.capacityFaces) throw new Error(`mesh ${this.index}: ${f + count} faces exceed its capacity ${this.capacityFaces}`);
    MeshoptDecoder.decodeIndexBuffer(new Uint8Array(I.buffer, I.byteOffset + 4 * start, 4 * corners), corners, 4, source);
    const solid = scanFaces(I, start, start + corners, this.vertices);
    if (solid < 0) {
      const i = -solid - 1;
      throw new Error(`mesh ${this.index}: face ${i / 3} names vertex ${Math.max(I[i], I[i + 1], I[i + 2])}, only ${this.vertices} are received`);
    }
    this.solid += solid;
    this.faces = f + count;
    this.indexAttribute.addUpdateRange(start, corners);
    this.indexAttribute.needsUpdate = true;
    this.geometry.setDrawRange(0, 3 * this.faces);
  }

  // Decodes meshopt index-sequence bytes of 2u uint32 (u ascending corner positions, then u
  // vertices) and moves those corners of the faces received so far.
  applyUpdates(source, u) {
    ensureScratch(8 * u);
    MeshoptDecoder.decodeIndexSequence(scratchU8.subarray(0, 8 * u), 2 * u, 4, source);
    const delta = applyCornerUpdates(this.indices, scratchU32, u, 3 * this.faces, this.vertices, this.indexAttribute);
    if (delta === UPDATE_ERROR) {
      const { i, p, v } = updateError;
      throw new Error(`mesh ${this.index}: update ${i} sets corner ${p} to vertex ${v} (positions must ascend; ` +
        `${3 * this.faces} corners and ${this.vertices} vertices are received)`);
    }
    this.indexAttribute.needsUpdate = true;
    this.solid += delta;
  }

  dispose() { this.geometry.dispose(); }
}

// Applies one mesh chunk's payload to the stream meshes, part by part: vertices, then corner
// updates (positions refer to faces received before the part), then new faces. Returns the
// faces touched (new faces + updates).
export function applyMeshChunk(meshes, chunk, payload) {
  let at = 0, touched = 0;
  for (const part of chunk.parts) {
    const mesh = meshes[part.mesh];
    if (part.vertex_begin !== mesh.vertices || part.face_begin !== mesh.faces) {
      throw new Error(`mesh ${part.mesh}: part starts at vertex ${part.vertex_begin}, face ${part.face_begin}, ` +
        `but ${mesh.vertices} vertices and ${mesh.faces} faces are received`);
    }
    const vertexBytes = payload.subarray(at, at += part.vertex_bytes);
    const indexBytes = payload.subarray(at, at += part.index_bytes);
    const updateBytes = payload.subarray(at, at += part.update_bytes);
    if (part.vertex_bytes > 0) mesh.appendVertices(vertexBytes, part.vertex_end - part.vertex_begin);
    if (part.update_bytes > 0) mesh.applyUpdates(updateBytes, part.updates);
    if (part.index_bytes > 0) mesh.appendFaces(indexBytes, part.face_end - part.face_begin);
    touched += part.face_end - part.face_begin + part.updates;
  }
  return touched;
}

// ---- Warm-up ---------------------------------------------------------------------------------

// Prepares the decode path before the first chunk is applied (called while its bytes are on
// their way); a cold first chunk runs several times slower than the others.
//  - Grows the decoder's WebAssembly heap to `heapBytes` (the largest decode ahead) at once.
//    Growing detaches the heap's old ArrayBuffer, and V8 then throws away every function it
//    optimized assuming no ArrayBuffer was ever detached: better now than mid-stream.
//  - Runs the real refinement path on a tiny synthetic mesh (the decoders get compiled, every
//    branch gets type feedback), then the three loops on larger synthetic arrays until the
//    optimizing compiler takes them. About 20 ms, once per page.
let warmedUp = false, heapReserved = 0;
function warmUp(heapBytes) {
  try {
    if (heapBytes > heapReserved) {
      const n = Math.ceil(heapBytes / 5);  // a zero sequence of n values takes 4n + n + 5 bytes
      const source = new Uint8Array(n + 5);
      source[0] = 0xd0;
      MeshoptDecoder.decodeIndexSequence(new Uint8Array(4 * n), n, 4, source);
      heapReserved = heapBytes;
    }
    if (warmedUp) return;
    warmedUp = true;
    // Codec streams: 256 and 16 zero vertices (header 0xa0, per 256-vertex block and byte
    // channel one zero group header per 64 vertices, a 32-byte tail); the faces (0,1,2)(2,1,3);
    // corners 0, 4, 5 set to vertices 256, 260, 271 (header 0xd0, per value the LEB128 varint of
    // its zigzag delta shifted left once, a 4-byte tail).
    const zeros256 = new Uint8Array(1 + 20 * 4 + 32), zeros16 = new Uint8Array(1 + 20 + 32);
    zeros256[0] = zeros16[0] = 0xa0;
    const faces = [0xe0, 0xf0, 0x10, 0x00, 0x76, 0x87, 0x56, 0x67, 0x78, 0xa9, 0x86, 0x65, 0x89, 0x68, 0x98, 0x01, 0x69, 0x00, 0x00];
    const updates = [0xd0, 0x00, 0x10, 0x04, 0xec, 0x07, 0x10, 0x2c, 0x00, 0x00, 0x00, 0x00];
    const payload = new Uint8Array([...zeros256, ...faces, ...zeros16, ...faces, ...updates]);
    const part = (vertex_begin, vertex_end, face_begin, vertex_bytes, u, update_bytes) => ({
      mesh: 0, vertex_begin, vertex_end, face_begin, face_end: face_begin + 2, vertex_bytes,
      index_bytes: faces.length, updates: u, update_bytes,
    });
    const chunk = { parts: [part(0, 256, 0, zeros256.length, 0, 0), part(256, 272, 2, zeros16.length, 3, updates.length)] };
    for (let k = 0; k < 20; k++) {
      const mesh = new StreamMesh({ vertices: 272, faces: 4, bounds: [-1, -1, -1, 1, 1, 1] }, 0);
      applyMeshChunk([mesh], chunk, payload);
      mesh.dispose();
    }
    // Then the loops alone, long enough for the optimizing compiler: 4096 vertices, faces over
    // them, and updates of every third corner or so.
    const n = 4096, u16 = new Uint16Array(10 * n).map((_, i) => i * 7919), i8 = new Int8Array(u16.buffer);
    const I = new Uint32Array(3 * n).map((_, i) => (i * 2654435761) % n), S = new Uint32Array(2 * n);
    for (let i = 0; i < n; i++) { S[i] = 3 * i + (i % 3); S[n + i] = (i * 40503) % n; }
    const mesh = new StreamMesh({ vertices: n, faces: n, bounds: [-1, -1, -1, 1, 1, 1] }, 0);
    for (let k = 0; k < 12; k++) {
      dequantize(u16, i8, n, mesh.bounds, mesh.position, mesh.normal, mesh.uv, 0);
      scanFaces(I, 0, 3 * n, n);
      applyCornerUpdates(I, S, n, 3 * n, n, mesh.indexAttribute);
      mesh.indexAttribute.clearUpdateRanges();
    }
    mesh.dispose();
  } catch (e) {
    // Only a warm-up: the real decodes do the same work with the real data.
  }
}

// ---- Textures and material -------------------------------------------------------------------

// Texels used as stored bytes (no colour management), glTF's uv convention (no flip),
// trilinear + anisotropic filtering, clamped to the edge.
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
flat out float vMirror;  // -1 where the instance matrix mirrors (the winding flips on screen)
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
uniform vec3 lightDirection;  // view space, unit, towards the light
uniform float ambient, diffuse;  // the package's "view": what the distortion was measured with
in vec3 vNormal;
in vec2 vUv;
flat in float vMirror;
out vec4 fragColor;
void main() {
  vec4 base = baseColorFactor;
  if (textured) {
    // Trilinear + anisotropic where a pixel spans more than one texel; level 0 bilinear where
    // the texture is magnified (as meshmux's offscreen renderer: some software rasterizers
    // blur magnified texels under anisotropic filtering; GPUs filter them bilinearly anyway).
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
  fragColor = vec4(base.rgb * (ambient + diffuse * max(dot(n, lightDirection), 0.0)), 1.0);
}`;

// One ShaderMaterial per distinct glTF material (normally one: the atlas); all share the
// texture uniform, so a streamed level reaches every material at once. Shading comes from the
// package table's "view" (light in view space: it follows the camera).
function makeMaterial(source, mapUniform, view) {
  const color = source.color || new THREE.Color(1, 1, 1);
  return new THREE.ShaderMaterial({
    name: `meshmux(${source.name || 'material'})`,
    glslVersion: THREE.GLSL3,
    side: THREE.DoubleSide,
    uniforms: {
      baseColorFactor: { value: new THREE.Vector4(color.r, color.g, color.b, source.opacity ?? 1) },
      map: mapUniform,
      textured: { value: !!source.map },
      lightDirection: { value: new THREE.Vector3(...view.lightDirection).normalize() },
      ambient: { value: view.ambient },
      diffuse: { value: view.diffuse },
    },
    vertexShader: VERTEX_SHADER,
    fragmentShader: FRAGMENT_SHADER,
  });
}

// Between two chunks: the next animation frame (the page shows every step), or a bare task
// where there are no frames (workers); 50 ms at most when frames stall (a hidden page).
const pause = () => new Promise((resolve) => {
  if (typeof requestAnimationFrame !== 'function') { setTimeout(resolve, 0); return; }
  const timer = setTimeout(resolve, 50);
  requestAnimationFrame(() => { clearTimeout(timer); resolve(); });
});

// ---- The stream ------------------------------------------------------------------------------

export class MeshmuxStream extends EventTarget {
  // options: order (a name from the package's orders), budgetBytes (stop before a chunk would
  // take the bytes received past it), chunkBatchBytes (most bytes per range request, unless
  // one chunk is larger), renderer (a THREE.WebGLRenderer, for the texture anisotropy).
  constructor(url, options = {}) {
    super();
    this.url = String(url);
    this.options = { order: 'rate-distortion', budgetBytes: Infinity, chunkBatchBytes: 256 * 1024, renderer: null, ...options };
    this.object = new THREE.Group();
    this.object.name = 'meshmux';
    this.table = null;   // the validated package table
    this.order = null;   // the chosen order: {name, chunks, distortion}
    this.meshes = [];    // StreamMesh per package mesh
    this.materials = [];
    this.notes = [];     // non-fatal findings about the package
    this._reader = new RangeReader(this.url);
    this._map = { value: null };  // the texture uniform shared by the materials
    this._ownTextures = new Set();
    this._state = 'idle';
    this._abort = null;
    this._playing = null;
    this._position = 0;  // chunks of the order applied
    this._bytes = 0;
    this._textureSize = [0, 0];
    this._trianglesApplied = 0;
    this._applySeconds = 0;
  }

  _fail(message) { return new Error(`meshmux: ${this.url}: ${message}`); }
  _emit(type, extra) { this.dispatchEvent(new CustomEvent(type, { detail: { ...this.stats, ...extra } })); }
  _anisotropy() { return this.options.renderer ? Math.min(16, this.options.renderer.capabilities.getMaxAnisotropy()) : 1; }

  get budgetBytes() { return this.options.budgetBytes; }
  set budgetBytes(bytes) { this.options.budgetBytes = bytes; }
  get state() { return this._state; }
  get playing() { return this._playing !== null; }

  get stats() {
    let triangles = 0, vertices = 0;
    for (const m of this.meshes) { triangles += m.solid * m.instances; vertices += m.vertices; }
    return {
      bytesReceived: this._bytes, bytesTotal: this._reader.size,
      chunksApplied: this._position, chunkCount: this.table ? this.table.chunks.length : 0,
      triangles, vertices, textureWidth: this._textureSize[0], textureHeight: this._textureSize[1],
      distortion: this._position > 0 ? this.order.distortion[this._position - 1] : this.table ? this.table.base.distortion : NaN,
      order: this.order ? this.order.name : this.options.order,
      trianglesApplied: this._trianglesApplied, applySeconds: this._applySeconds, state: this._state,
    };
  }

  // Fetches the header, the table, the base and the base faces; builds the scene. Resolves with
  // this.object.
  async open() {
    if (this.table) return this.object;
    this._state = 'opening';
    try {
      this._abort = new AbortController();
      const signal = this._abort.signal;
      const probe = this._reader.probe(PROBE_BYTES, signal);
      probe.catch(() => {});  // awaited below
      await MeshoptDecoder.ready;
      const head = await probe;
      if (head.length < HEADER_BYTES) throw this._fail(`${head.length} bytes: too short for a meshmux package`);
      const magic = String.fromCharCode(...head.subarray(0, 4));
      if (magic !== 'MMXP') throw this._fail(`not a meshmux package (magic ${JSON.stringify(magic)}, expected "MMXP")`);
      const view = new DataView(head.buffer, head.byteOffset, HEADER_BYTES);
      const version = view.getUint32(4, true), dataStart = HEADER_BYTES + view.getUint32(8, true);
      if (version !== PACKAGE_VERSION) throw this._fail(`package version ${version} is not supported (this client reads version ${PACKAGE_VERSION})`);
      if (dataStart > this._reader.size) throw this._fail(`the JSON table runs past the end of the file (${this._reader.size} bytes)`);
      const json = head.length >= dataStart ? head.subarray(HEADER_BYTES, dataStart) : await this._reader.read(HEADER_BYTES, dataStart, signal);
      let raw;
      try {
        raw = JSON.parse(new TextDecoder('utf-8', { fatal: true }).decode(json));
      } catch (e) {
        throw this._fail(`the JSON table cannot be parsed (${e.message})`);
      }
      const table = validateTable(raw, { fileSize: Number.isFinite(this._reader.size) ? this._reader.size : Infinity, dataStart, fail: (m) => this._fail(m) });
      if (!Number.isFinite(this._reader.size)) {  // the server hid the size: the table's end stands in
        const ends = [table.base, ...table.meshes.map((m) => m.base_indices), ...table.chunks].map((r) => r.offset + r.size);
        this._reader.size = Math.max(dataStart, ...ends);
      }
      this.notes.push(...table.notes);
      const order = table.orders.find((o) => o.name === this.options.order);
      if (!order) throw this._fail(`no order "${this.options.order}" (the package has ${table.orders.map((o) => o.name).join(', ')})`);

      // The base .glb and the base faces (stored one after the other): one request.
      const ranges = [table.base, ...table.meshes.map((m) => m.base_indices).filter((r) => r.size > 0)];
      const lo = Math.min(...ranges.map((r) => r.offset)), hi = Math.max(...ranges.map((r) => r.offset + r.size));
      const sum = ranges.reduce((s, r) => s + r.size, 0);
      const block = await this._reader.read(lo, hi, signal);
      await this._buildBase(table, (r) => block.subarray(r.offset - lo, r.offset - lo + r.size));
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

  // Parses the base .glb; swaps in the streaming geometries and the shared shading.
  async _buildBase(table, slice) {
    const bytes = slice(table.base);
    const glb = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
    let gltf;
    try {
      gltf = await new GLTFLoader().setMeshoptDecoder(MeshoptDecoder).parseAsync(glb, '');
    } catch (e) {
      throw this._fail(`the base .glb cannot be loaded (${e && e.message ? e.message : e})`);
    }
    const root = gltf.scene || gltf.scenes[0];
    const objects = [];
    if (root) root.traverse((o) => { if (o.isMesh) objects.push(o); });
    if (!objects.length) throw this._fail('the base .glb holds no mesh');

    this.meshes = table.meshes.map((d, i) => new StreamMesh(d, i));
    const filled = new Set(), oldGeometries = new Set(), oldMaterials = new Set(), materialFor = new Map();
    for (const o of objects) {
      const source = Array.isArray(o.material) ? o.material[0] : o.material;
      if (!materialFor.has(source)) {
        if (source.map && !this._map.value) {
          this._map.value = configureTexture(source.map, this._anisotropy());
          this._textureSize = [source.map.image?.width || 0, source.map.image?.height || 0];
        }
        materialFor.set(source, makeMaterial(source, this._map, table.view));
      }
      [o.material].flat().forEach((x) => oldMaterials.add(x));
      o.material = materialFor.get(source);

      const m = o.userData.meshmux_mesh;
      if (m === undefined) { this.notes.push(`base .glb object "${o.name}" has no meshmux_mesh tag: drawn as it is`); continue; }
      const mesh = this.meshes[m];
      if (!Number.isInteger(m) || !mesh) throw this._fail(`base .glb object "${o.name}" names meshmux_mesh ${JSON.stringify(m)}, the package has ${this.meshes.length} meshes`);
      if (!filled.has(m)) {
        const d = table.meshes[m], pos = o.geometry.getAttribute('position');
        if (!pos || pos.count !== d.base_vertices) {
          throw this._fail(`base .glb mesh ${m} has ${pos ? pos.count : 0} vertices, the table says base_vertices ${d.base_vertices}`);
        }
        mesh.setBaseVertices(o.geometry);
        try {
          if (d.base_faces > 0) mesh.appendFaces(slice(d.base_indices), d.base_faces);
        } catch (e) {
          throw this._fail(`mesh ${m}: base_indices: ${e.message}`);
        }
        filled.add(m);
      }
      oldGeometries.add(o.geometry);
      o.geometry = mesh.geometry;
      if (o.isInstancedMesh) {
        o.boundingBox = o.boundingSphere = null;
        o.computeBoundingSphere();  // from the package bounds, over the instances
      }
      mesh.instances += o.isInstancedMesh ? o.count : 1;
    }
    this.meshes.forEach((_, m) => { if (!filled.has(m)) this.notes.push(`package mesh ${m} is drawn by no object of the base .glb`); });
    for (const g of oldGeometries) g.dispose();
    for (const material of oldMaterials) {
      for (const value of Object.values(material)) if (value && value.isTexture && value !== this._map.value) value.dispose();
      material.dispose();
    }
    this.materials = [...materialFor.values()];
    this.object.add(root);
    this.object.updateMatrixWorld(true);
  }

  // The world-space box of all the stream will draw: each mesh's package bounds through each
  // object's world matrix (and instance matrices).
  worldBounds(target = new THREE.Box3()) {
    target.makeEmpty();
    this.object.updateWorldMatrix(true, true);
    const matrix = new THREE.Matrix4(), box = new THREE.Box3();
    this.object.traverse((o) => {
      const mesh = o.isMesh && this.meshes[o.userData.meshmux_mesh];
      if (!mesh) return;
      for (let i = 0; i < (o.isInstancedMesh ? o.count : 1); i++) {
        if (o.isInstancedMesh) o.getMatrixAt(i, matrix).premultiply(o.matrixWorld);
        else matrix.copy(o.matrixWorld);
        target.union(box.copy(mesh.geometry.boundingBox).applyMatrix4(matrix));
      }
    });
    return target;
  }

  // The next batch from order position `pos`, `planned` bytes being counted before it: chunks
  // consecutive in the file, up to chunkBatchBytes (at least one chunk), none past the budget.
  _planBatch(pos, planned) {
    const seq = this.order.chunks, chunks = this.table.chunks;
    if (pos >= seq.length || planned + chunks[seq[pos]].size > this.options.budgetBytes) return null;
    const first = chunks[seq[pos]];
    const batch = { indices: [seq[pos]], start: first.offset, end: first.offset + first.size, bytes: planned + first.size };
    for (let k = pos + 1; k < seq.length; k++) {
      const c = chunks[seq[k]];
      if (c.offset !== batch.end || batch.end + c.size - batch.start > this.options.chunkBatchBytes ||
          batch.bytes + c.size > this.options.budgetBytes) break;
      batch.indices.push(seq[k]);
      batch.end += c.size;
      batch.bytes += c.size;
    }
    return batch;
  }

  // Fetches and applies chunks in the chosen order until the last one or the budget. Resolves
  // with the stats; while playing, returns the same promise.
  play() {
    if (!this.table) return Promise.reject(this._fail('play() before open()'));
    if (this._state === 'error' || this._state === 'disposed') return Promise.reject(this._fail(`cannot play: the stream is in state ${this._state}`));
    if (!this._playing) this._playing = this._run().finally(() => { this._playing = null; });
    return this._playing;
  }

  async _run() {
    const abort = this._abort = new AbortController(), signal = abort.signal;
    const read = (batch) => {
      const promise = batch && this._reader.read(batch.start, batch.end, signal);
      if (promise) promise.catch(() => {});  // awaited later, or dropped by the abort below
      return promise;
    };
    const stopped = () => new DOMException('stopped', 'AbortError');
    this._state = 'streaming';
    try {
      let batch = this._planBatch(this._position, this._bytes), fetching = read(batch);
      if (batch) warmUp(this.table.heapBytes);  // while the first batch is on its way
      while (batch) {
        const data = await fetching;
        const next = this._planBatch(this._position + batch.indices.length, batch.bytes);
        const nextFetch = read(next);  // prefetch while this batch is applied
        for (const index of batch.indices) {
          if (signal.aborted) throw stopped();
          const chunk = this.table.chunks[index];
          if (this._bytes + chunk.size > this.options.budgetBytes) { batch = null; break; }  // the budget was lowered
          await this._applyChunk(index, chunk, data.subarray(chunk.offset - batch.start, chunk.offset - batch.start + chunk.size));
          if (signal.aborted) throw stopped();
          this._position++;
          this._bytes += chunk.size;
          this._emit('chunk', { chunk: index, kind: chunk.kind });
          this._emit('progress');
          await pause();
          if (chunk.kind === 'texture') await this._gpuIdle();
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
      if (this._state === 'disposed') return this.stats;
      if (error && error.name === 'AbortError' && signal.aborted) {
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

  // Resolves once the GPU has done what was submitted so far (after a texture level: its
  // upload and mipmaps, costly on software rasterizers), so that decoding the next chunk does
  // not compete with it for the CPU. Needs the renderer; gives up after 2 s.
  async _gpuIdle() {
    const gl = this.options.renderer && this.options.renderer.getContext();
    const sync = gl && gl.fenceSync && gl.fenceSync(gl.SYNC_GPU_COMMANDS_COMPLETE, 0);
    if (!sync) return;
    gl.flush();
    for (const t0 = performance.now(); performance.now() - t0 < 2000;) {
      if (gl.clientWaitSync(sync, 0, 0) !== gl.TIMEOUT_EXPIRED) break;
      await new Promise((resolve) => setTimeout(resolve, 2));
    }
    gl.deleteSync(sync);
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
      this.notes.push(`chunk ${index}: the texture is ${bitmap.width}×${bitmap.height}, the table says ${chunk.width}×${chunk.height}`);
    }
    const texture = configureTexture(new THREE.Texture(bitmap), this._anisotropy());
    texture.name = `meshmux level ${bitmap.width}x${bitmap.height}`;
    this._ownTextures.add(texture);
    this._releaseTexture(this._map.value);
    this._map.value = texture;
    this._textureSize = [bitmap.width, bitmap.height];
  }

  _releaseTexture(texture) {
    if (!texture) return;
    texture.dispose();
    if (this._ownTextures.delete(texture)) texture.image.close();  // an ImageBitmap of ours
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
    for (const m of this.materials) m.dispose();
    this._releaseTexture(this._map.value);
    this._map.value = null;
    this.meshes = [];
    this.materials = [];
  }
}
