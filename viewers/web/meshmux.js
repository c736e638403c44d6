// meshmux.js — web client of meshmux stream packages (model.mmxp, version 14; the format: stream/format.h).
//
// A package is one file: a 12-byte header ("MMXP", version, table length), a deflated JSON table, a base
// .glb any glTF viewer opens, each mesh's base faces, then chunks (mesh refinements and texture
// levels) stored in rate-distortion order. Everything is fetched with HTTP Range requests:
//
//   const stream = new MeshmuxStream('model.mmxp', { renderer });
//   scene.add(await stream.open());      // the base, ready to show
//   stream.addEventListener('chunk', render);
//   await stream.play();                 // refinements and texture levels, chunk by chunk
//
// Per package mesh the client keeps ONE BufferGeometry with the capacity of the full mesh: a
// vertex buffer that is only appended to and an index buffer of every face received so far.
// Each part is a range-coded stream of compact vertex splits (stream/vsplit.h), decoded and
// applied against the corner lists the client keeps per vertex. Everything is drawn as
// meshmux's offscreen renderer drew it to measure the distortion: with the package's view.shading
// "physical", three.js's MeshStandardMaterial (base colour, normal, occlusion-roughness-metallic
// and emissive maps, swapped together as levels arrive) under addStreamLighting's rig; with
// "lambert", one shared shading (base colour × texture × two-sided Lambert, light following the
// camera, no colour management).
//
// Events (CustomEvent; detail = a copy of `stats`, plus what is said): 'base' (base built),
// 'chunk' (one chunk applied; + chunk, kind), 'progress' (bytes changed), 'complete' (every
// chunk applied), 'stopped' (budget reached or stop()), 'error' (+ error).

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';

import { TaskPerMesh, TexturesInWorker } from './gltf_plugins.js';
import { CHANNEL_SLOTS, configureMap, configureTexture, makeMaterial, makeStandardMaterial } from './materials.js';
import { MAX_TABLE_BYTES, PACKAGE_VERSION, RangeReader, RequestLimiter, inflate, mergeIndex, validateTable } from './package_reader.js';
import { BLOCK_PACKAGE_VERSION, PACKAGE_HEADER_BYTES } from './stream_format.js';
import { StreamMesh, applyMeshChunk, checkCompletionFaces, loadDecoder, textureOf } from './stream_mesh.js';
import { Ktx2Image, compressedLike, gpuBytesOf, sharedKtx2Loader, shownTextures, texelGpuBytes, textureSource, usesBasisu } from './ktx2.js';
import { gpuIdle, nextTask, pause, taskSlicer, uploadInBands } from './upload.js';
import { displayScale, planRemaining, sequenceDistortion, textureAxis, viewWeights } from './view_plan.js';
import { PixelImage, StreamWorker, WorkerPool } from './worker_client.js';
import { BlockMeshState } from './block_view.js';
import { ViewPlayer, viewCapacities } from './view_stream.js';

export { PACKAGE_VERSION, mergeIndex, validateTable, RequestLimiter, StreamMesh, StreamWorker, WorkerPool, applyMeshChunk, inflate, loadDecoder };
export { addStreamLighting } from './lighting.js';
export { nextTask, uploadInBands };
const HEADER_BYTES = PACKAGE_HEADER_BYTES;
// Texture maps are decoded as stored (EXIF orientation applied): no colour conversion and no
// premultiplied alpha (three.js is told each map's colour space).
const IMAGE_OPTIONS = { imageOrientation: 'from-image', premultiplyAlpha: 'none', colorSpaceConversion: 'none' };
// Where three's Draco glTF decoder files are by default: beside this module, as `meshmux
// convert` and `meshmux batch` lay them out.
export const DRACO_DECODER_PATH = new URL('./three/addons/libs/draco/gltf/', import.meta.url).href;
// Where three's Basis Universal transcoder is (basis_transcoder.js and .wasm): KTX2 texture
// levels (convert --textures ktx2) are transcoded by it in KTX2Loader's workers.
export const BASIS_TRANSCODER_PATH = new URL('./three/addons/libs/basis/', import.meta.url).href;
export const PROBE_BYTES = 65536;  // the first request: header, table and often the base too

// A stream re-plans for the camera once its direction turned by more than a degree (view_plan.js).
const REPLAN_COS = Math.cos(Math.PI / 180);

// ---- The stream ------------------------------------------------------------------------------

