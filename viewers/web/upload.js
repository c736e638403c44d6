// upload.js — pacing a meshmux stream's work on the page's main thread (meshmux.js): task and
// frame boundaries (pause, nextTask, taskSlicer), waiting for the GPU (gpuIdle: a fence polled
// between tasks), and a texture level's upload in bands of rows that the GPU takes without
// holding the page (uploadInBands; nextTask and uploadInBands are re-exported by meshmux.js).

import * as THREE from 'three';

// Between two chunks: the next animation frame (the page shows every step), or a bare task
// where there are no frames (workers); 50 ms at most when frames stall (a hidden page).
export const pause = () => new Promise((resolve) => {
  if (typeof requestAnimationFrame !== 'function') { setTimeout(resolve, 0); return; }
  const timer = setTimeout(resolve, 50);
  requestAnimationFrame(() => { clearTimeout(timer); resolve(); });
});

// A bare task boundary (a message to itself: no timer clamping), so that the page's other
// tasks (its frames, input) run between two steps of a long job.
export const nextTask = () => new Promise((resolve) => {
  if (typeof MessageChannel !== 'function') { setTimeout(resolve, 0); return; }
  const channel = new MessageChannel();
  channel.port1.onmessage = () => { channel.port1.close(); resolve(); };
  channel.port2.postMessage(0);
});

// Resolves once the GPU has done what was submitted to `gl` so far (a fence polled between
// tasks: WebGL updates a fence's status only then, so the poll never blocks), or after
// `maxMs`. Without WebGL 2 fences: at once.
export async function gpuIdle(gl, maxMs = 2000) {
  const sync = gl && gl.fenceSync && gl.fenceSync(gl.SYNC_GPU_COMMANDS_COMPLETE, 0);
  if (!sync) return;
  gl.flush();
  await fenceDone(gl, sync, maxMs);
}

// Resolves once the fence `sync` has signalled (polled every 2 ms, between tasks) or after
// `maxMs`, and deletes it.
async function fenceDone(gl, sync, maxMs) {
  for (const t0 = performance.now(); gl.clientWaitSync(sync, 0, 0) === gl.TIMEOUT_EXPIRED && performance.now() - t0 < maxMs;)
    await new Promise((resolve) => setTimeout(resolve, 2));
  gl.deleteSync(sync);
}

// Texture bands sent to the GPU and not yet taken before the next waits (uploadInBands): as
// many as four of the largest bands a texture is sent in, counted in bytes over every texture
// uploading on the same context, since all of them go through one transfer buffer.
const BANDS_IN_FLIGHT = 4;
const bandsSent = new WeakMap();  // WebGL context → { fences: [{ sync, bytes }], bytes, waiting, polling }

// Lets waiting bands through in arrival order while they fit in the context's bands in flight
// (each its texture's `most` bytes), or once one waited `maxMs` (it then goes anyway: a fence
// that never signals does not stop the page), or when nothing is in flight; a band let through
// has its bytes counted at once. One timer per context polls the fences while bands wait.
function letBandsThrough(gl, queue) {
  while (queue.fences.length && gl.clientWaitSync(queue.fences[0].sync, 0, 0) !== gl.TIMEOUT_EXPIRED) {
    const taken = queue.fences.shift();
    gl.deleteSync(taken.sync);
    queue.bytes -= taken.bytes;
  }
  while (queue.waiting.length) {
    const w = queue.waiting[0];
    if (queue.bytes + w.bytes > w.most && queue.bytes > 0 && performance.now() - w.t0 < w.maxMs) break;
    queue.waiting.shift();
    queue.bytes += w.bytes;
    w.resolve();
  }
  if (queue.waiting.length && !queue.polling) {
    queue.polling = true;
    setTimeout(() => { queue.polling = false; letBandsThrough(gl, queue); }, 2);
  }
}

// Resolves once a band of `bytes` may be sent on `gl` (letBandsThrough); the returned handle
// fences it once sent (sent()), or gives its room back when it is not (cancel()).
async function roomForBand(gl, bytes, most, maxMs) {
  let queue = bandsSent.get(gl);
  if (!queue) bandsSent.set(gl, queue = { fences: [], bytes: 0, waiting: [], polling: false });
  await new Promise((resolve) => {
    queue.waiting.push({ bytes, most, maxMs, t0: performance.now(), resolve });
    letBandsThrough(gl, queue);
  });
  return {
    sent() {
      queue.fences.push({ sync: gl.fenceSync(gl.SYNC_GPU_COMMANDS_COMPLETE, 0), bytes });
      gl.flush();
    },
    cancel() {
      queue.bytes -= bytes;
      letBandsThrough(gl, queue);
    },
  };
}

