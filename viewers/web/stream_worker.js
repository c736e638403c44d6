// stream_worker.js — meshmux streams' mesh decoding in a Web Worker (started by StreamWorker
// or a WorkerPool in worker_client.js), so that the page's main thread only copies in what each
// chunk changed. It holds, per stream it serves (the `stream` number every request carries; a
// pool's worker serves several), a MeshDecoder per package mesh (stream_decoder.js: the C++
// decoder compiled to WebAssembly, loaded as the worker starts, while the page fetches the
// base) and answers (setup, chunk, digests and release in the order asked; fetch and image once
// their work is done, so they may overtake):
//   setup  {meshes: [{vertices, faces, origin, step, base: {qp, qn, qt, count, quantized,
//          faces: [Uint32Array]} | null, blocks: [...] | null}]} → {solid: [per mesh]}: the
//          meshes with their bases (the decoder checks every base face) and blocks (the table's,
//          with their ranges: a block mesh's parts are read against them)
//   chunk  {parts: [[mesh, splits, faces, bytes, block]], payload} → {changes, seconds}:
//          the chunk's parts applied in order (block ≥ 0: a block part, stream/format.h
//          "Blocks", its vertices placed at that block's stream numbers); per mesh touched {mesh, v0, vn, f0, nf, solid, position,
//          normal, uv (the new vertices' float attributes), appended (the new faces' indices),
//          moved ([corner, vertex] pairs: corners of earlier faces the splits moved)}
//   block  {mesh, block, payload} → {change, seconds}: a block mesh played by view (setup gave
//          it `view`: {capacityVertices, capacityFaces, blocks}; block_view.js BlockMeshState)
//          takes block `block`'s part, in any dependency-closed order; the change as a chunk's,
//          its vertices in the page's slots
//   rebuild {mesh, keep} → {whole, seconds}: that mesh decoded again holding only the blocks
//          `keep`; its whole buffers ({replace, vertices, faces, solid, position, normal, uv,
//          indices}, sized to the capacities)
//   digests {} → {digests}: per mesh, stream/vsplit.h state_digest of what it holds (none
//          before setup: a package whose base is whole streams no mesh)
//   release {} → {}: the stream's states dropped (its MeshmuxStream was disposed)
//   held   {} → {count, ever}: how many fetched ranges the worker holds for the stream now, and
//          has held for it in all
//   fetch  {url, start, end, hold} → {status, statusText, contentRange, bytes}: a byte range
//          fetched here (package_reader.js fetchRange), so its body never passes through the
//          page's main thread (in chromium, a megabyte there stalls it for tens of milliseconds);
//          with `hold`, a range the server sent as asked (206) stays here and the reply says
//          {held (this request's id), length} instead of `bytes`: the page then names parts of
//          it in `chunk` and `image` requests ({held, offset, size} for payload or bytes), so
//          they are not copied on the page nor sent back; drop {held} lets it go (no reply).
//          abort {request} aborts such a fetch (it then answers with an error) or drops what
//          it holds
//   image  {bytes, mime, options, pixels} → {bitmap} | {pixels, width, height}: a texture map's
//          file decoded (createImageBitmap with `options`, the ImageBitmap transferred); with
//          `pixels`, as its RGBA bytes where they can be had exactly (decodeImage below)
// Every reply carries the request's id; an Error becomes {type: 'error', id, message}. After
// an error the states are not used again (the page fails the stream).
import { fetchRange } from './package_reader.js';
import { BlockMeshState } from './block_view.js';
import { MeshDecoder, loadDecoder } from './stream_decoder.js';

const streams = new Map();  // stream number → its meshes: [{state, origin, step, quantized}]
const fetches = new Map();  // request id → the AbortController of its fetch
const held = new Map();     // fetch request id → {bytes, stream}: a range the page names parts of
const heldEver = new Map(); // stream number → how many ranges were ever held for it

// A request's bytes: its own `field`, or the part {offset, size} of a range held here.
function bytesOf(m, field) {
  if (m.held === undefined) return m[field];
  const range = held.get(m.held);
  if (!range) throw new Error(`bytes of fetch ${m.held} are no longer held`);
  if (!(Number.isInteger(m.offset) && Number.isInteger(m.size) && m.offset >= 0 && m.size >= 0 && m.offset + m.size <= range.bytes.length))
    throw new Error(`bytes ${m.offset}+${m.size} lie outside the ${range.bytes.length} held of fetch ${m.held}`);
  return range.bytes.subarray(m.offset, m.offset + m.size);
}

// The decoder module, loading from the start (its failure is reported by the first setup).
const decoderReady = loadDecoder();
decoderReady.catch(() => {});

function release(stream) {
  for (const entry of streams.get(stream) || []) (entry.view || entry.state).free();
  streams.delete(stream);
}