export class MeshmuxStream extends EventTarget {
  // options: order (a name from the package's orders), budgetBytes (stop before a chunk would
  // take the bytes received past it), chunkBatchBytes (most bytes per range request, unless
  // one chunk is larger), renderer (a THREE.WebGLRenderer, for the texture anisotropy),
  // dracoDecoderPath (where three's draco/gltf/ decoder files are: a package whose base is the
  // whole model is Draco-coded; default: beside this module, as `meshmux convert` writes them),
  // camera (the THREE.Camera the model is seen through: with the package's per-view table the
  // stored order is re-planned for it before each batch, view_plan.js), adaptive (default true:
  // false keeps the stored order whatever the camera), firstBytes (a Promise of the Response to
  // a request for the package's first PROBE_BYTES bytes, Range: bytes=0-65535, that the page
  // started before this module loaded: index.html does, so the package arrives beside the
  // module graph), worker (default true: mesh refinements are decoded in a Web Worker,
  // stream_worker.js beside this module, by the WebAssembly decoder stream_decoder.wasm beside
  // it, and the page only copies in and uploads what changed; false, or where no worker can
  // start, loads that module on the page and decodes there), workers (a WorkerPool whose
  // shared workers decode for this stream instead of one of its own; MeshmuxWorld passes one),
  // limiter (a RequestLimiter shared by several streams: their range requests wait for it, so
  // a page of many packages keeps few in flight; MeshmuxWorld passes one), probeBytes (the
  // first request's bytes, default PROBE_BYTES: where the header, table and base are known to
  // end, exactly that, so that a package opens in one request of its own size; a world file
  // says it), dracoLoader (a function giving a Promise of a three DRACOLoader, its decoder
  // preloaded, shared by many streams: each DRACOLoader starts its own decoding workers and
  // compiles the decoder in each; called only for a Draco-coded base; MeshmuxWorld passes one),
  // uploadBandBytes (with a renderer, a texture level goes to the GPU in bands of rows of at
  // most this many bytes, one band per task, before it is shown: default 256 KiB; Infinity
  // leaves three.js to upload it whole inside the next frame), builds (a limiter whose
  // run(job) the base's build waits for, like a RequestLimiter: with many streams on a page
  // the bases are built a few at a time, first come first built, instead of all at once taking
  // turns task by task, which shows none until nearly all are done; MeshmuxWorld passes one),
  // uploadsBeside (default false: a texture level is on screen before the chunk after it is
  // taken; true: once its maps are decoded the stream goes on, the level's upload and swap
  // running beside the next chunks, levels still shown in order (`uploading` is the Promise of
  // the last one, null when none is left); MeshmuxWorld sets it, so that a package's grant ends
  // with its bytes decoded and a texture level being uploaded holds no request slot), display
  // ([width, height] in device pixels: the canvas the model is seen on, for which the order is
  // re-planned when it is smaller than the display the package was ordered for (texture levels
  // no pixel of it resolves go last, view_plan.js textureAxis); default null: the renderer's
  // drawing buffer, read at each re-plan; without either, the package's display),
  // basisTranscoderPath (where three's basis/ transcoder files are: KTX2 texture levels are
  // transcoded by KTX2Loader in its workers to what the GPU reads, BC7/BC1 on desktops,
  // ASTC/ETC on phones, RGBA where none, and uploaded compressed; default: beside this module),
  // ktx2Loader (a function giving a Promise of a three KTX2Loader, support detected, shared by
  // many streams; called only for a package with KTX2 textures; without it every stream of the
  // page shares one, ktx2.js sharedKtx2Loader), triangleBudget (a block package, stream/format.h
  // "Blocks", seen through `camera` with `adaptive` on: its blocks are chosen for the camera,
  // fetched by range and dropped again when they left the view, with at most this many faces
  // held over all meshes (view_stream.js; play() then runs until stop(), emitting 'settled'
  // whenever the view is refined to one pixel of screen-space error or the budget is full);
  // default Infinity: the stored order).
  constructor(url, options = {}) {
    super();
    this.url = String(url);
    this.options = { order: 'rate-distortion', budgetBytes: Infinity, chunkBatchBytes: 256 * 1024, renderer: null,
      dracoDecoderPath: DRACO_DECODER_PATH, basisTranscoderPath: BASIS_TRANSCODER_PATH, ktx2Loader: null,
      camera: null, adaptive: true, firstBytes: null, worker: true, workers: null, limiter: null,
      probeBytes: PROBE_BYTES, dracoLoader: null, uploadBandBytes: 2 ** 18, builds: null, uploadsBeside: false,
      display: null, triangleBudget: Infinity, ...options };
    this.object = new THREE.Group();
    this.object.name = 'meshmux';
    this.table = null;   // the validated package table
    this.order = null;   // the chosen order: {name, chunks, distortion}
    this.meshes = [];    // StreamMesh per package mesh
    this._whole = [];    // a whole base: its objects, drawn as they are
    this.materials = [];
    this._streamedMaterials = [];  // those of this.materials the texture levels refine
    this.notes = [];     // non-fatal findings about the package
    this._reader = new RangeReader(this.url);
    this._reader.limiter = this.options.limiter;
    this._map = { value: null };  // the texture uniform shared by the materials (Lambert)
    this._maps = {};              // physical: channel → the texture every material shows
    this._ownTextures = new Set();
    // Images of materials kept beside the atlas that texture levels bring up ("kept" maps): the
    // base .glb image index (extras.meshmux_image) → { textures: those its materials show (one
    // per sampler, uv set or transform), uses: [[material, slot], ...], own: the ImageBitmap of
    // ours they show, once a level replaced GLTFLoader's }.
    this._kept = new Map();
    this._unshownChannels = new Set();  // texture channels streamed that this client does not shade yet
    this._state = 'idle';
    this._abort = null;
    this._playing = null;
    this._position = 0;  // chunks of the order applied
    this._bytes = 0;
    this._textureSize = [0, 0];
    this._wrap = undefined;  // the atlas sampler's [wrapS, wrapT] (configureTexture), from the base
    this._trianglesApplied = 0;
    this._applySeconds = 0;
    this._worker = null;  // the StreamWorker decoding the mesh chunks, or null: on the page
    this._decoder = null;  // decoding on the page: the WebAssembly decoder (stream_decoder.js)
    this._setup = null;    // the worker's setup of the meshes (a Promise), awaited by mesh chunks
    this._indexed = null;  // the block index read and the decoders set up (a Promise; play awaits it)
    this._workerStart = null;  // the Promise of it while it starts
    this._uploads = null;  // uploadsBeside: the Promise of the last texture level's upload and swap
    this._bounds = null;   // worldBounds() as last computed, and the object's matrix then
    this._planned = null;  // the position and view direction the order was last re-planned at
    this._ktx2 = null;     // the Promise of the KTX2Loader (ktx2Loader()), once one was needed
    this._ktx2Config = null;  // its workerConfig (the formats the GPU reads), once known
    this._levelGpuBytes = 0;  // GPU bytes of the last texture level applied (its maps and kept maps)
    this._gpuBytes = null;    // gpuBytes() as last computed (null: textures changed since)
    this._viewCaps = null;    // played by view: per mesh, viewCapacities' entry
    this._view = null;        // the ViewPlayer, once play() started by view
    this.viewRoots = null;    // played by view: the objects whose copies of the meshes count (a
                              // world's placements); null: this.object
  }

  _fail(message) { return new Error(`meshmux: ${this.url}: ${message}`); }
  _emit(type, extra) { this.dispatchEvent(new CustomEvent(type, { detail: { ...this.stats, ...extra } })); }
  _anisotropy() { return this.options.renderer ? Math.min(16, this.options.renderer.capabilities.getMaxAnisotropy()) : 1; }

  // Played by view: the faces held at most (options.triangleBudget); lowering it drops detail
  // at the stream's next look at the view.
  get triangleBudget() { return this.options.triangleBudget; }
  set triangleBudget(faces) { this.options.triangleBudget = Number(faces); }
  get budgetBytes() { return this.options.budgetBytes; }
  set budgetBytes(bytes) { this.options.budgetBytes = bytes; }
  // The canvas the order is planned for ([width, height] device pixels; null: the renderer's).
  get display() { return this.options.display; }
  set display(size) { this.options.display = size ? [Number(size[0]), Number(size[1])] : null; }

  // The canvas in device pixels: options.display, else the renderer's drawing buffer, else null.
  canvasSize() {
    if (this.options.display) return this.options.display;
    const r = this.options.renderer;
    if (!r || typeof r.getDrawingBufferSize !== 'function') return null;
    const v = r.getDrawingBufferSize(new THREE.Vector2());
    return v.x > 0 && v.y > 0 ? [v.x, v.y] : null;
  }

  // Per texture level, where the package's per-view table is read for this canvas (view_plan.js
  // textureAxis); null when the canvas is not smaller than the package's display.
  textureAxis() {
    return this.table ? textureAxis(this.table, displayScale(this.table, this.canvasSize())) : null;
  }
  get state() { return this._state; }
  get playing() { return this._playing !== null; }
  // Whether this stream is played by view (a block package under triangleBudget with a camera).
  get byView() { return this._viewCaps !== null; }
  // uploadsBeside: the Promise of the texture level being uploaded (it resolves once that level
  // and every one before it are shown), or null when none is.
  get uploading() { return this._uploads; }

