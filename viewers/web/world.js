// world.js — MeshmuxWorld: many meshmux packages streamed as one scene under one budget.
//
//   const world = new MeshmuxWorld('world.json', { renderer, camera });
//   scene.add(world.object);               // each base shows as it arrives,
//   await world.open();                    // most screen per byte first
//   world.addEventListener('chunk', render);
//   await world.play();                    // refinements, each where it buys the most on screen
//
// One MeshmuxStream per package (placed as often as world.json says: the placements share its
// geometry and materials, so a refinement shows everywhere at once), every range request through
// one RequestLimiter (at most `maxRequests` in flight). After the bases, requests go to the
// chunks of best gain per byte over all packages (each request carries a package's next chunks
// while they follow in the file and beat the best offer left waiting): each package offers
// the next chunk of its own order as re-planned for its first placement's view (MeshmuxStream's
// camera re-planning), scored by its distortion drop on the package's per-view surface for the
// direction each placement is seen from, times the share of the screen that placement covers
// (world_plan.js chunkGain, screenShare). Re-planned before every grant from the current camera:
// what is off screen gains nothing and waits (play() keeps watching the camera), what is tiny
// gains little. A budget of what is drawn (triangles over all placements, texels over all
// packages, chunks on their way counted) stops refinement where the next chunk would pass it;
// it does not bound the streams' own buffers (each holds its full mesh's capacity). A package
// that fails (missing, corrupt) is reported by name ('error' event, stats.failed) and the rest
// play on. The packages share one pool of decoding workers and one Draco decoder; their bases
// are built two at a time, in arrival order. A big mesh's block package (stream/format.h
// "Blocks") is played by view by its own stream (MeshmuxStream triangleBudget, view_stream.js:
// blocks chosen by the error they remove on screen per byte, dropped again when they left the
// view) from the world's camera over all its placements, its requests through the same limiter;
// such packages share half the world's triangle budget (divided over their placements), the
// other packages what is left.
//
// Events (CustomEvent; detail = a copy of `stats`, plus what is said): 'base' (+ package: a
// package's base is in the scene), 'chunk' (+ package, chunk, kind), 'progress', 'waiting' (only
// off-screen work is left), 'complete', 'stopped', 'error' (+ package, error).

import * as THREE from 'three';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';

import { DRACO_DECODER_PATH, MeshmuxStream, nextTask, PROBE_BYTES } from './meshmux.js';
import { RequestLimiter } from './package_reader.js';
import { WorkerPool } from './worker_client.js';
import { chunkCost, chunkGain, packageDirection, screenShare, validateWorld, viewWeights, WORLD_LIMITS } from './world_plan.js';

export { validateWorld, screenShare, chunkGain };

// Default memory budgets by device class: phones and tablets, then desktops.
export function defaultBudget() {
  const mobile = typeof navigator !== 'undefined' && /Mobi|Android|iPhone|iPad/i.test(navigator.userAgent || '');
  // gpuBytes: what the textures shown hold on the GPU (MeshmuxStream stats.gpuBytes: RGBA8 with
  // mipmaps for JPEG/PNG levels, the block format for KTX2 ones, a quarter of that or less), so
  // KTX2 packages fit four times the texels of JPEG ones.
  return mobile ? { triangles: 4e6, texels: 64 * 2 ** 20, gpuBytes: 256 * 2 ** 20 }
    : { triangles: 20e6, texels: 256 * 2 ** 20, gpuBytes: 1024 * 2 ** 20 };
}

