// worker_client.js — the page's side of a meshmux stream's decoding worker (stream_worker.js):
// StreamWorker (one stream's requests: setup, mesh chunks, byte ranges, images), the Web
// Workers it talks through (a worker of its own, or a WorkerPool's shared one), the bytes a
// worker holds for the page (HeldBytes) and the maps it decodes as bytes (PixelImage), and the
// check of a mesh chunk's parts both decoders run (checkParts; applyMeshChunk decodes on the
// page). Used by meshmux.js and stream_mesh.js (which re-exports the classes); imports nothing.

// Checks that a mesh chunk's parts hold its payload's bytes and start where the meshes stand.
export function checkParts(meshes, chunk, payload) {
  let total = 0;
  for (const part of chunk.parts) total += part.bytes;
  if (total !== payload.length) throw new Error(`mesh chunk: its parts hold ${total} bytes, the chunk ${payload.length}`);
  const at = new Map();  // per mesh: where it stands after the parts before
  for (const part of chunk.parts) {
    const mesh = meshes[part.mesh];
    const [v, f] = at.get(part.mesh) || [mesh.vertices, mesh.faces];
    if (part.vertex_begin !== v || part.face_begin !== f) {
      throw new Error(`mesh ${part.mesh}: part starts at vertex ${part.vertex_begin}, face ${part.face_begin}, ` +
        `but ${v} vertices and ${f} faces are received`);
    }
    at.set(part.mesh, [part.vertex_end, part.face_end]);
  }
}

// A texture map decoded in the worker, as its RGBA bytes (rows top first) where an
// ImageBitmap would be: a THREE.DataTexture's image ({data, width, height}), uploaded a band of
// rows at a time at the band's own cost. close() lets the bytes go, as ImageBitmap's does.
export class PixelImage {
  constructor(data, width, height) {
    this.data = data;
    this.width = width;
    this.height = height;
  }

  close() {
    this.data = null;
  }
}

// Bytes a stream's worker holds (a range it fetched with `hold`: stream_worker.js): the page
// knows how many and names parts of them (subarray) in the worker's chunk and image requests,
// so that a range's body is neither copied on the page's thread nor sent back to the worker.
// release() lets the worker drop them (every part named before it is served first).
export class HeldBytes {
  constructor(stream, id, offset, length) {
    this.stream = stream;  // the StreamWorker whose worker holds them
    this.id = id;          // the fetch request's id, the worker's key
    this.offset = offset;  // where this part starts in the range held
    this.length = length;
  }

  // Bytes [begin, end) of these, clamped like TypedArray.subarray (no negative indices).
  subarray(begin = 0, end = this.length) {
    const b = Math.max(0, Math.min(this.length, begin)), e = Math.max(b, Math.min(this.length, end));
    return new HeldBytes(this.stream, this.id, this.offset + b, e - b);
  }

  release() { this.stream.dropHeld(this.id); }
}

// The page's side of stream_worker.js. A DecoderWorker is one Web Worker; each stream talks to
// it through its own StreamWorker (its stream number on every message), so that one worker can
// decode for many streams (WorkerPool). Messages are answered in order per worker; payloads
// and results move as transferred buffers.
class DecoderWorker {
  // Starts a worker; resolves with it once it runs, or null where workers cannot run (no
  // Worker, a file:// page, a blocked script).
  static async start(url) {
    if (typeof Worker === 'undefined') return null;
    let worker;
    try {
      worker = new Worker(url, { type: 'module', name: 'meshmux decoder' });
    } catch {
      return null;
    }
    const ready = await new Promise((resolve) => {
      const timer = setTimeout(() => resolve(false), 10000);
      worker.onmessage = (e) => { clearTimeout(timer); resolve(e.data && e.data.type === 'ready'); };
      worker.onerror = (e) => { e.preventDefault(); clearTimeout(timer); resolve(false); };
    });
    if (!ready) { worker.terminate(); return null; }
    return new DecoderWorker(worker);
  }