// A page-time budget for a long job on the main thread: `await slice()` returns at once while
// the job has run less than `ms` since its last task boundary, else after one (nextTask), so
// that the job's steps share tasks up to about `ms` and no task holds many of them.
export function taskSlicer(ms = 8) {
  let start = performance.now();
  return async () => {
    if (performance.now() - start < ms) return;
    await nextTask();
    start = performance.now();
  };
}

// Uploads `texture` (an ImageBitmap's or a PixelImage's) to the GPU in bands of rows of at most
// `bandBytes` of pixels, one band per task, then its mipmaps. Handed to three.js whole, a 2048² level of four
// maps is 64 MB uploaded inside one frame of the application's, the longest task on the page
// (in chromium on software GL, 16 MB from an ImageBitmap take ~240 ms, 256 kB ~1 ms). The
// texture's storage is allocated first (texStorage2D through WebGLRenderer.initTexture, no
// pixels: TextureSource.dataReady), then each band is copied in (copyTextureToTexture of a
// region) in the next task, once the bands sent on this context that the GPU has not taken (a
// fence after each, counted over every texture uploading on the page) leave room for it: at
// most BANDS_IN_FLIGHT of this texture's largest bands' bytes. Bands sent while it is busy wait
// inside the call for room in the browser's transfer buffer, on the page's thread (two bands in
// one task took up to 200 ms there, bands sent whenever a copy was quick up to 149 ms), and a
// wait for the GPU after every band made a world's levels arrive at a frame's pace. The band
// grows (doubles after a copy and its flush of under 4 ms, up to `grow` times `bandBytes`) and
// shrinks back after one of over 8 ms.
// Resolves false, the texture unfinished, once `alive()` turns false. Without a renderer, for
// a texture that fits in one band, or one past the GPU's largest side (three.js scales it
// down), three.js uploads it whole when first drawn.
export async function uploadInBands(renderer, texture, bandBytes, alive = () => true, grow = 4) {
  if (texture.isCompressedTexture) return uploadCompressedInBands(renderer, texture, bandBytes, alive, grow);
  const image = texture.image, width = image.width, height = image.height;
  const least = Math.max(1, Math.floor(bandBytes / (4 * width))), most = Math.max(least, Math.floor(least * grow));
  let rows = least;
  if (!renderer || typeof renderer.copyTextureToTexture !== 'function' || rows >= height) return true;
  if (Math.max(width, height) > renderer.capabilities.maxTextureSize) return true;
  const mipmaps = texture.mipmapsAutoUpdate;
  texture.source.dataReady = false;
  texture.mipmapsAutoUpdate = false;
  renderer.initTexture(texture);
  texture.source.dataReady = true;
  // The same pixels as the copy's source (never uploaded itself). A PixelImage's bands cost their
  // own bytes; an ImageBitmap is converted whole by chromium for every band.
  const source = texture.isDataTexture ? new THREE.DataTexture(image.data, width, height) : new THREE.Texture(image);
  const region = new THREE.Box2(), at = new THREE.Vector2();
  const gl = renderer.getContext(), fenced = typeof gl.fenceSync === 'function';
  try {
    for (let y = 0; y < height;) {
      await nextTask();
      const band = Math.min(rows, height - y) * width * 4;
      const room = fenced ? await roomForBand(gl, band, BANDS_IN_FLIGHT * most * width * 4, 500) : null;
      if (!alive()) {
        if (room) room.cancel();
        return false;
      }
      texture.mipmapsAutoUpdate = mipmaps && y + rows >= height;  // generated once, after the last band
      region.min.set(0, y);
      region.max.set(width, Math.min(height, y + rows));
      const t0 = performance.now();
      try {
        renderer.copyTextureToTexture(source, texture, region, at.set(0, y));
      } finally {
        if (room) room.sent();  // its flush may be where the band's pixels go
      }
      const ms = performance.now() - t0;
      y += rows;
      rows = ms < 4 ? Math.min(most, 2 * rows) : ms > 8 ? Math.max(least, rows >> 1) : rows;
    }
  } finally {
    texture.mipmapsAutoUpdate = mipmaps;
  }
  return true;
}

