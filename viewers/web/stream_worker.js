// stream_worker.js — meshmux streams' mesh decoding in a Web Worker (started by StreamWorker
// or a WorkerPool in stream_mesh.js), so that the page's main thread only copies in what each
// chunk changed. It holds, per stream it serves (the `stream` number every request carries; a
// pool's worker serves several), a MeshState per package mesh (stream_decode.js) and answers
// (setup, chunk, digests and release in the order asked; fetch and image once their work is
// done, so they may overtake):
//   setup  {meshes: [{vertices, faces, origin, step, base: {qp, qn, qt, count, quantized,
//          faces: [Uint32Array]} | null}]} → {}: the meshes with their bases
//   chunk  {parts: [[mesh, splits, faces, bytes]], payload} → {changes, seconds}: the chunk's
//          parts applied in order; per mesh touched {mesh, v0, vn, f0, nf, solid, position,
//          normal, uv (the new vertices' float attributes), appended (the new faces' indices),
//          moved ([corner, vertex] pairs: corners of earlier faces the splits moved)}
//   digests {} → {digests}: per mesh, stream/vsplit.h state_digest of what it holds (none
//          before setup: a package whose base is whole streams no mesh)
//   release {} → {}: the stream's states dropped (its MeshmuxStream was disposed)
//   fetch  {url, start, end} → {status, statusText, contentRange, bytes}: a byte range fetched
//          here (package_reader.js fetchRange), so its body never passes through the page's
//          main thread (in chromium, a megabyte there stalls it for tens of milliseconds);
//          abort {request} aborts such a fetch (it then answers with an error)
//   image  {bytes, mime, options} → {bitmap}: a texture map's file decoded (createImageBitmap),
//          the ImageBitmap transferred
// Every reply carries the request's id; an Error becomes {type: 'error', id, message}. After
// an error the states are not used again (the page fails the stream).
import { fetchRange } from './package_reader.js';
import { MeshState } from './stream_decode.js';

const streams = new Map();  // stream number → its meshes: [{state, origin, step, quantized}]
const fetches = new Map();  // request id → the AbortController of its fetch

function setup(m) {
  streams.set(m.stream, m.meshes.map((d, i) => {
    const state = new MeshState(d, i);
    if (d.base) {
      state.setBase(d.base.qp, d.base.qn, d.base.qt, d.base.count);
      for (const f of d.base.faces) state.appendFaces(f);
    }
    return { state, origin: d.origin, step: d.step, quantized: d.base ? d.base.quantized : true };
  }));
  return {};
}

function meshesOf(m) {
  const meshes = streams.get(m.stream);
  if (!meshes) throw new Error(`stream ${m.stream} was not set up`);
  return meshes;
}

function chunk(m) {
  const meshes = meshesOf(m);
  const t0 = performance.now();
  const touched = new Map();  // mesh → where it stood before this chunk
  let at = 0;
  for (const [mesh, splits, faces, bytes] of m.parts) {
    const entry = meshes[mesh];
    if (!entry) throw new Error(`mesh chunk: part of mesh ${mesh}, the package has ${meshes.length}`);
    if (!touched.has(mesh)) {
      entry.state.beginChanges();
      touched.set(mesh, [entry.state.vertices, entry.state.faces]);
    }
    entry.state.applySplits(m.payload, at, at + bytes, splits, faces);
    at += bytes;
  }
  const seconds = (performance.now() - t0) / 1000;
  const changes = [], transfer = [];
  for (const [mesh, [v0, f0]] of touched) {
    const { state, origin, step, quantized } = meshes[mesh];
    const vn = state.vertices, nf = state.faces, n = vn - v0;
    const position = new Float32Array(3 * n), normal = new Float32Array(3 * n), uv = new Float32Array(2 * n);
    state.dequantize(v0, vn, position, normal, uv, 0, quantized, origin, step);
    const appended = state.indices.slice(3 * f0, 3 * nf);
    const moved = new Uint32Array(2 * state.movedCount);
    for (let i = 0; i < state.movedCount; i++) {
      const c = state.movedCorners[i];
      moved[2 * i] = c;
      moved[2 * i + 1] = state.indices[c];
    }
    changes.push({ mesh, v0, vn, f0, nf, solid: state.solid, position, normal, uv, appended, moved });
    transfer.push(position.buffer, normal.buffer, uv.buffer, appended.buffer, moved.buffer);
  }
  return { reply: { changes, seconds }, transfer };
}

self.onmessage = (e) => {
  const m = e.data;
  try {
    if (m.type === 'setup') self.postMessage({ type: 'setup', id: m.id, ...setup(m) });
    else if (m.type === 'chunk') {
      const { reply, transfer } = chunk(m);
      self.postMessage({ type: 'chunk', id: m.id, ...reply }, transfer);
    } else if (m.type === 'fetch') {
      const abort = new AbortController();
      fetches.set(m.id, abort);
      fetchRange(m.url, m.start, m.end, abort.signal).then(
        (r) => self.postMessage({ type: 'fetch', id: m.id, ...r }, [r.bytes.buffer]),
        (error) => self.postMessage({ type: 'error', id: m.id, message: error && error.message ? error.message : String(error) }))
        .finally(() => fetches.delete(m.id));
    } else if (m.type === 'abort') {
      if (fetches.has(m.request)) fetches.get(m.request).abort();
    } else if (m.type === 'image') {
      createImageBitmap(new Blob([m.bytes], { type: m.mime }), m.options).then(
        (bitmap) => self.postMessage({ type: 'image', id: m.id, bitmap }, [bitmap]),
        (error) => self.postMessage({ type: 'error', id: m.id, message: error && error.message ? error.message : String(error) }));
    } else if (m.type === 'digests') {
      self.postMessage({ type: 'digests', id: m.id, digests: (streams.get(m.stream) || []).map((x) => x.state.digest()) });
    } else if (m.type === 'release') {
      streams.delete(m.stream);
      self.postMessage({ type: 'release', id: m.id });
    } else throw new Error(`unknown request ${JSON.stringify(m.type)}`);
  } catch (error) {
    self.postMessage({ type: 'error', id: m.id, message: error && error.message ? error.message : String(error) });
  }
};
self.postMessage({ type: 'ready' });