  constructor(worker) {
    this.worker = worker;
    this.pending = new Map();  // request id → { resolve, reject }
    this.nextId = 1;
    this.nextStream = 1;       // the number the next StreamWorker on it gets
    this.streams = 0;          // StreamWorkers on it now (a pool gives the next to the least used)
    this.failure = null;       // the worker died: every later request fails with this
    worker.onmessage = (e) => {
      const m = e.data, p = this.pending.get(m.id);
      if (!p) {
        if (m.held !== undefined) worker.postMessage({ type: 'drop', held: m.held });  // an aborted fetch's
        return;
      }
      this.pending.delete(m.id);
      if (m.type === 'error') p.reject(new Error(m.message)); else p.resolve(m);
    };
    worker.onerror = (e) => {
      e.preventDefault();
      this.failure = new Error(`the decoding worker failed (${e.message || 'no message'})`);
      for (const p of this.pending.values()) p.reject(this.failure);
      this.pending.clear();
    };
  }

  // Posts `message`; { id, promise of the reply }.
  request(message, transfer = []) {
    if (this.failure) return { id: 0, promise: Promise.reject(this.failure) };
    const id = this.nextId++;
    const promise = new Promise((resolve, reject) => {
      this.pending.set(id, { resolve, reject });
      this.worker.postMessage({ ...message, id }, transfer);
    });
    return { id, promise };
  }

  terminate() {
    this.worker.terminate();
    this.failure = new Error('the decoding worker was stopped');
    for (const p of this.pending.values()) p.reject(this.failure);
    this.pending.clear();
  }
}

// Web Workers shared by many streams (MeshmuxWorld: fifty packages need not start fifty
// workers): up to `size` workers, started as streams ask, each new stream on the least used.
export class WorkerPool {
  // size: workers at most (default: the cores but one, 1 to 4); url: stream_worker.js.
  constructor(size = defaultPoolSize(), url = new URL('./stream_worker.js', import.meta.url)) {
    this.size = Number.isFinite(size) && size >= 1 ? Math.floor(size) : 1;
    this.url = url;
    this._workers = [];  // Promises of DecoderWorker (null where workers cannot run)
  }

  // A StreamWorker for one stream, or null where workers cannot run.
  async acquire() {
    if (this._workers.length < this.size) this._workers.push(DecoderWorker.start(this.url));
    const started = (await Promise.all(this._workers)).filter((w) => w && !w.failure);
    if (!started.length) return null;
    const worker = started.reduce((a, b) => (b.streams < a.streams ? b : a));
    return new StreamWorker(worker, true);
  }

  // Stops every worker (their streams' later requests fail).
  terminate() {
    for (const w of this._workers) w.then((x) => { if (x) x.terminate(); });
    this._workers = [];
  }
}

function defaultPoolSize() {
  const cores = typeof navigator !== 'undefined' && navigator.hardwareConcurrency ? navigator.hardwareConcurrency : 2;
  return Math.max(1, Math.min(4, cores - 1));
}

// One stream's decoder: its meshes' states in a worker of its own (StreamWorker.start) or in a
// pool's shared worker (WorkerPool.acquire).
export class StreamWorker {
  // Starts a worker of its own; resolves with the stream's decoder once it runs, or null where
  // workers cannot run (no Worker, a file:// page, a blocked script) so that the caller decodes
  // on the page.
  static async start(url = new URL('./stream_worker.js', import.meta.url)) {
    const worker = await DecoderWorker.start(url);
    return worker ? new StreamWorker(worker, false) : null;
  }

  constructor(decoder, shared) {
    this.decoder = decoder;
    this.shared = shared;  // the worker serves other streams too: release, do not terminate
    this.stream = decoder.nextStream++;
    this.released = null;  // set once terminate() ran: every later request fails with this
    decoder.streams++;
  }