export class MeshmuxWorld extends EventTarget {
  // options: renderer (THREE.WebGLRenderer), camera (the THREE.Camera the world is seen through:
  // required for play()), maxRequests (range requests in flight over all packages, default 6),
  // concurrent (packages with a grant at once, default 6: each grant is one range request, so
  // fewer would leave the link idle between requests), budget ({triangles, texels, gpuBytes}; default by
  // device class, defaultBudget()), allowExternalUrls (package URLs outside the world's folder:
  // trusted worlds only), worker (decode in Web Workers, as MeshmuxStream; default true: a
  // pool of `workers` workers shared by the packages, default the cores but one, 1 to 4),
  // pollMs (how often play() looks at the camera while only off-screen work is left, default
  // 200), dracoDecoderPath (three's draco/gltf/ decoder files, for Draco-coded bases: one
  // DRACOLoader serves every package; default beside this module, as batch lays them out),
  // meshoptWorkers (the bases' meshopt-coded buffers are decoded in this many workers of three's
  // MeshoptDecoder instead of on the page, default 1; 0 leaves the decoder as the page set it:
  // it is one module shared with the page, so this sets its worker count for the page too).
  constructor(world, options = {}) {
    super();
    this.source = world;  // a URL of world.json, or its parsed JSON
    this.options = { renderer: null, camera: null, maxRequests: 6, concurrent: 6, budget: defaultBudget(),
      allowExternalUrls: false, worker: true, workers: undefined, pollMs: 200,
      dracoDecoderPath: DRACO_DECODER_PATH, meshoptWorkers: 1, ...options };
    this.object = new THREE.Group();
    this.object.name = 'meshmux world';
    const whole = (x, fallback) => (Number.isFinite(x) && x >= 1 ? Math.floor(x) : fallback);
    this.options.maxRequests = whole(this.options.maxRequests, 6);
    this.options.concurrent = whole(this.options.concurrent, 6);
    this.limiter = new RequestLimiter(this.options.maxRequests);
    // Bases are built (and their shaders compiled) two at a time, in the order they arrive: all
    // at once, each yielding to the others task by task, none would show until nearly all did.
    this.builds = new RequestLimiter(2);
    this.workers = this.options.worker ? new WorkerPool(this.options.workers) : null;
    if (this.options.meshoptWorkers >= 1 && typeof MeshoptDecoder.useWorkers === 'function')  // none without WebAssembly
      MeshoptDecoder.useWorkers(Math.min(4, Math.floor(this.options.meshoptWorkers)));
    this.packages = [];  // { name, url, bounds, bytes, placements: [{matrix, group}], stream, error }
    this._state = 'idle';
    this._stop = false;
    this._playing = null;
  }

  get state() { return this._state; }

  get stats() {
    let bytesReceived = 0, bytesTotal = 0, chunksApplied = 0, chunkCount = 0, triangles = 0, texels = 0, gpuBytes = 0;
    let vertices = 0, trianglesApplied = 0, applySeconds = 0, decoder = 'worker';
    const failed = [];
    for (const p of this.packages) {
      if (p.error) { failed.push({ name: p.name, error: p.error.message }); continue; }
      if (!p.stream || !p.stream.table) { bytesTotal += p.bytes; continue; }
      const s = p.stream.stats;
      bytesReceived += s.bytesReceived;
      bytesTotal += Number.isFinite(s.bytesTotal) ? s.bytesTotal : p.bytes;
      chunksApplied += s.chunksApplied;
      chunkCount += s.chunkCount;
      triangles += s.triangles * p.placements.length;
      texels += s.textureWidth * s.textureHeight + (s.keptTexels || 0);
      gpuBytes += s.gpuBytes || 0;
      vertices += s.vertices;
      trianglesApplied += s.trianglesApplied;
      applySeconds += s.applySeconds;
      if (s.decoder === 'page') decoder = 'page';
    }
    return { packages: this.packages.length, failed, bytesReceived, bytesTotal, chunksApplied, chunkCount,
      triangles, vertices, texels, gpuBytes, trianglesApplied, applySeconds, decoder, budget: { ...this.options.budget }, requestsPeak: this.limiter.peak, state: this._state };
  }

  _emit(type, extra) { this.dispatchEvent(new CustomEvent(type, { detail: { ...this.stats, ...extra } })); }