  get stats() {
    let triangles = 0, vertices = 0;
    for (const m of this.meshes) { triangles += m.solid * m.instances; vertices += m.vertices; }
    // A whole base never refines: its count is taken once (a game scene's has thousands of
    // objects, and a world reads every stream's stats at each of their events).
    if (!this._wholeCount || this._wholeCount.objects !== this._whole.length) {
      const counted = new Set(), c = this._wholeCount = { objects: this._whole.length, triangles: 0, vertices: 0 };
      for (const o of this._whole) {
        const g = o.geometry, count = g.index ? g.index.count : g.getAttribute('position').count;
        c.triangles += Math.floor(count / 3) * (o.isInstancedMesh ? o.count : 1);
        if (!counted.has(g)) { counted.add(g); c.vertices += g.getAttribute('position').count; }
      }
    }
    triangles += this._wholeCount.triangles;
    vertices += this._wholeCount.vertices;
    return {
      bytesReceived: this._bytes, bytesTotal: this._reader.size,
      chunksApplied: this._position, chunkCount: this.table ? this.table.chunks.length : 0,
      triangles, vertices, textureWidth: this._textureSize[0], textureHeight: this._textureSize[1],
      keptTexels: this.keptTexels(), gpuBytes: this.gpuBytes(), levelGpuBytes: this._levelGpuBytes,
      distortion: this._position > 0 ? this._sequenceDistortion[this._position - 1] : this.table ? this.table.base.distortion : NaN,
      order: this.order ? this.order.name : this.options.order,
      // The order being followed: the chosen one, or "view-adapted" once re-planned for the camera.
      orderFollowed: this._followed || (this.order ? this.order.name : this.options.order),
      trianglesApplied: this._trianglesApplied, applySeconds: this._applySeconds, state: this._state,
      decoder: this._worker ? 'worker' : 'page',
      ...(this._view ? this._view.stats() : {}),
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
      const first = this.options.firstBytes ? PROBE_BYTES : Math.max(HEADER_BYTES, Math.floor(this.options.probeBytes) || PROBE_BYTES);
      const probe = this._reader.probe(first, signal, this.options.firstBytes);
      probe.catch(() => {});  // awaited below
      await MeshoptDecoder.ready;
      const head = await probe;
      this._bytes = head.length;  // progress from the first bytes: the page shows them at once
      this._emit('progress');
      if (head.length < HEADER_BYTES) throw this._fail(`${head.length} bytes: too short for a meshmux package`);
      const magic = String.fromCharCode(...head.subarray(0, 4));
      if (magic !== 'MMXP') throw this._fail(`not a meshmux package (magic ${JSON.stringify(magic)}, expected "MMXP")`);
      const view = new DataView(head.buffer, head.byteOffset, HEADER_BYTES);
      const version = view.getUint32(4, true), dataStart = HEADER_BYTES + view.getUint32(8, true);
      if (version !== PACKAGE_VERSION && version !== BLOCK_PACKAGE_VERSION) {
        throw this._fail(`package version ${version} is not supported (this client reads versions ${PACKAGE_VERSION} and ${BLOCK_PACKAGE_VERSION})`);
      }
      if (dataStart > this._reader.size) throw this._fail(`the JSON table runs past the end of the file (${this._reader.size} bytes)`);
      const deflated = head.length >= dataStart ? head.subarray(HEADER_BYTES, dataStart) : await this._reader.read(HEADER_BYTES, dataStart, signal);
      let raw;
      try {
        const json = await inflate(deflated, MAX_TABLE_BYTES);
        raw = JSON.parse(new TextDecoder('utf-8', { fatal: true }).decode(json));
      } catch (e) {
        throw this._fail(`the JSON table cannot be read (${e.message})`);
      }
      const table = validateTable(raw, { fileSize: Number.isFinite(this._reader.size) ? this._reader.size : Infinity, dataStart, fail: (m) => this._fail(m) });
      if (!Number.isFinite(this._reader.size)) {  // the server hid the size: the table's end stands in
        const ends = [table.base, ...table.chunks].map((r) => r.offset + r.size);
        this._reader.size = Math.max(dataStart, ...ends);
      }
      this.notes.push(...table.notes);
      const order = table.orders.find((o) => o.name === this.options.order);
      if (!order) throw this._fail(`no order "${this.options.order}" (the package has ${table.orders.map((o) => o.name).join(', ')})`);

      // The base .glb: one request. A whole (Draco-coded) base needs three's Draco decoder: it
      // loads while the base arrives, not after.
      const draco = table.base.whole ? this._dracoLoader() : null;
      if (draco) draco.catch(() => {});  // awaited in _buildBase
      // The decoding worker (mesh chunks and texture maps) starts while the base arrives.
      const worker = this._workerStart = !this.options.worker ? Promise.resolve(null)
        : this.options.workers ? this.options.workers.acquire() : StreamWorker.start();
      const base = await this._reader.read(table.base.offset, table.base.offset + table.base.size, signal);
      this._worker = await worker;
      // Later ranges are fetched by the worker (their bodies stay off the main thread).
      if (this._worker) this._reader.fetchRange = (...a) => this._worker.fetchRange(...a);
      // No worker: the WebAssembly decoder (stream_decoder.wasm) runs on the page.
      if (!this._worker && !table.base.whole) {
        try {
          this._decoder = await loadDecoder();
        } catch (e) {
          throw this._fail(e.message);
        }
      }
      // A block package seen through a camera under a triangle budget is played by view.
      const o = this.options;
      if (Number.isFinite(o.triangleBudget) && o.triangleBudget >= 0 && o.camera && o.adaptive && table.meshes.some((d) => d.blockCount)) {
        this._viewCaps = viewCapacities(table, o.triangleBudget);
      }
      await nextTask();  // the base is built in tasks of its own (_buildBase), not in the fetch's
      const build = () => this._buildBase(table, base, draco);
      await (this.options.builds ? this.options.builds.run(build) : build());
      // The decoders take the bases (the worker's WebAssembly decoder checks them) while the base
      // shows: the first picture does not wait for the module, nor for a block index (read after
      // the base: what refinements need, not the first picture); the first mesh chunk does.
      if (table.indexPending) {
        this._indexed = this._readIndex(table, raw, dataStart, signal);
        this._indexed.catch(() => {});  // reported where it is awaited (play)
      } else {
        this._startDecoders(table);
        this._indexed = Promise.resolve();
      }
      this.table = table;
      this.order = order;
      this._sequence = order.chunks.slice();  // the chunks in the order followed (re-planned)
      this._sequenceDistortion = order.distortion.slice();
      this._followed = order.name;
      this._bytes = dataStart + table.base.size;
      this._state = 'base';
      this._emit('base');
      this._emit('progress');
      return this.object;
    } catch (error) {
      // A failed open leaves no worker running (one may still be starting).
      if (this._workerStart) this._workerStart.then((w) => { if (w) w.terminate(); });
      this._worker = null;
      this._state = 'error';
      this._emit('error', { error });
      throw error;
    } finally {
      this._abort = null;
    }
  }

  // The decoders set up with the bases (and, for block meshes, their blocks): the worker's
  // (this._setup, awaited by mesh chunks), or on the page the block meshes' blocks and, played by
  // view, their BlockMeshStates.
  _startDecoders(table) {
    if (this._worker && this.meshes.length) {
      this._setup = this._worker.setup(table.meshes, this.meshes, this._viewCaps)
        .catch((e) => { throw this._fail(`the base cannot be decoded (${e.message})`); });
      this._setup.catch(() => {});  // reported where it is awaited
      return;
    }
    this.meshes.forEach((mesh, i) => {
      const d = table.meshes[i], cap = this._viewCaps && this._viewCaps[i];
      if (cap && mesh.base) {  // played by view on the page: the state takes blocks
        mesh.view = new BlockMeshState(this._decoder, d, i, mesh.base,
          { quantized: mesh.quantized, origin: mesh.origin, step: mesh.step, ...cap });
        mesh.base = null;
        mesh.solid = mesh.view.solid;
      } else if (mesh.state && d.blocks.length) {
        mesh.state.setBlocks(d.blocks);
      }
    });
  }