async function setup(m) {
  const decoder = await decoderReady;
  release(m.stream);
  const meshes = [];
  streams.set(m.stream, meshes);
  for (const [i, d] of m.meshes.entries()) {
    if (d.view && d.base) {  // a block mesh played by view: block_view.js
      const quantized = d.base.quantized;
      const view = new BlockMeshState(decoder, { vertices: d.vertices, faces: d.faces, blocks: d.view.blocks }, i, d.base,
        { quantized, origin: d.origin, step: d.step, capacityVertices: d.view.capacityVertices, capacityFaces: d.view.capacityFaces });
      meshes.push({ view, state: null, origin: d.origin, step: d.step, quantized });
      continue;
    }
    const state = new MeshDecoder(decoder, d, i);
    meshes.push({ state, origin: d.origin, step: d.step, quantized: d.base ? d.base.quantized : true });
    if (d.base) {
      state.setBase(d.base.qp, d.base.qn, d.base.qt, d.base.count);
      for (const f of d.base.faces) state.appendFaces(f);
    }
  }
  return { solid: meshes.map((e) => (e.view || e.state).solid) };
}

// A block mesh's view state (setup with `view`), by the request's mesh number.
function viewOf(m) {
  const entry = meshesOf(m)[m.mesh];
  if (!entry || !entry.view) throw new Error(`mesh ${m.mesh} is not a block mesh played by view`);
  return entry.view;
}

// `block`: one block's part applied (its bytes kept to decode again); its changes in slots.
function block(m, bytes) {
  const t0 = performance.now();
  const c = viewOf(m).apply(m.block, bytes.slice());
  const seconds = (performance.now() - t0) / 1000;
  return { reply: { change: { mesh: m.mesh, ...c }, seconds },
    transfer: [c.position.buffer, c.normal.buffer, c.uv.buffer, c.appended.buffer, c.moved.buffer] };
}

// `rebuild`: the mesh decoded again from the base and the blocks kept; its whole buffers.
function rebuild(m) {
  const t0 = performance.now();
  const w = viewOf(m).rebuild(m.keep);
  const seconds = (performance.now() - t0) / 1000;
  return { reply: { whole: { mesh: m.mesh, ...w }, seconds },
    transfer: [w.position.buffer, w.normal.buffer, w.uv.buffer, w.indices.buffer] };
}

function meshesOf(m) {
  const meshes = streams.get(m.stream);
  if (!meshes) throw new Error(`stream ${m.stream} was not set up`);
  return meshes;
}

function chunk(m, payload) {
  const meshes = meshesOf(m);
  const t0 = performance.now();
  const touched = new Map();  // mesh → where it stood before this chunk
  let at = 0;
  for (const [mesh, splits, faces, bytes, block = -1] of m.parts) {
    const entry = meshes[mesh];
    if (!entry) throw new Error(`mesh chunk: part of mesh ${mesh}, the package has ${meshes.length}`);
    if (entry.view) throw new Error(`mesh ${mesh} is played by view: it takes blocks, not chunks`);
    if (!touched.has(mesh)) {
      entry.state.beginChanges();
      touched.set(mesh, [entry.state.vertices, entry.state.faces]);
    }
    if (!(at + bytes <= payload.length)) throw new Error(`mesh ${mesh}: its part runs past the chunk's ${payload.length} bytes`);
    if (block >= 0) entry.state.applyBlockSplits(payload, at, at + bytes, block, splits, faces);
    else entry.state.applySplits(payload, at, at + bytes, splits, faces);
    at += bytes;
  }
  const seconds = (performance.now() - t0) / 1000;
  const changes = [], transfer = [];
  for (const [mesh, [v0, f0]] of touched) {
    const { state, origin, step, quantized } = meshes[mesh];
    const c = state.changes(v0, f0, quantized, origin, step);
    changes.push({ mesh, ...c });
    transfer.push(c.position.buffer, c.normal.buffer, c.uv.buffer, c.appended.buffer, c.moved.buffer);
  }
  return { reply: { changes, seconds }, transfer };
}

// A map's RGBA bytes, rows top first, as stored (no premultiplied alpha, no colour conversion):
// {pixels: Uint8Array, width, height}, or null where they cannot be had exactly (the caller then
// sends the ImageBitmap). The page uploads such bytes a band of rows at a time at the band's own
// cost; an ImageBitmap given to WebGL with a sub-rectangle is converted whole by chromium for
// every band (tens of ms for a 2048² map on the page's thread, each time).
// A PNG through ImageDecoder (WebCodecs: secure contexts; its RGBA/BGRA frames copy out exactly);
// else an opaque bitmap through a 2D OffscreenCanvas (which stores texels premultiplied: exact
// only where they are opaque). Not a JPEG through ImageDecoder: its YUV frames convert to RGB
// otherwise than the browser's image decoder does (up to 95 levels apart on sharp detail).
async function decodedPng(bytes) {
  if (typeof ImageDecoder !== 'function') return null;
  let decoder = null, image = null;
  try {
    decoder = new ImageDecoder({ data: bytes, type: 'image/png', premultiplyAlpha: 'none', colorSpaceConversion: 'none' });
    image = (await decoder.decode()).image;
    if (!/^(RGB|BGR)[AX]$/.test(image.format)) return null;
    const width = image.displayWidth, height = image.displayHeight, pixels = new Uint8Array(width * height * 4);
    await image.copyTo(pixels, { format: 'RGBA' });
    return { pixels, width, height };
  } catch {
    return null;  // the bitmap's decode says what is wrong, if anything is
  } finally {
    if (image) image.close();
    if (decoder) decoder.close();
  }
}