  async _readWorld() {
    if (typeof this.source !== 'string' && !(this.source instanceof URL)) return { json: this.source, base: location.href };
    const url = new URL(String(this.source), typeof location !== 'undefined' ? location.href : undefined).href;
    const res = await fetch(url);
    if (!res.ok) throw new Error(`meshmux: ${url}: HTTP ${res.status}`);
    const text = await res.text();
    if (text.length > WORLD_LIMITS.maxBytes) throw new Error(`meshmux: ${url}: larger than 16 MB`);
    let json;
    try { json = JSON.parse(text); } catch { throw new Error(`meshmux: ${url}: not valid JSON`); }
    return { json, base: url };
  }

  // Reads and validates the world, then opens every package (its table and base) through the
  // shared limiter, the most screen per byte first; each base joins the scene as it arrives. A
  // package that cannot open is reported ('error', stats.failed) and left out. Resolves with
  // this.object once every package opened or failed; rejects only for the world file itself.
  async open() {
    if (this._state !== 'idle') return this.object;
    this._state = 'opening';
    let json, base, world;
    try {
      ({ json, base } = await this._readWorld());
      const file = typeof this.source === 'string' ? this.source.split('/').pop() : 'world.json';
      world = validateWorld(json, file, { allowExternalUrls: this.options.allowExternalUrls });
    } catch (error) {
      this._state = 'idle';  // open() may be called again
      throw error;
    }
    this.packages = world.packages.map((p) => ({ ...p, url: new URL(p.url, base).href, placements: [], stream: null, error: null }));
    for (const pl of world.placements) this.packages[pl.package].placements.push({ matrix: pl.matrix, group: null });
    // Bases by screen share per byte of their first request (where world.json does not say
    // it, the probe's): the screen fills fastest when a small base that covers as much as a
    // large one comes first; among equal sizes, the largest on screen first.
    const rate = this.packages.map((p) => this._share(p) / (p.headBytes > 0 ? p.headBytes : PROBE_BYTES));
    const order = this.packages.map((_, i) => i).sort((a, b) => rate[b] - rate[a] || a - b);
    await Promise.all(order.map((i) => this._openPackage(this.packages[i])));
    this._shareBlocks();
    this._state = 'open';
    return this.object;
  }

  async _openPackage(p) {
    if (p.placements.length === 0) return;
    // The first request: the package's header, table and base exactly where world.json says
    // how long they are (a smaller package's base in one request of its own size).
    const probeBytes = p.headBytes > 0 ? p.headBytes : undefined;
    // A block package's buffers are sized for at most half the world's triangles (its share is
    // set once every package is open: _shareBlocks).
    const triangleBudget = Math.floor(this.options.budget.triangles / 2 / p.placements.length);
    p.stream = new MeshmuxStream(p.url, { renderer: this.options.renderer, camera: this.options.camera, probeBytes,
      dracoLoader: () => this._draco(), builds: this.builds, uploadsBeside: true,
      limiter: this.limiter, worker: this.options.worker, workers: this.workers, budgetBytes: 0, triangleBudget });
    p.stream.addEventListener('chunk', (e) => {
      this._emit('chunk', { package: p.name, chunk: e.detail.chunk, kind: e.detail.kind });
      this._emit('progress', { package: p.name });
    });
    try {
      const object = await p.stream.open();
      const groups = p.placements.map((pl, k) => {
        const group = new THREE.Group();
        group.name = `${p.name} ${k}`;
        group.matrixAutoUpdate = false;
        group.matrix.fromArray(pl.matrix);
        group.add(k === 0 ? object : object.clone());  // clones share geometry and materials
        return (pl.group = group);
      });
      await nextTask();  // each package's compile in a task of its own, after its base's build
      await this.builds.run(() => this._compile(object));
      await nextTask();
      if (p.error || this._state === 'disposed') return;  // failed or disposed meanwhile
      for (const group of groups) this.object.add(group);
      this.object.updateMatrixWorld(true);
      p.stream.viewRoots = groups;  // played by view: every placement seen
      this._emit('base', { package: p.name });
    } catch (error) {
      this._fail(p, error);
    }
  }