  // The block index (stream/format.h "Block index"), fetched after the base: merged into the
  // table (`raw`, as parsed), validated whole, its block lists and parts put in `table` (the one
  // this.table holds); its bytes counted as received; then the decoders set up.
  async _readIndex(table, raw, dataStart, signal) {
    const { offset, size } = table.index;
    const stored = await this._reader.read(offset, offset + size, signal);
    let index;
    try {
      index = JSON.parse(new TextDecoder('utf-8', { fatal: true }).decode(await inflate(stored, MAX_TABLE_BYTES)));
    } catch (e) {
      throw this._fail(`the block index cannot be read (${e.message})`);
    }
    const fail = (m) => this._fail(m);
    const whole = validateTable(mergeIndex(raw, index, fail), { fileSize: Number.isFinite(this._reader.size) ? this._reader.size : Infinity, dataStart, fail });
    table.meshes.forEach((d, i) => { d.blocks = whole.meshes[i].blocks; });
    table.chunks.forEach((c, i) => { c.parts = whole.chunks[i].parts; });
    table.notes = whole.notes;
    table.indexPending = false;
    this.notes.push(...whole.notes);
    this._bytes += size;
    this._emit('progress');
    this._startDecoders(table);
  }

  // Parses the base .glb; swaps in the streaming geometries and the shared shading.
  // three's DRACOLoader with its decoder fetched and compiled (DRACOLoader.preload): the one
  // options.dracoLoader() gives (shared by many streams, never disposed here), else one of the
  // stream's own.
  async _dracoLoader() {
    if (this.options.dracoLoader) return this.options.dracoLoader();
    const { DRACOLoader } = await import('three/addons/loaders/DRACOLoader.js');
    return new DRACOLoader().setDecoderPath(this.options.dracoDecoderPath).preload();
  }

  // three's KTX2Loader: options.ktx2Loader()'s, else the page's one for the transcoder folder
  // (ktx2.js sharedKtx2Loader: support detected for the renderer, or the GPU a canvas of its own
  // reports). Never disposed here. One Promise per stream.
  ktx2Loader() {
    if (this._ktx2) return this._ktx2;
    this._ktx2 = (async () => {
      let loader;
      if (this.options.ktx2Loader) {
        loader = await this.options.ktx2Loader();
      } else {
        const { KTX2Loader } = await import('three/addons/loaders/KTX2Loader.js');
        loader = sharedKtx2Loader(KTX2Loader, this.options.basisTranscoderPath, this.options.renderer);
      }
      this._ktx2Config = loader.workerConfig;
      return loader;
    })();
    return this._ktx2;
  }

  async _buildBase(table, stored, dracoLoader = null) {
    let bytes = stored;
    if (table.base.deflated) {
      try {
        bytes = await inflate(stored, table.base.glbSize);
      } catch (e) {
        throw this._fail(`the base .glb cannot be inflated (${e.message})`);
      }
    }
    if (bytes.length !== table.base.glbSize) throw this._fail(`the base .glb is ${bytes.length} bytes, the table says ${table.base.glbSize}`);
    // Parsing, the meshes' buffers and the objects' swap each get tasks of their own: one task
    // for all of a base is tens to hundreds of milliseconds of the page's time.
    await nextTask();
    const glb = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
    let gltf, draco = null;
    try {
      const loader = new GLTFLoader().setMeshoptDecoder(MeshoptDecoder).register((parser) => new TaskPerMesh(parser));
      const worker = this._worker;
      // As ImageBitmaps: three uploads a base's textures whole, and reading their bytes out
      // (PixelImage) would cost the worker a copy each for nothing.
      if (worker) loader.register((parser) => new TexturesInWorker(parser, (bytes, mime, own) => worker.decodeImage(bytes, mime, IMAGE_OPTIONS, false, own)));
      if (table.base.whole) {  // Draco-coded (stream/format.h): its decoder, loaded only then
        draco = await (dracoLoader || this._dracoLoader());
        loader.setDRACOLoader(draco);
      }
      if (usesBasisu(bytes)) loader.setKTX2Loader(await this.ktx2Loader());  // KTX2 images
      gltf = await loader.parseAsync(glb, '');
      await nextTask();
    } catch (e) {
      throw this._fail(`the base .glb cannot be loaded (${e && e.message ? e.message : e})`);
    } finally {
      if (draco && !this.options.dracoLoader) draco.dispose();
    }
    const root = gltf.scene || gltf.scenes[0];
    const objects = [];
    if (root) root.traverse((o) => { if (o.isMesh) objects.push(o); });
    if (!objects.length) throw this._fail('the base .glb holds no mesh');

    const slice = taskSlicer();
    this.meshes = [];
    if (!table.base.whole) {
      for (const [i, d] of table.meshes.entries()) {
        await slice();
        const cap = this._viewCaps && this._viewCaps[i];
        const mesh = new StreamMesh(cap ? { ...d, vertices: cap.capacityVertices, faces: cap.capacityFaces } : d, i,
          { decoder: this._worker || cap ? null : this._decoder, deferCommit: true });
        for (const _ of mesh.commitPieces()) await slice();
        this.meshes.push(mesh);
      }
    }
    const filled = new Set(), oldGeometries = new Set(), oldMaterials = new Set(), materialFor = new Map();
    const baseFaces = new Set(), facesDone = new Set();
    const physical = table.view.physical;
    // The base materials that show the stream's texture levels: those sampling the image the
    // base's first material samples (meshmux streams that material's texture, the atlas, and
    // every atlas material shares it). Materials kept beside the atlas (tiled textures, layer
    // textures, samplers without mipmaps) keep their own textures, as GLTFLoader gives them.
    const json = gltf.parser.json;
    const imageOf = (i) => {
      const t = json.materials?.[i]?.pbrMetallicRoughness?.baseColorTexture;
      return textureSource(t ? json.textures?.[t.index] : undefined);
    };
    const streamImage = imageOf(0);
    const streamed = (material) => {
      const a = gltf.parser.associations.get(material);
      return !a || a.materials === undefined || imageOf(a.materials) === streamImage;
    };
    // A streamed mesh carries one uv set (the refinements code TEXCOORD_0 only): a kept
    // material's maps on another set (an occlusion map on TEXCOORD_1) would read coordinates
    // the stream never sends, so the streamed copy goes without them.
    const ownUvSetOnly = (material) => {
      if (table.base.whole) return material;
      const other = Object.keys(material).filter((k) => material[k] && material[k].isTexture && material[k].channel > 0);
      if (!other.length) return material;
      const copy = material.clone();
      for (const k of other) copy[k] = null;
      this.notes.push(`material "${material.name}": ${other.join(', ')} left out while streaming (they sample a second uv set)`);
      return copy;
    };
    for (const o of objects) {
      await slice();
      const source = Array.isArray(o.material) ? o.material[0] : o.material;
      if (!materialFor.has(source) && !streamed(source)) materialFor.set(source, ownUvSetOnly(source));
      if (!materialFor.has(source)) {
        if (source.map && !this._map.value && !this._maps.base_color) {
          this._textureSize = [source.map.image?.width || 0, source.map.image?.height || 0];
          // Every atlas material samples the atlas with one sampler; the levels keep its wraps.
          this._wrap = [source.map.wrapS, source.map.wrapT];
          if (!physical) this._map.value = configureTexture(source.map, this._anisotropy(), this._wrap);
        }
        if (physical) {
          for (const [channel, slots] of Object.entries(CHANNEL_SLOTS))
            if (!this._maps[channel] && source[slots[0]])
              this._maps[channel] = configureMap(source[slots[0]], channel, this._anisotropy(), this._wrap);
          materialFor.set(source, makeStandardMaterial(source, this._maps));
        } else {
          materialFor.set(source, makeMaterial(source, this._map, table.view));
        }
      }
      [o.material].flat().forEach((x) => { if (x !== materialFor.get(source)) oldMaterials.add(x); });
      o.material = materialFor.get(source);

      const m = o.userData.meshmux_mesh;
      if (table.base.whole) { this._whole.push(o); continue; }  // every mesh whole: drawn as it is
      if (m === undefined) { this.notes.push(`base .glb object "${o.name}" has no meshmux_mesh tag: drawn as it is`); continue; }
      const mesh = this.meshes[m];
      if (!Number.isInteger(m) || !mesh) throw this._fail(`base .glb object "${o.name}" names meshmux_mesh ${JSON.stringify(m)}, the package has ${this.meshes.length} meshes`);
      if (!filled.has(m)) {
        const d = table.meshes[m], pos = o.geometry.getAttribute('position');
        if (!pos || pos.count !== d.base_vertices) {
          throw this._fail(`base .glb mesh ${m} has ${pos ? pos.count : 0} vertices, the table says base_vertices ${d.base_vertices}`);
        }
        for (const _ of mesh.baseVertexPieces(o.geometry)) await slice();
        filled.add(m);
      }
      // The base faces: the mesh's primitives' indices in primitive order (its first node's
      // objects, each primitive's geometry once).
      if (!baseFaces.has(o.geometry) && !facesDone.has(m)) {
        baseFaces.add(o.geometry);
        try {
          if (o.geometry.index) mesh.appendIndices(o.geometry.index.array);
        } catch (e) {
          throw this._fail(`mesh ${m}: base faces: ${e.message}`);
        }
      } else if (baseFaces.has(o.geometry)) {
        facesDone.add(m);  // a second node drawing the mesh: its faces are in
      }
      oldGeometries.add(o.geometry);
      o.geometry = mesh.geometry;
      if (o.isInstancedMesh) {
        o.boundingBox = o.boundingSphere = null;
        o.computeBoundingSphere();  // from the package bounds, over the instances
      }
      mesh.instances += o.isInstancedMesh ? o.count : 1;
    }
    this.meshes.forEach((mesh, m) => {
      if (table.base.whole) return;
      if (!filled.has(m)) this.notes.push(`package mesh ${m} is drawn by no object of the base .glb`);
      else if (mesh.faces !== table.meshes[m].base_faces) throw this._fail(`base .glb mesh ${m} has ${mesh.faces} faces, the table says base_faces ${table.meshes[m].base_faces}`);
    });
    for (const g of oldGeometries) {
      await slice();
      g.dispose();
    }
    // The textures that live on: the stream's, and those of materials kept as they came.
    const live = new Set([this._map.value, ...Object.values(this._maps)]);
    for (const m of materialFor.values()) for (const value of Object.values(m)) if (value && value.isTexture) live.add(value);
    for (const material of oldMaterials) {
      await slice();
      for (const value of Object.values(material)) if (value && value.isTexture && !live.has(value)) value.dispose();
      material.dispose();
    }
    this.materials = [...materialFor.values()];
    this._gpuBytes = null;
    // The materials the texture levels refine (kept ones keep their own textures).
    this._streamedMaterials = [...materialFor].filter(([source]) => streamed(source)).map(([, m]) => m);
    await slice();
    this._findKept(gltf.parser, [...materialFor].filter(([source]) => !streamed(source)).map(([, m]) => m));
    await slice();
    this.object.add(root);
    this.object.updateMatrixWorld(true);
  }