function opaquePixels(bitmap) {
  if (typeof OffscreenCanvas !== 'function') return null;
  const { width, height } = bitmap;
  const context = new OffscreenCanvas(width, height).getContext('2d', { willReadFrequently: true });
  if (!context) return null;
  context.drawImage(bitmap, 0, 0);
  const data = context.getImageData(0, 0, width, height).data;
  for (let i = 3; i < data.length; i += 4) if (data[i] !== 255) return null;
  return { pixels: new Uint8Array(data.buffer, data.byteOffset, data.byteLength), width, height };
}

// The `image` request: {bitmap} or, with m.pixels, {pixels, width, height} where exact; and the
// transfer list.
async function decodeImage(m) {
  const png = m.pixels && m.mime === 'image/png' ? await decodedPng(m.bytes) : null;
  if (png) return { reply: png, transfer: [png.pixels.buffer] };
  const bitmap = await createImageBitmap(new Blob([m.bytes], { type: m.mime }), m.options);
  const pixels = m.pixels ? opaquePixels(bitmap) : null;
  if (!pixels) return { reply: { bitmap }, transfer: [bitmap] };
  bitmap.close();
  return { reply: pixels, transfer: [pixels.pixels.buffer] };
}

// Setup, chunk, digests and release run in the order asked, one after the other (setup waits for
// the module); their bytes are taken as they arrive (a later drop does not reach them).
let ordered = Promise.resolve();
function inOrder(m, work) {
  ordered = ordered.then(work).then(
    ({ reply, transfer = [] }) => self.postMessage({ type: m.type, id: m.id, ...reply }, transfer),
    (error) => self.postMessage({ type: 'error', id: m.id, message: error && error.message ? error.message : String(error) }));
}

self.onmessage = (e) => {
  const m = e.data;
  try {
    if (m.type === 'setup') inOrder(m, async () => ({ reply: await setup(m) }));
    else if (m.type === 'chunk') {
      const payload = bytesOf(m, 'payload');
      inOrder(m, () => chunk(m, payload));
    } else if (m.type === 'block') {
      const bytes = bytesOf(m, 'payload');
      inOrder(m, () => block(m, bytes));
    } else if (m.type === 'rebuild') {
      inOrder(m, () => rebuild(m));
    } else if (m.type === 'fetch') {
      const abort = new AbortController();
      fetches.set(m.id, abort);
      fetchRange(m.url, m.start, m.end, abort.signal).then(
        (r) => {
          if (!m.hold || r.status !== 206) { self.postMessage({ type: 'fetch', id: m.id, ...r }, [r.bytes.buffer]); return; }
          held.set(m.id, { bytes: r.bytes, stream: m.stream });
          heldEver.set(m.stream, (heldEver.get(m.stream) || 0) + 1);
          self.postMessage({ type: 'fetch', id: m.id, status: r.status, statusText: r.statusText, contentRange: r.contentRange, held: m.id, length: r.bytes.length });
        },
        (error) => self.postMessage({ type: 'error', id: m.id, message: error && error.message ? error.message : String(error) }))
        .finally(() => fetches.delete(m.id));
    } else if (m.type === 'abort') {
      if (fetches.has(m.request)) fetches.get(m.request).abort();
      held.delete(m.request);  // its reply came too late for the page
    } else if (m.type === 'drop') {
      held.delete(m.held);
    } else if (m.type === 'image') {
      decodeImage({ ...m, bytes: bytesOf(m, 'bytes') }).then(
        ({ reply, transfer }) => self.postMessage({ type: 'image', id: m.id, ...reply }, transfer),
        (error) => self.postMessage({ type: 'error', id: m.id, message: error && error.message ? error.message : String(error) }));
    } else if (m.type === 'copy') {
      // A copy of bytes the worker holds, for a part the page decodes itself (the completion's
      // bitstreams go to three's Draco decoder).
      const bytes = bytesOf(m, 'bytes').slice();
      self.postMessage({ type: 'copy', id: m.id, bytes }, [bytes.buffer]);
    } else if (m.type === 'held') {
      let count = 0;
      for (const range of held.values()) count += range.stream === m.stream;
      self.postMessage({ type: 'held', id: m.id, count, ever: heldEver.get(m.stream) || 0 });
    } else if (m.type === 'digests') {
      inOrder(m, () => ({ reply: { digests: (streams.get(m.stream) || []).map((x) => (x.view || x.state).digest()) } }));
    } else if (m.type === 'release') {
      heldEver.delete(m.stream);
      for (const [id, range] of held) if (range.stream === m.stream) held.delete(id);
      inOrder(m, () => { release(m.stream); return { reply: {} }; });
    } else throw new Error(`unknown request ${JSON.stringify(m.type)}`);
  } catch (error) {
    self.postMessage({ type: 'error', id: m.id, message: error && error.message ? error.message : String(error) });
  }
};
self.postMessage({ type: 'ready' });