  _request(message, transfer = []) {
    if (this.released) return Promise.reject(this.released);
    return this.decoder.request({ ...message, stream: this.stream }, transfer).promise;
  }

  // Hands the worker the package's meshes (their table entries) with their bases, taken from
  // `meshes` (StreamMesh objects made with { local: false }, their bases set); the bases' copies
  // are released here. The worker's decoder checks every base face (an Error names the mesh).
  // `view` (optional): per mesh, null or {capacityVertices, capacityFaces} for a block mesh
  // played by view (view_stream.js viewCapacities): its state is then a block_view.js
  // BlockMeshState taking blocks (applyBlock, rebuildBlocks), not chunks.
  async setup(descs, meshes, view = null) {
    const bases = meshes.map((m) => m.base);
    const transfer = [];
    for (const b of bases) {
      if (!b) continue;
      transfer.push(b.qp.buffer, b.qn.buffer, b.qt.buffer, ...b.faces.map((f) => f.buffer));
    }
    meshes.forEach((m) => { m.base = null; });
    const reply = await this._request({ type: 'setup', meshes: descs.map((d, i) => ({
      vertices: d.vertices, faces: d.faces, origin: meshes[i].origin, step: meshes[i].step, base: bases[i],
      blocks: d.blocks && d.blocks.length ? d.blocks : null,
      view: view && view[i] ? { ...view[i], blocks: d.blocks } : null })) }, transfer);
    // The decoder checked the bases' faces and counted the solid ones.
    reply.solid.forEach((n, i) => { meshes[i].solid = n; });
    return {};
  }

  // Decodes one mesh chunk in the worker and takes its changes into `meshes`. Resolves with
  // { added, seconds }: the faces added and the worker's decoding time.
  // `payload`: the chunk's bytes, or HeldBytes of this worker's.
  async applyChunk(meshes, chunk, payload) {
    checkParts(meshes, chunk, payload);
    // A block part (stream/format.h "Blocks") carries its block.
    const parts = chunk.parts.map((p) => [p.mesh, p.vertex_end - p.vertex_begin, p.face_end - p.face_begin, p.bytes,
      p.block >= 0 ? p.block : -1]);
    const reply = await this._request(...this._bytesMessage({ type: 'chunk', parts }, 'payload', payload));
    let added = 0;
    for (const c of reply.changes) {
      meshes[c.mesh].applyChanges(c);
      added += c.nf - c.f0;
    }
    return { added, seconds: reply.seconds };
  }

  // Applies block `block` of mesh `index` (a block mesh played by view) in the worker and takes
  // its changes into `mesh` (its StreamMesh). `payload`: the block's part, or HeldBytes of this
  // worker's. Resolves with { added, seconds }.
  async applyBlock(mesh, index, block, payload) {
    const reply = await this._request(...this._bytesMessage({ type: 'block', mesh: index, block }, 'payload', payload));
    mesh.applyChanges(reply.change);
    return { added: reply.change.nf - reply.change.f0, seconds: reply.seconds };
  }

  // Decodes mesh `index` (a block mesh played by view) again in the worker holding only the
  // blocks `keep` (dependency-closed) and replaces `mesh`'s buffers with the result. Resolves
  // with { seconds }.
  async rebuildBlocks(mesh, index, keep) {
    const reply = await this._request({ type: 'rebuild', mesh: index, keep });
    mesh.replaceAll(reply.whole);
    return { seconds: reply.seconds };
  }

  // A request's message and transfer list carrying `bytes` as `field`: HeldBytes by name, else
  // a copy the worker takes (the caller's bytes may be a view of a larger buffer).
  _bytesMessage(message, field, bytes) {
    if (bytes instanceof HeldBytes && bytes.stream === this) return [{ ...message, held: bytes.id, offset: bytes.offset, size: bytes.length }, []];
    const copy = bytes instanceof HeldBytes ? null : bytes.slice();
    if (!copy) throw new Error('bytes held by another stream\'s worker');
    return [{ ...message, [field]: copy }, [copy.buffer]];
  }