  // Where the kept materials' images are shown (this._kept): each texture GLTFLoader made is
  // traced to its glTF image through the parser's associations (textures that share an image
  // share its THREE.Source, clones for another uv set or a transform included).
  _findKept(parser, materials) {
    const json = parser.json, imageOfSource = new Map();
    for (const [o, ref] of parser.associations) {
      if (!o || !o.isTexture || !ref || ref.textures === undefined) continue;
      const k = json.images?.[textureSource(json.textures?.[ref.textures])]?.extras?.meshmux_image;
      if (Number.isInteger(k)) imageOfSource.set(o.source, k);
    }
    for (const m of materials) {
      for (const [slot, value] of Object.entries(m)) {
        if (!value || !value.isTexture || !imageOfSource.has(value.source)) continue;
        const k = imageOfSource.get(value.source);
        if (!this._kept.has(k)) this._kept.set(k, { textures: new Set(), uses: [] });
        this._kept.get(k).textures.add(value);
        this._kept.get(k).uses.push([m, slot]);
      }
    }
  }

  // GPU bytes of every texture the stream's materials show (each once: ktx2.js gpuBytesOf), as
  // three.js holds them once uploaded. Recomputed only after textures changed.
  gpuBytes() {
    if (this._gpuBytes !== null) return this._gpuBytes;
    const textures = shownTextures(this.materials, [this._map.value, ...Object.values(this._maps)]);
    return (this._gpuBytes = textures.reduce((n, t) => n + gpuBytesOf(t), 0));
  }

  // GPU bytes texture chunk `index` shows once applied: its maps and kept images at their sizes
  // (ktx2.js texelGpuBytes: KTX2 maps as the GPU here reads them once transcoded).
  chunkGpuBytes(index) {
    const c = this.table.chunks[index], config = this._ktx2Config;
    if (c.kind !== 'texture') return 0;
    let n = 0;
    for (const m of c.maps) n += c.width * c.height * texelGpuBytes(m.mime, config);
    for (const k of c.kept || []) n += k.width * k.height * texelGpuBytes(k.mime, config);
    return Math.round(n);
  }

  // Texels of the kept images as shown (image k alone, or all of them).
  keptTexels(k) {
    const of = (e) => { const t = e.textures.values().next().value, i = t && t.image; return i ? (i.width || 0) * (i.height || 0) : 0; };
    if (k !== undefined) return this._kept.has(k) ? of(this._kept.get(k)) : 0;
    let n = 0;
    for (const e of this._kept.values()) n += of(e);
    return n;
  }

  // A texture level's kept images (decoded: [[k, bitmap]]) as the textures that replace those
  // showing them: each a copy (sampler, uv set, transform, colour space kept) of the new pixels.
  // Images no material shows here are let go. Upload `textures`, then swap with _swapKept.
  _keptSwaps(decoded) {
    const swaps = [], textures = [];
    for (const [k, bitmap] of decoded) {
      const e = this._kept.get(k);
      if (!e) { bitmap.close(); continue; }
      const replaced = new Map();
      for (const old of e.textures) {
        let t;
        if (bitmap instanceof Ktx2Image) {
          t = compressedLike(bitmap.texture, old);
        } else {
          t = (bitmap instanceof PixelImage ? new THREE.DataTexture() : new THREE.Texture()).copy(old);
          t.source = new THREE.TextureSource(bitmap);
        }
        t.name = `meshmux kept ${k} ${bitmap.width}x${bitmap.height}`;
        t.needsUpdate = true;
        replaced.set(old, t);
        textures.push(t);
      }
      swaps.push([e, replaced, bitmap]);
    }
    return { swaps, textures };
  }

  _swapKept({ swaps }) {
    for (const [e, replaced, bitmap] of swaps) {
      for (const [m, slot] of e.uses) if (replaced.has(m[slot])) m[slot] = replaced.get(m[slot]);
      for (const old of e.textures) {
        old.dispose();
        if (e.own && old.image && typeof old.image.close === 'function') old.image.close();
      }
      e.textures = new Set(replaced.values());
      e.own = bitmap;
    }
    this._gpuBytes = null;
  }