  // Compiles the shaders `object` needs before it joins the scene (WebGLRenderer.compileAsync,
  // with the scene the world is in for its lights): drawn as it arrives, a base's new
  // materials would compile inside the application's next frame, all bases that arrived since
  // the last frame at once. Where the driver compiles in parallel (KHR_parallel_shader_compile)
  // this waits without blocking; elsewhere the compile runs here, a task per program (a base's
  // materials at once were up to 80 ms of the page's thread). Without a renderer: nothing.
  async _compile(object) {
    const renderer = this.options.renderer, camera = this.options.camera;
    if (!renderer || !camera || typeof renderer.compileAsync !== 'function') return;
    let root = this.object;
    while (root.parent) root = root.parent;
    // A program depends on the material and on what draws it (instancing, skinning, morph
    // targets, vertex colours): the first object of each such kind.
    const kinds = new Map();
    object.traverse((o) => {
      if (!o.isMesh) return;
      const g = o.geometry, drawn = `${!!o.isInstancedMesh} ${!!o.isSkinnedMesh} ${Object.keys(g.attributes)} ${Object.keys(g.morphAttributes)}`;
      for (const m of [o.material].flat()) {
        const kind = `${m && m.uuid} ${drawn}`;
        if (m && !kinds.has(kind)) kinds.set(kind, o);
      }
    });
    for (const o of new Set(kinds.values())) {
      try {
        await renderer.compileAsync(o, camera, root.isScene ? root : null);
      } catch {
        // drawn anyway: the frame compiles what is missing
      }
      await nextTask();
    }
  }

  _fail(p, error) {
    p.error = error instanceof Error ? error : new Error(String(error));
    if (p.stream) p.stream.stop();
    for (const pl of p.placements) if (pl.group) this.object.remove(pl.group);
    this._emit('error', { package: p.name, error: p.error });
  }

  // One DRACOLoader for every package whose base is Draco-coded (each loader starts its own
  // workers and compiles the decoder in each), made when first asked for; a Promise.
  _draco() {
    if (!this._dracoPromise) {
      this._dracoPromise = import('three/addons/loaders/DRACOLoader.js')
        .then(({ DRACOLoader }) => (this._dracoInstance = new DRACOLoader().setDecoderPath(this.options.dracoDecoderPath).preload()));
      this._dracoPromise.catch(() => {});
    }
    return this._dracoPromise;
  }

  // The packages played by view (block packages) share half the triangle budget, each
  // placement alike.
  _shareBlocks() {
    const byView = this.packages.filter((p) => !p.error && p.stream && p.stream.byView);
    const placements = byView.reduce((n, p) => n + p.placements.length, 0);
    for (const p of byView) {
      p.stream.triangleBudget = Math.min(p.stream.triangleBudget, Math.floor(this.options.budget.triangles / 2 / placements));
    }
  }