  // Lets the worker drop the range fetched by request `id` (HeldBytes.release).
  dropHeld(id) {
    if (!this.released && !this.decoder.failure) this.decoder.worker.postMessage({ type: 'drop', held: id });
  }

  // Bytes [start, end) of `url` (relative to the page) fetched by the worker; resolves like
  // package_reader.js fetchRange. With `hold`, a range sent as asked (HTTP 206) stays in the
  // worker: `bytes` is then HeldBytes, to be released once used. An abort of `signal` rejects
  // at once with an AbortError and aborts the worker's fetch.
  fetchRange(url, start, end, signal, hold = false) {
    if (signal && signal.aborted) return Promise.reject(new DOMException('aborted', 'AbortError'));
    if (this.released) return Promise.reject(this.released);
    const d = this.decoder;
    const { id, promise } = d.request({ type: 'fetch', stream: this.stream, url: new URL(url, globalThis.location && location.href).href, start, end, hold });
    const reply = promise.then((r) => (r.held === undefined ? r : { ...r, bytes: new HeldBytes(this, r.held, 0, r.length) }));
    if (!signal) return reply;
    return new Promise((resolve, reject) => {
      const onAbort = () => {
        if (!d.pending.delete(id)) return;
        d.worker.postMessage({ type: 'abort', request: id });
        reject(new DOMException('aborted', 'AbortError'));
      };
      signal.addEventListener('abort', onAbort, { once: true });
      reply.then(resolve, reject).finally(() => signal.removeEventListener('abort', onAbort));
    });
  }

  // One image file's bytes decoded in the worker (createImageBitmap with `options`); resolves
  // with the ImageBitmap, or with `pixels` a PixelImage (its RGBA bytes as stored) wherever the
  // worker can read them exactly (stream_worker.js decodeImage: a PNG where there is WebCodecs'
  // ImageDecoder, any opaque map).
  // `bytes`: the file's bytes, or HeldBytes of this worker's; `own`: the caller gives up a
  // Uint8Array over a whole buffer (transferred, not copied).
  async decodeImage(bytes, mime, options, pixels = false, own = false) {
    const whole = own && bytes instanceof Uint8Array && bytes.byteOffset === 0 && bytes.byteLength === bytes.buffer.byteLength;
    const r = await this._request(...(whole ? [{ type: 'image', mime, options, pixels, bytes }, [bytes.buffer]]
      : this._bytesMessage({ type: 'image', mime, options, pixels }, 'bytes', bytes)));
    return r.bitmap || new PixelImage(r.pixels, r.width, r.height);
  }

  // `bytes` on the page: a copy of HeldBytes of this worker's (the page decodes them itself), or
  // the bytes as given.
  async pageBytes(bytes) {
    if (!(bytes instanceof HeldBytes)) return bytes;
    return (await this._request(...this._bytesMessage({ type: 'copy' }, 'bytes', bytes))).bytes;
  }

  // Per mesh, the digest of the state the worker holds (stream/vsplit.h state_digest).
  async digests() {
    return (await this._request({ type: 'digests' })).digests;
  }

  // The fetched ranges the worker holds for this stream: { count (now: none once its play
  // ended), ever (in all) }.
  async heldRanges() {
    const { count, ever } = await this._request({ type: 'held' });
    return { count, ever };
  }

  // Ends this stream's use of its worker: a worker of its own stops; a pool's worker drops the
  // stream's states and serves the others on.
  terminate() {
    if (this.released) return;
    this.released = new Error('the decoding worker was stopped');
    this.decoder.streams--;
    if (!this.shared) this.decoder.terminate();
    else if (!this.decoder.failure) this.decoder.request({ type: 'release', stream: this.stream }).promise.catch(() => {});
  }
}