  // The world-space box of all the stream will draw: each mesh's package bounds through each
  // object's world matrix (and instance matrices). Kept while `object`'s world matrix stays as it
  // was (the objects inside it are not moved; a world re-plans every package before each of its
  // requests, and a game scene's base has thousands of instances).
  worldBounds(target = new THREE.Box3()) {
    this.object.updateWorldMatrix(true, false);
    const at = this.object.matrixWorld, cached = this._bounds;
    if (cached && cached.objects === this.object.children.length && cached.matrix.equals(at)) return target.copy(cached.box);
    target.makeEmpty();
    this.object.updateWorldMatrix(true, true);
    const matrix = new THREE.Matrix4(), box = new THREE.Box3(), wholes = new Set(this._whole);
    this.object.traverse((o) => {
      const whole = wholes.has(o), mesh = o.isMesh && !whole && this.meshes[o.userData.meshmux_mesh];
      if (!mesh && !whole) return;
      const geometry = whole ? o.geometry : mesh.geometry;
      if (whole && !geometry.boundingBox) geometry.computeBoundingBox();
      for (let i = 0; i < (o.isInstancedMesh ? o.count : 1); i++) {
        if (o.isInstancedMesh) o.getMatrixAt(i, matrix).premultiply(o.matrixWorld);
        else matrix.copy(o.matrixWorld);
        target.union(box.copy(geometry.boundingBox).applyMatrix4(matrix));
      }
    });
    this._bounds = { matrix: at.clone(), objects: this.object.children.length, box: target.clone() };
    return target;
  }