  // The placements' screen shares and view weights of a package from the current camera.
  _views(p) {
    const camera = this.options.camera;
    if (!camera) return p.placements.map(() => ({ share: 1, weights: null }));
    camera.updateMatrixWorld();
    const vp = new THREE.Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse).elements;
    const root = this.object.matrixWorld.elements;
    const eye = camera.getWorldPosition(new THREE.Vector3()).toArray();
    const vt = p.stream && p.stream.table && p.stream.table.view_table;
    return p.placements.map((pl) => {
      const m = new THREE.Matrix4().fromArray(root).multiply(new THREE.Matrix4().fromArray(pl.matrix)).elements;
      const share = screenShare(p.bounds, m, vp);
      return { share, weights: vt && share > 0 ? viewWeights(vt, packageDirection(p.bounds, m, eye)) : null };
    });
  }

  _share(p) { return this._views(p).reduce((s, v) => s + v.share, 0); }

  // Every package's offer now: its next chunk with its gain per byte, where the budget allows
  // it, best first ([{ p, next, views, gain }]). `offscreen` is set when work is left that only
  // a camera turn would make worth anything.
  _offers(busy, used) {
    const offers = [];
    let offscreen = false;
    for (const p of this.packages) {
      if (p.error || !p.stream || !p.stream.table || busy.has(p) || p.stream.byView) continue;
      const next = p.stream.nextChunk();
      if (!next) continue;
      if (next.chunk.kind === 'texture' && p.stream.uploading) continue;  // one level in memory beside the GPU's
      const cost = this._cost(p, [next]);
      if (!this._fits(used, cost)) continue;
      const views = this._views(p);
      const gain = chunkGain(p.stream.table, next.applied, next.index, views, next, p.stream.textureAxis()) / Math.max(1, next.chunk.size);
      if (!(gain > 0)) { offscreen = true; continue; }
      offers.push({ p, next, views, gain });
    }
    offers.sort((a, b) => b.gain - a.gain);
    return { offers, offscreen };
  }

  // What granting `chunks` of package p adds to what is drawn: triangles over its placements
  // (each mesh as often as the base draws it), and the texels its largest texture level adds
  // over the one shown, with its kept images' over theirs; and the GPU bytes that level's maps
  // hold over the level shown's (MeshmuxStream chunkGpuBytes).
  _cost(p, chunks) {
    const s = p.stream.stats, shown = s.textureWidth * s.textureHeight;
    const instances = p.stream.meshes.map((m) => m.instances);
    let triangles = 0, texels = 0, gpuBytes = 0;
    const kept = new Map();  // kept image → the most texels a granted level gives it
    for (const c of chunks) {
      const k = chunkCost(p.stream.table, c.index, instances);
      triangles += k.triangles * p.placements.length;
      texels = Math.max(texels, k.texels - shown);
      gpuBytes = Math.max(gpuBytes, p.stream.chunkGpuBytes(c.index) - s.levelGpuBytes);
      for (const m of p.stream.table.chunks[c.index].kept || []) kept.set(m.image, Math.max(kept.get(m.image) || 0, m.width * m.height));
    }
    for (const [image, n] of kept) texels += Math.max(0, n - p.stream.keptTexels(image));
    return { triangles, texels, gpuBytes };
  }

  _fits(used, cost) {
    const b = this.options.budget;
    return used.triangles + cost.triangles <= b.triangles && used.texels + cost.texels <= b.texels &&
      (!(b.gpuBytes >= 0) || used.gpuBytes + cost.gpuBytes <= b.gpuBytes);
  }

  // The grant for an offer: its chunk, and after it the package's next ones while they follow
  // in the file (one range request), fit the package's batch size and the budget, and gain per
  // byte at least `floor` (the best offer left without a request this round), so that a
  // request carries what is worth its round trip and nothing another package needs more.
  _grant(offer, floor, used) {
    const { p, views } = offer, stream = p.stream;
    const chunks = [offer.next];
    let end = offer.next.chunk.offset + offer.next.chunk.size, bytes = offer.next.chunk.size;
    for (const c of stream.nextChunks(64).slice(1)) {
      if (c.chunk.offset !== end || bytes + c.chunk.size > stream.options.chunkBatchBytes) break;
      if (!this._fits(used, this._cost(p, [...chunks, c]))) break;
      const gain = chunkGain(stream.table, c.applied, c.index, views, c, stream.textureAxis()) / Math.max(1, c.chunk.size);
      if (!(gain > 0) || gain < floor) break;
      chunks.push(c);
      end += c.chunk.size;
      bytes += c.chunk.size;
    }
    return { chunks, bytes, cost: this._cost(p, chunks) };
  }

  // Streams refinements across the packages until every one is complete, the budget stops them,
  // or stop(); while only off-screen work is left it waits for the camera ('waiting'). Resolves
  // with the stats; while playing, returns the same promise.
  play() {
    if (this._state === 'idle' || this._state === 'opening') return Promise.reject(new Error('meshmux: play() before open()'));
    if (!this.options.camera) return Promise.reject(new Error('meshmux: play() needs options.camera (the world is planned from it)'));
    if (!this._playing) this._playing = this._run().finally(() => { this._playing = null; });
    return this._playing;
  }

  async _run() {
    this._stop = false;
    this._state = 'streaming';
    const busy = new Map();  // package → the promise of its granted chunk
    const inFlight = new Map();  // package → { triangles, texels } its granted chunk adds
    // package → { texels, done }: a texture level of a grant that ended, still going up to the
    // GPU beside the next grants (MeshmuxStream uploadsBeside): its texels count until shown.
    const uploads = new Map();
    let waiting = false;
    // Block packages play by view on their own until stop().
    for (const p of this.packages) {
      if (!p.error && p.stream && p.stream.byView && !p.stream.playing) {
        p.stream.budgetBytes = Infinity;  // no grants: its own choice, within its triangles
        p.stream.play().catch((error) => this._fail(p, error));
      }
    }
    // What is shown, plus what the chunks on their way will add (the budget counts both).
    const used = () => {
      const u = this.stats;
      for (const c of inFlight.values()) u.triangles += c.triangles, u.texels += c.texels, u.gpuBytes += c.gpuBytes;
      for (const c of uploads.values()) u.texels += c.texels, u.gpuBytes += c.gpuBytes;
      return u;
    };
    const ended = (p, cost) => {
      busy.delete(p);
      inFlight.delete(p);
      const pending = p.stream.uploading;
      if (!pending || cost.texels <= 0) return;
      const before = uploads.get(p);  // both over what is shown
      const texels = Math.max(cost.texels, before ? before.texels : 0), gpuBytes = Math.max(cost.gpuBytes, before ? before.gpuBytes : 0);
      const done = pending.then(() => { if (uploads.get(p) && uploads.get(p).done === done) uploads.delete(p); });
      uploads.set(p, { texels, gpuBytes, done });
    };
    for (;;) {
      if (this._stop) break;
      const free = this.options.concurrent - busy.size;
      const { offers, offscreen } = free > 0 ? this._offers(busy, used()) : { offers: [], offscreen: false };
      // The best offers get this round's requests, each extended against the best one left.
      const floor = offers.length > free ? offers[free].gain : 0;
      for (const offer of offers.slice(0, free)) {
        const u = used();
        if (!this._fits(u, this._cost(offer.p, [offer.next]))) continue;  // an earlier grant took the room
        const { p } = offer, { bytes, cost } = this._grant(offer, floor, u);
        inFlight.set(p, cost);
        p.stream.budgetBytes = p.stream.stats.bytesReceived + bytes;  // exactly the granted chunks
        busy.set(p, p.stream.play().catch((error) => this._fail(p, error)).finally(() => ended(p, cost)));
      }
      const uploading = this.packages.map((p) => p.stream && p.stream.uploading).filter(Boolean);
      if (busy.size > 0 || (!offers.length && uploading.length > 0)) {
        waiting = false;
        await Promise.race([...busy.values(), ...uploading]);  // a package whose level is up may go on
        continue;
      }
      if (offers.length) continue;
      if (!offscreen) break;  // nothing left that the budget allows
      if (!waiting) { waiting = true; this._state = 'waiting'; this._emit('waiting'); }
      await new Promise((resolve) => setTimeout(resolve, this.options.pollMs));
      this._state = 'streaming';
    }
    if (this._state === 'disposed') return this.stats;
    const left = this.packages.some((p) => !p.error && p.stream && !p.stream.byView && p.stream.nextChunk());
    this._state = this._stop || left ? 'stopped' : 'complete';
    this._emit(this._state);
    return this.stats;
  }

  stop() {
    this._stop = true;
    for (const p of this.packages) if (p.stream) p.stream.stop();
  }

  dispose() {
    this.stop();
    for (const p of this.packages) if (p.stream) p.stream.dispose();
    if (this.workers) this.workers.terminate();
    if (this._dracoInstance) this._dracoInstance.dispose();
    this._state = 'disposed';
  }
}