// A compressed texture (KTX2, transcoded by KTX2Loader: BC7, BC1, ASTC, ETC; its mip levels
// inside) to the GPU in bands of block rows of at most `bandBytes` (growing to `grow` times that
// after quick ones, as uploadInBands), one band per task, largest level first, the small levels
// together: handed to three.js whole, a 2048² BC7 level with its mips (5.6 MB) took 54 ms of the
// page's thread in one task on software GL (whose driver decodes the blocks as they arrive). The
// storage is allocated first (texStorage2D through initTexture, no data: TextureSource.dataReady),
// then each band goes in by compressedTexSubImage2D in the texture's own format and colour space
// (three's copyTextureToTexture names the format without the colour space: an sRGB texture's
// storage refuses it). The texture unit's binding is put back after each band, so three.js's
// cached state stays true. Resolves false, the texture unfinished, once `alive()` turns false.
// Without a renderer, or a texture of one band, three.js uploads it whole when first drawn.
async function uploadCompressedInBands(renderer, texture, bandBytes, alive, grow) {
  const mipmaps = texture.mipmaps || [];
  const total = mipmaps.reduce((n, m) => n + (m.data ? m.data.byteLength : 0), 0);
  if (!renderer || !mipmaps.length || total <= bandBytes) return alive();
  // KTX2 transcoded to RGBA8 (a GPU reading no block format): three.js uploads it whole.
  if (texture.format === THREE.RGBAFormat) return alive();
  if (Math.max(mipmaps[0].width, mipmaps[0].height) > renderer.capabilities.maxTextureSize) return alive();
  texture.source.dataReady = false;
  renderer.initTexture(texture);
  texture.source.dataReady = true;
  const gl = renderer.getContext(), handle = renderer.properties.get(texture).__webglTexture;
  const format = new THREE.WebGLUtils(gl, renderer.extensions).convert(texture.format, texture.colorSpace);
  if (!handle || !format) return alive();
  const send = (level, y, width, height, data) => {
    const before = gl.getParameter(gl.TEXTURE_BINDING_2D);
    gl.bindTexture(gl.TEXTURE_2D, handle);
    gl.compressedTexSubImage2D(gl.TEXTURE_2D, level, 0, y, width, height, format, data);
    gl.bindTexture(gl.TEXTURE_2D, before);
  };
  // Each band waits for room among the bands the GPU has not taken (fences, as uploadInBands):
  // calls return at once, and bands sent faster than the GPU process decodes them (a software
  // driver turns BC7 into texels) filled the transfer buffer until a call waited inside a task.
  const fenced = typeof gl.fenceSync === 'function', most = bandBytes * grow;
  const sendBand = async (bytes, job) => {
    await nextTask();
    const room = fenced ? await roomForBand(gl, bytes, BANDS_IN_FLIGHT * most, 500) : null;
    if (!alive()) {
      if (room) room.cancel();
      return false;
    }
    try {
      job();
    } finally {
      if (room) room.sent();
    }
    return true;
  };
  let band = bandBytes;
  for (let level = 0; level < mipmaps.length; level++) {
    const { width, height, data } = mipmaps[level];
    const blockRows = Math.ceil(height / 4), rowBytes = data.byteLength / blockRows;
    if (data.byteLength <= band && level > 0) {  // this level and every smaller one: one task
      const rest = mipmaps.slice(level);
      return sendBand(rest.reduce((n, m) => n + m.data.byteLength, 0),
        () => rest.forEach((m, k) => send(level + k, 0, m.width, m.height, m.data)));
    }
    for (let row = 0; row < blockRows;) {
      const rows = Math.max(1, Math.min(blockRows - row, Math.floor(band / rowBytes)));
      let ms = 0;
      const sent = await sendBand(rows * rowBytes, () => {
        const t0 = performance.now();
        send(level, 4 * row, width, Math.min(height - 4 * row, 4 * rows), data.subarray(row * rowBytes, (row + rows) * rowBytes));
        ms = performance.now() - t0;
      });
      if (!sent) return false;
      row += rows;
      band = ms < 4 ? Math.min(most, 2 * band) : ms > 8 ? Math.max(bandBytes, band / 2) : band;
    }
  }
  return true;
}
