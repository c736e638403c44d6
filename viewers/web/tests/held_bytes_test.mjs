// The page's side of bytes a stream's worker holds (stream_mesh.js HeldBytes, StreamWorker), on
// a stand-in worker (no browser): a fetched range the worker kept comes back as HeldBytes; its
// parts are named in the chunk and image requests (offset and size within the range, nothing
// transferred, no copy), parts of parts add up, and release() tells the worker to drop it. Bytes
// the page has are copied into the request as before (the caller's view may share a larger
// buffer), or handed over whole when the caller gives them up.
import assert from 'node:assert/strict';
import { HeldBytes, StreamWorker } from '../stream_mesh.js';

// A DecoderWorker stand-in: records what is posted and answers each request as `answer` says.
function standIn(answer) {
  const posted = [];
  const decoder = {
    nextStream: 1, streams: 0, failure: null, pending: new Map(),
    worker: { postMessage: (m, transfer = []) => posted.push({ m, transfer }) },
    request(message, transfer = []) {
      posted.push({ m: message, transfer });
      return { id: posted.length, promise: Promise.resolve(answer(message, posted.length)) };
    },
  };
  return { decoder, posted };
}

// A range fetched with hold: the reply names the held range (no bytes), the page gets HeldBytes.
{
  const { decoder, posted } = standIn((m, id) => ({ status: 206, statusText: '', contentRange: `bytes ${m.start}-${m.end - 1}/5000`, held: id, length: m.end - m.start }));
  const stream = new StreamWorker(decoder, true);
  const r = await stream.fetchRange('http://x/p.mmxp', 1000, 3000, undefined, true);
  assert.equal(posted[0].m.hold, true);
  assert.ok(r.bytes instanceof HeldBytes);
  assert.equal(r.bytes.length, 2000);
  assert.equal(r.bytes.id, 1);
  // Parts of parts: offsets add up; ends clamp like TypedArray.subarray.
  const chunk = r.bytes.subarray(500, 1500), map = chunk.subarray(100, 5000);
  assert.deepEqual([chunk.offset, chunk.length, map.offset, map.length], [500, 1000, 600, 900]);
  assert.equal(r.bytes.subarray(1900, 1800).length, 0);
  r.bytes.release();
  assert.deepEqual(posted.at(-1).m, { type: 'drop', held: 1 });
}

// A chunk and an image named in held bytes: the request carries held, offset, size, and no
// payload or bytes, nothing transferred.
{
  const { decoder, posted } = standIn((m) => (m.type === 'chunk' ? { changes: [], seconds: 0 } : { pixels: new Uint8Array(4), width: 1, height: 1 }));
  const stream = new StreamWorker(decoder, true);
  const held = new HeldBytes(stream, 7, 0, 4096);
  const meshes = [{ vertices: 10, faces: 4, applyChanges() {} }];
  const chunk = { parts: [{ mesh: 0, vertex_begin: 10, vertex_end: 14, face_begin: 4, face_end: 9, bytes: 300 }] };
  await stream.applyChunk(meshes, chunk, held.subarray(1000, 1300));
  assert.equal(posted[0].m.type, 'chunk');
  assert.deepEqual([posted[0].m.held, posted[0].m.offset, posted[0].m.size], [7, 1000, 300]);
  assert.equal(posted[0].m.payload, undefined);
  assert.equal(posted[0].transfer.length, 0);
  const image = await stream.decodeImage(held.subarray(2000, 2500), 'image/png', {}, true);
  assert.deepEqual([posted[1].m.held, posted[1].m.offset, posted[1].m.size, posted[1].m.bytes], [7, 2000, 500, undefined]);
  assert.equal(image.width, 1);
  // The parts' sizes still guard the chunk: a payload shorter than its parts is refused here.
  await assert.rejects(stream.applyChunk(meshes, chunk, held.subarray(1000, 1200)), /parts hold 300 bytes, the chunk 200/);
}

// Bytes on the page: a view of a larger buffer is copied (the buffer stays whole for its other
// users); bytes given up (own) go over whole, transferred.
{
  const { decoder, posted } = standIn(() => ({ pixels: new Uint8Array(4), width: 1, height: 1 }));
  const stream = new StreamWorker(decoder, true);
  const buffer = new Uint8Array(100).map((_, i) => i);
  await stream.decodeImage(buffer.subarray(10, 20), 'image/jpeg', {}, true);
  assert.deepEqual([...posted[0].m.bytes], [10, 11, 12, 13, 14, 15, 16, 17, 18, 19]);
  assert.notEqual(posted[0].m.bytes.buffer, buffer.buffer);
  assert.equal(buffer.length, 100);
  const own = new Uint8Array([1, 2, 3]);
  await stream.decodeImage(own, 'image/png', {}, true, true);
  assert.equal(posted[1].m.bytes, own);
  assert.deepEqual(posted[1].transfer, [own.buffer]);
  // Given up but only a view: still copied.
  await stream.decodeImage(buffer.subarray(0, 5), 'image/png', {}, true, true);
  assert.notEqual(posted[2].m.bytes.buffer, buffer.buffer);
}
console.log('held bytes: ranges held, parts named, released; page bytes copied or handed over whole');