  // The next batch from order position `pos`, `planned` bytes being counted before it: chunks
  // consecutive in the file, up to chunkBatchBytes (at least one chunk), none past the budget.
  _planBatch(pos, planned) {
    this._replan(pos);
    const seq = this._sequence, chunks = this.table.chunks;
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

  // Re-plans the chunks from position `pos` on for the camera's direction and the canvas
  // (view_plan.js): only the stored order is adapted (a baseline chosen by name is played as it
  // is), and only with the package's per-view table and a camera or a canvas smaller than the
  // package's display (without a camera: from the package's default view direction).
  _replan(pos) {
    const camera = this.options.camera, vt = this.table.view_table;
    if (!this.options.adaptive || !vt || this.order !== this.table.orders[0] || pos >= this._sequence.length) return;
    const axis = this.textureAxis();
    if (!camera && !axis) return;
    let direction;
    if (camera) {
      const centre = this.worldBounds().getCenter(new THREE.Vector3());
      direction = camera.getWorldPosition(new THREE.Vector3()).sub(centre);
      this.object.updateWorldMatrix(true, false);
      direction.transformDirection(new THREE.Matrix4().copy(this.object.matrixWorld).invert());
    } else {
      direction = new THREE.Vector3().fromArray(this.table.view.direction).normalize();
    }
    // Planned already at this position from within a degree of this direction, for the same
    // canvas: kept (a world asks every package before each of its requests).
    const last = this._planned, key = axis ? axis.join(',') : '';
    if (last && last.pos === pos && last.axis === key && last.direction.dot(direction) > REPLAN_COS) return;
    this._planned = { pos, direction, axis: key };
    const applied = new Set(this._sequence.slice(0, pos));
    const stored = this.order.chunks.filter((c) => !applied.has(c));
    const plan = planRemaining(this.table, viewWeights(vt, direction.toArray()), applied, stored, axis);
    this._sequence = this._sequence.slice(0, pos).concat(plan.sequence);
    this._sequenceDistortion = sequenceDistortion(this.table, this._sequence);
    const adaptedBefore = this._followed === 'view-adapted';
    this._followed = plan.adapted || adaptedBefore ? 'view-adapted' : this.order.name;
  }

  // The chunks the stream would fetch next (after re-planning for the camera), at most `max`,
  // in order: [{ index, chunk, applied (a Set of the chunks applied before it), before, after
  // (the order's view-independent distortion before and after it) }]; [] when none is left. For
  // a scheduler over many streams.
  nextChunks(max = 1) {
    if (!this.table || this._state === 'error' || this._state === 'disposed') return [];
    const pos = this._position;
    this._replan(pos);
    const applied = new Set(this._sequence.slice(0, pos)), out = [];
    for (let k = pos; k < Math.min(this._sequence.length, pos + max); k++) {
      const index = this._sequence[k];
      out.push({ index, chunk: this.table.chunks[index], applied: new Set(applied),
        before: k > 0 ? this._sequenceDistortion[k - 1] : this.table.base.distortion, after: this._sequenceDistortion[k] });
      applied.add(index);
    }
    return out;
  }

  // nextChunks(1)'s one entry, or null when none is left.
  nextChunk() { return this.nextChunks(1)[0] || null; }

  // Fetches and applies chunks in the chosen order until the last one or the budget. Resolves
  // with the stats; while playing, returns the same promise.
  play() {
    if (!this.table) return Promise.reject(this._fail('play() before open()'));
    if (this._state === 'error' || this._state === 'disposed') return Promise.reject(this._fail(`cannot play: the stream is in state ${this._state}`));
    // A block index still on its way comes first (the refinements are read against it).
    const run = async () => {
      try {
        await this._indexed;
      } catch (error) {
        this._state = 'error';
        this._emit('error', { error });
        throw error;
      }
      return this._viewCaps ? this._runView() : this._run();
    };
    if (!this._playing) this._playing = run().finally(() => { this._playing = null; });
    return this._playing;
  }

  async _run() {
    const abort = this._abort = new AbortController(), signal = abort.signal;
    // Ranges asked for and not yet taken: with a worker, their bytes stay there (HeldBytes) and
    // are let go once their chunks are applied, or here when the run ends without them.
    const reads = new Set();
    const read = (batch) => {
      const promise = batch && this._reader.read(batch.start, batch.end, signal, true);
      if (promise) {
        promise.catch(() => {});  // awaited later, or dropped by the abort below
        reads.add(promise);
      }
      return promise;
    };
    const stopped = () => new DOMException('stopped', 'AbortError');
    this._state = 'streaming';
    try {
      let batch = this._planBatch(this._position, this._bytes), fetching = read(batch);
      while (batch) {
        const data = await fetching;
        reads.delete(fetching);
        const next = this._planBatch(this._position + batch.indices.length, batch.bytes);
        const nextFetch = read(next);  // prefetch while this batch is applied
        try {
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
            if (chunk.kind === 'texture' && !this.options.uploadsBeside) await this._gpuIdle();
          }
        } finally {
          if (data.release) data.release();
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
      return this._playFailed(error, signal);
    } finally {
      if (this._abort === abort) this._abort = null;
      for (const r of reads) r.then((d) => { if (d && d.release) d.release(); }, () => {});
    }
  }

  // A play that threw: 'stopped' when `signal` was aborted (stop()), else 'error' and the error
  // thrown on; once disposed, the stats.
  _playFailed(error, signal) {
    if (this._state === 'disposed') return this.stats;
    if (error && error.name === 'AbortError' && signal.aborted) {
      this._state = 'stopped';
      this._emit('stopped');
      return this.stats;
    }
    this._state = 'error';
    this._emit('error', { error });
    throw error;
  }

  // Plays by view (view_stream.js) until stop() or an error; resolves with the stats.
  async _runView() {
    const abort = this._abort = new AbortController(), signal = abort.signal;
    this._state = 'streaming';
    try {
      if (!this._view) this._view = new ViewPlayer(this);
      await this._view.run(signal);
      if (this._state === 'disposed') return this.stats;
      this._state = 'stopped';
      this._emit('stopped');
      return this.stats;
    } catch (error) {
      return this._playFailed(error, signal);
    } finally {
      if (this._abort === abort) this._abort = null;
    }
  }

  // Played by view: block `block` of mesh `i` (its part's bytes: `payload`, or HeldBytes of the
  // worker's) applied where the stream decodes.
  async _viewApply(i, block, payload) {
    const mesh = this.meshes[i], t0 = performance.now();
    try {
      if (this._worker) {
        await this._setup;
        const { added, seconds } = await this._worker.applyBlock(mesh, i, block, payload);
        this._trianglesApplied += added;
        this._applySeconds += seconds;
        return;
      }
      const c = mesh.view.apply(block, payload.slice());
      mesh.applyChanges(c);
      this._trianglesApplied += c.nf - c.f0;
      this._applySeconds += (performance.now() - t0) / 1000;
    } catch (e) {
      throw this._fail(`mesh ${i} block ${block}: ${e.message}`);
    }
  }

  // Played by view: mesh `i` decoded again holding only the blocks `keep` (the detail dropped).
  async _viewRebuild(i, keep) {
    const mesh = this.meshes[i], t0 = performance.now();
    try {
      if (this._worker) {
        await this._setup;
        this._applySeconds += (await this._worker.rebuildBlocks(mesh, i, keep)).seconds;
        return;
      }
      mesh.replaceAll(mesh.view.rebuild(keep));
      this._applySeconds += (performance.now() - t0) / 1000;
    } catch (e) {
      throw this._fail(`mesh ${i}: dropping blocks: ${e.message}`);
    }
  }

  // Played by view: the parts of mesh chunk `index` for meshes that are not block meshes
  // ([{part, offset}]; `data` holds the file's bytes from `start` on), applied in order.
  async _viewChainParts(index, parts, start, data) {
    for (const { part, offset } of parts) {
      const payload = data.subarray(offset - start, offset - start + part.bytes);
      await this._applyChunk(index, { kind: 'mesh', parts: [part] }, payload);
    }
  }

  // Resolves once the GPU has done what was submitted so far (after a texture level: its
  // upload and mipmaps, costly on software rasterizers), so that decoding the next chunk does
  // not compete with it for the CPU. Needs the renderer; gives up after 2 s.
  async _gpuIdle() {
    await gpuIdle(this.options.renderer && this.options.renderer.getContext());
  }

  // The completion (stream/format.h "Completion"): each listed mesh's full detail, a Draco
  // bitstream decoded by three's DRACOLoader (its own workers), swapped in for the buffers the
  // splits grew; the meshes change together, in one task.
  async _applyCompletion(index, chunk, payload) {
    const t0 = performance.now();
    let loader, bytes;
    try {
      loader = await this._dracoLoader();
      bytes = this._worker ? await this._worker.pageBytes(payload) : payload;
    } catch (e) {
      throw this._fail(`chunk ${index}: the completion cannot be read (${e.message})`);
    }
    let decoded;
    try {
      decoded = await Promise.all(chunk.meshes.map((e) => new Promise((resolve, reject) => {
        const part = bytes.slice(e.offset - chunk.offset, e.offset - chunk.offset + e.bytes);
        loader.parse(part.buffer, resolve, reject);
      })));
    } catch (e) {
      if (!this.options.dracoLoader) loader.dispose();
      throw this._fail(`chunk ${index}: the completion cannot be decoded (${e && e.message ? e.message : e})`);
    }
    try {
      if (this._state === 'disposed') return;
      for (const [k, e] of chunk.meshes.entries()) {
        const g = decoded[k], points = g.getAttribute('position'), faces = g.getIndex();
        if (!points || points.count !== e.vertices || !faces || faces.count !== 3 * e.faces) {
          throw new Error(`mesh ${e.mesh}: the completion decodes to ${points ? points.count : 0} points and ${faces ? faces.count / 3 : 0} faces, the table says ${e.vertices} and ${e.faces}`);
        }
        await checkCompletionFaces(e.mesh, faces, points.count);
      }
      if (this._state === 'disposed') return;
      chunk.meshes.forEach((e, k) => {
        const mesh = this.meshes[e.mesh], before = mesh.solid;
        mesh.complete(decoded[k]);
        this._trianglesApplied += Math.max(0, mesh.solid - before);
      });
    } catch (e) {
      throw this._fail(`chunk ${index}: ${e.message}`);
    } finally {
      for (const g of decoded) g.dispose();
      if (!this.options.dracoLoader) loader.dispose();  // its workers were this chunk's alone
      this._applySeconds += (performance.now() - t0) / 1000;
    }
  }

  async _applyChunk(index, chunk, payload) {
    if (chunk.kind === 'complete') { await this._applyCompletion(index, chunk, payload); return; }
    if (chunk.kind === 'mesh') {
      if (this._worker) {  // decoded in the worker; its own time is the decoding time
        await this._setup;
        try {
          const { added, seconds } = await this._worker.applyChunk(this.meshes, chunk, payload);
          this._trianglesApplied += added;
          this._applySeconds += seconds;
        } catch (e) {
          throw this._fail(`chunk ${index}: ${e.message}`);
        }
        return;
      }
      const t0 = performance.now();
      try {
        this._trianglesApplied += await applyMeshChunk(this.meshes, chunk, payload);
      } catch (e) {
        throw this._fail(`chunk ${index}: ${e.message}`);
      } finally {
        this._applySeconds += (performance.now() - t0) / 1000;
      }
      return;
    }
    if (this.table.view.physical) { await this._applyMaps(index, chunk, payload); return; }
    // A texture level: its maps' complete JPEG/PNG files; the base colour map is decoded off
    // the main thread, bytes as stored. Further channels need physically based shading.
    const map = chunk.maps[0];
    for (const other of chunk.maps.slice(1)) {
      if (!this._unshownChannels.has(other.channel)) {
        this._unshownChannels.add(other.channel);
        this.notes.push(`texture maps of channel ${other.channel} are streamed but not shown yet`);
      }
    }
    let bitmap;
    try {
      const bytes = payload.subarray(map.offset - chunk.offset, map.offset - chunk.offset + map.size);
      bitmap = await this._decodeImage(bytes, map.mime);
    } catch (e) {
      throw this._fail(`chunk ${index}: the ${map.mime} texture level cannot be decoded (${e.message})`);
    }
    if (this._state === 'disposed') { bitmap.close(); return; }
    if (bitmap.width !== chunk.width || bitmap.height !== chunk.height) {
      this.notes.push(`chunk ${index}: the texture is ${bitmap.width}×${bitmap.height}, the table says ${chunk.width}×${chunk.height}`);
    }
    let kept;
    try {
      kept = await this._decodeKept(index, chunk, payload);
    } catch (e) {
      bitmap.close();
      throw e;
    }
    if (this._state === 'disposed') { bitmap.close(); for (const [, b] of kept) b.close(); return; }
    const texture = configureTexture(textureOf(bitmap), this._anisotropy(), this._wrap);
    texture.name = `meshmux level ${bitmap.width}x${bitmap.height}`;
    this._ownTextures.add(texture);
    const keptSwaps = this._keptSwaps(kept);
    await this._show(async () => {  // the level's maps change together
      for (const t of [texture, ...keptSwaps.textures]) if (!(await this._upload(t))) return;
      this._releaseTexture(this._map.value);
      this._map.value = texture;
      this._textureSize = [bitmap.width, bitmap.height];
      this._swapKept(keptSwaps);
      this._levelGpuBytes = this.chunkGpuBytes(index);
    });
  }

  // Physical shading: every map of the level decoded off the main thread (bytes as stored; the
  // texture's colour space says how three.js reads them), then swapped in on every material.
  async _applyMaps(index, chunk, payload) {
    const decoded = [];
    let kept = [];
    try {
      for (const map of chunk.maps) {
        const bytes = payload.subarray(map.offset - chunk.offset, map.offset - chunk.offset + map.size);
        let bitmap;
        try {
          bitmap = await this._decodeImage(bytes, map.mime);
        } catch (e) {
          throw this._fail(`chunk ${index}: the ${map.channel} ${map.mime} map cannot be decoded (${e.message})`);
        }
        decoded.push([map.channel, bitmap]);
        if (bitmap.width !== chunk.width || bitmap.height !== chunk.height)
          this.notes.push(`chunk ${index}: the ${map.channel} map is ${bitmap.width}×${bitmap.height}, the table says ${chunk.width}×${chunk.height}`);
      }
      kept = await this._decodeKept(index, chunk, payload);
    } catch (e) {
      for (const [, b] of decoded) b.close();
      throw e;
    }
    if (this._state === 'disposed') { for (const [, b] of [...decoded, ...kept]) b.close(); return; }
    // Every map on the GPU before any is shown: the level's maps change together.
    const textures = [];
    for (const [channel, bitmap] of decoded) {
      if (!CHANNEL_SLOTS[channel]) { bitmap.close(); continue; }
      const texture = configureMap(textureOf(bitmap), channel, this._anisotropy(), this._wrap);
      texture.name = `meshmux ${channel} ${bitmap.width}x${bitmap.height}`;
      this._ownTextures.add(texture);
      textures.push([channel, texture]);
    }
    const keptSwaps = this._keptSwaps(kept);
    await this._show(async () => {
      for (const texture of [...textures.map(([, t]) => t), ...keptSwaps.textures]) if (!(await this._upload(texture))) return;
      for (const [channel, texture] of textures) {
        const bitmap = texture.image, old = this._maps[channel];
        this._maps[channel] = texture;
        for (const m of this._streamedMaterials) {
          let changed = false;
          for (const slot of CHANNEL_SLOTS[channel]) { changed ||= !m[slot]; m[slot] = texture; }
          if (changed) m.needsUpdate = true;  // a map it did not have: another shader
        }
        this._releaseTexture(old);
        if (channel === 'base_color') this._textureSize = [bitmap.width, bitmap.height];
      }
      this._swapKept(keptSwaps);
      this._levelGpuBytes = this.chunkGpuBytes(index);
    });
  }

  // A texture chunk's kept images decoded off the main thread ([[image, bitmap]], table order);
  // on failure none is left open.
  async _decodeKept(index, chunk, payload) {
    const out = [];
    try {
      for (const map of chunk.kept || []) {
        const bytes = payload.subarray(map.offset - chunk.offset, map.offset - chunk.offset + map.size);
        let bitmap;
        try {
          bitmap = await this._decodeImage(bytes, map.mime);
        } catch (e) {
          throw this._fail(`chunk ${index}: kept image ${map.image} (${map.mime}) cannot be decoded (${e.message})`);
        }
        out.push([map.image, bitmap]);
        if (bitmap.width !== map.width || bitmap.height !== map.height)
          this.notes.push(`chunk ${index}: kept image ${map.image} is ${bitmap.width}×${bitmap.height}, the table says ${map.width}×${map.height}`);
      }
    } catch (e) {
      for (const [, b] of out) b.close();
      throw e;
    }
    return out;
  }

  // A decoded texture level's upload and swap (`job`): awaited, or with uploadsBeside queued
  // behind the level before it and left running (`uploading`). A level that fails to go up
  // beside the stream is left out with a note (three.js keeps showing the one before).
  _show(job) {
    if (!this.options.uploadsBeside) return job();
    const run = (this._uploads || Promise.resolve()).then(job).catch((e) => {
      this.notes.push(`a texture level could not be uploaded (${e && e.message})`);
    });
    this._uploads = run;
    run.then(() => { if (this._uploads === run) this._uploads = null; });
    return undefined;
  }

  // One map's JPEG or PNG bytes as an ImageBitmap, bytes as stored (no colour conversion, no
  // premultiplied alpha): decoded in the worker when there is one (its main-thread share in
  // chromium is tens of milliseconds per 2048² map), then as a PixelImage where its bytes can be
  // read exactly there (uploadInBands sends a band's rows at the band's cost), else on the page.
  _decodeImage(bytes, mime) {
    if (mime === 'image/ktx2') return this._transcode(bytes);
    if (this._worker) return this._worker.decodeImage(bytes, mime, IMAGE_OPTIONS, true);
    return createImageBitmap(new Blob([bytes], { type: mime }), IMAGE_OPTIONS);
  }

  // One KTX2 map transcoded by three's KTX2Loader in its workers (the bytes held by the stream's
  // worker copied to the page once, then handed over), as a Ktx2Image: its CompressedTexture,
  // sides and close().
  async _transcode(bytes) {
    const loader = await this.ktx2Loader();
    const page = this._worker ? await this._worker.pageBytes(bytes) : bytes;
    const whole = page.byteOffset === 0 && page.byteLength === page.buffer.byteLength;
    const buffer = whole ? page.buffer : page.slice().buffer;
    const texture = await new Promise((resolve, reject) => loader.parse(buffer, resolve, reject));
    return new Ktx2Image(texture);
  }

  // A texture level of ours to the GPU in bands (uploadInBands); false, with the level's
  // textures released, when the stream was disposed meanwhile.
  async _upload(texture) {
    const alive = () => this._state !== 'disposed';
    if (await uploadInBands(this.options.renderer, texture, this.options.uploadBandBytes, alive) && alive()) return true;
    for (const t of [...this._ownTextures]) {
      if (t !== this._map.value && !Object.values(this._maps).includes(t)) this._releaseTexture(t);
    }
    return false;
  }

  _releaseTexture(texture) {
    if (!texture) return;
    texture.dispose();
    this._gpuBytes = null;
    // An ImageBitmap of ours (a compressed texture's image is only its sides).
    if (this._ownTextures.delete(texture) && typeof texture.image.close === 'function') texture.image.close();
  }

  // Aborts fetching; play() then resolves with state 'stopped'.
  stop() {
    if (this._abort) this._abort.abort();
  }

  // Per package mesh, the digest of the state its decoder holds (stream/vsplit.h state_digest;
  // report.json's "stream_digests" once the stream is complete). For tests and tools.
  async stateDigests() {
    await this._indexed;
    if (this._worker) {
      await this._setup;
      return this._worker.digests();
    }
    return this.meshes.map((m) => (m.view || m.state).digest());
  }

  dispose() {
    this.stop();
    if (this._worker) this._worker.terminate();
    this._worker = null;
    this._state = 'disposed';
    if (this.object.parent) this.object.parent.remove(this.object);
    for (const m of this.meshes) m.dispose();
    for (const g of new Set(this._whole.map((o) => o.geometry))) g.dispose();
    this._whole = [];
    for (const m of this.materials) m.dispose();
    this._releaseTexture(this._map.value);
    this._map.value = null;
    for (const t of Object.values(this._maps)) this._releaseTexture(t);
    this._maps = {};
    for (const e of this._kept.values()) {
      for (const t of e.textures) t.dispose();
      if (e.own) e.own.close();
    }
    this._kept.clear();
    this.meshes = [];
    this.materials = [];
    this._streamedMaterials = [];
    this._gpuBytes = null;
  }
}
