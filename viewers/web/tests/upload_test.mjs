// A texture level uploaded in bands (meshmux.js uploadInBands) is the same texture as three.js
// uploading it whole, in every mip level (the longest task while the bands go is printed). The
// image is 256×512 with every texel distinct (a band off by a row, a flipped band or a missing
// last band shows), the bands 37 rows (the last one partial); level 0 is also checked against
// the source pixels; bands that grow (from 5 rows: copies are quick on a 256-pixel-wide image)
// give the same texture in fewer copies; two textures uploading at once (their bands
// interleaved, one room on the context) both come out whole; an opaque map the decoding worker
// gives as its bytes (a PixelImage) is the source exactly and bands to the same texture; one
// with alpha comes as bytes equal to its ImageBitmap's upload where there is ImageDecoder. Then a stopped upload (alive()
// false) resolves false after its first band, and a texture that fits in one band is left to
// three.js (no band copied).
//
// usage: node upload_test.mjs --meshmux BIN --work DIR [--chromium PATH]
// Exit: 0 pass, 1 fail, 77 skipped (no chromium: said on stderr).
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { launch, opt, serve, skip } from './harness.mjs';

const meshmux = opt('--meshmux');
const work = opt('--work');
const chromiumPath = opt('--chromium', '/usr/bin/chromium');
if (!meshmux || !work) {
  console.error('usage: node upload_test.mjs --meshmux BIN --work DIR');
  process.exit(2);
}
if (!fs.existsSync(chromiumPath)) skip(`${chromiumPath} not installed (apt-get install chromium)`);

fs.rmSync(work, { recursive: true, force: true });
fs.mkdirSync(work, { recursive: true });
// The viewer's files as `meshmux convert` lays them out (the library, three.js beside it).
const sample = path.join(work, 'sample.glb'), site = path.join(work, 'site');
for (const argv of [['sample', '-o', sample, '-q'], ['convert', sample, '-o', site, '-q']]) {
  const r = spawnSync(meshmux, argv, { encoding: 'utf8' });
  if (r.status !== 0) { console.error(`meshmux ${argv.join(' ')}: ${r.stderr}`); process.exit(1); }
}
const three = fs.readdirSync(path.join(site, 'viewer')).find((f) => f.startsWith('three-'));
fs.writeFileSync(path.join(site, 'upload.html'), `<!doctype html><html><head><meta charset="utf-8">
<script type="importmap">{"imports": {"three": "./viewer/${three}/three.module.js", "three/addons/": "./viewer/${three}/addons/"}}</script>
</head><body><script type="module">
import * as THREE from 'three';
import { uploadInBands } from './viewer/meshmux.js';
import { PixelImage, StreamWorker, textureOf } from './viewer/stream_mesh.js';
const W = 256, H = 512, ROWS = 37;
const renderer = new THREE.WebGLRenderer();
const gl = renderer.getContext();
const source = new Uint8ClampedArray(W * H * 4);
for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) {
  const i = 4 * (y * W + x);
  source.set([x, y & 255, ((y >> 8) << 6) | ((7 * x) & 63), 255], i);
}
const bitmap = await createImageBitmap(new ImageData(source, W, H), { premultiplyAlpha: 'none', colorSpaceConversion: 'none' });
const make = () => {
  const t = new THREE.Texture(bitmap);
  t.colorSpace = THREE.NoColorSpace;
  t.flipY = false;
  t.minFilter = THREE.LinearMipmapLinearFilter;
  t.generateMipmaps = true;
  t.needsUpdate = true;
  return t;
};
// Level \`level\` of texture t as the GPU holds it.
const read = (t, level) => {
  const fb = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, renderer.properties.get(t).__webglTexture, level);
  const w = W >> level, h = H >> level, px = new Uint8Array(w * h * 4);
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  gl.deleteFramebuffer(fb);
  return px;
};
const differing = (a, b) => { let n = 0; for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) n++; return n; };
let copies = 0;
const copy = renderer.copyTextureToTexture.bind(renderer);
renderer.copyTextureToTexture = (...a) => { copies++; return copy(...a); };
const whole = make();
renderer.initTexture(whole);
gl.finish();
// Tasks while the bands go: a 2 ms timer's lateness.
let longest = 0, tick = performance.now(), probing = true;
(function probe() { const t = performance.now(); longest = Math.max(longest, t - tick - 2); tick = t; if (probing) setTimeout(probe, 2); })();
const banded = make();
const done = await uploadInBands(renderer, banded, ROWS * W * 4, () => true, 1);
probing = false;
const result = { done, copies, longest, mipmapsAutoUpdate: banded.mipmapsAutoUpdate, levels: [] };
result.sourceDiffers = differing(read(banded, 0), new Uint8Array(source.buffer));
for (const level of [0, 1, 3, 6]) result.levels.push({ level, differs: differing(read(banded, level), read(whole, level)) });
// Bands that grow where copies are quick: the same texture.
copies = 0;
const grown = make();
result.grownDone = await uploadInBands(renderer, grown, 5 * W * 4, () => true, 64);
result.grownCopies = copies;
result.grownDiffers = [0, 1, 3].map((level) => differing(read(grown, level), read(whole, level))).reduce((a, b) => a + b, 0);
// Two textures at once (a world's packages): their bands share the context's room, interleaved.
copies = 0;
const pair = [make(), make()];
result.pairDone = await Promise.all(pair.map((t) => uploadInBands(renderer, t, ROWS * W * 4, () => true, 1)));
result.pairCopies = copies;
result.pairDiffers = pair.map((t) => [0, 1, 3].map((level) => differing(read(t, level), read(whole, level))).reduce((a, b) => a + b, 0));
// Stopped after its first band.
copies = 0;
const stopped = make();
let calls = 0;
result.stopped = await uploadInBands(renderer, stopped, ROWS * W * 4, () => ++calls < 2, 1);
result.stoppedCopies = copies;
// An opaque map as the decoding worker gives it (stream_worker.js: a PNG of the source decoded
// there, its bytes read back): the source's bytes exactly, as a PixelImage; its DataTexture
// (textureOf) uploaded in bands is the same texture as the bitmap's whole upload. A map with
// alpha comes back an ImageBitmap (a 2D canvas's premultiplied texels are not exact there).
const png = async (pixels) => {
  const canvas = new OffscreenCanvas(W, H);
  canvas.getContext('2d').putImageData(new ImageData(pixels, W, H), 0, 0);
  return new Uint8Array(await (await canvas.convertToBlob({ type: 'image/png' })).arrayBuffer());
};
const worker = await StreamWorker.start();
const decoded = await worker.decodeImage(await png(source), 'image/png', { premultiplyAlpha: 'none', colorSpaceConversion: 'none' }, true);
result.workerPixels = decoded instanceof PixelImage;
result.workerDiffers = result.workerPixels ? differing(decoded.data, new Uint8Array(source.buffer)) : -1;
const fromPixels = textureOf(decoded);
Object.assign(fromPixels, { colorSpace: THREE.NoColorSpace, flipY: false, minFilter: THREE.LinearMipmapLinearFilter, generateMipmaps: true, needsUpdate: true });
copies = 0;
result.pixelsDone = await uploadInBands(renderer, fromPixels, ROWS * W * 4, () => true, 1);
result.pixelsCopies = copies;
result.pixelsDiffers = [0, 1, 3, 6].map((level) => differing(read(fromPixels, level), read(whole, level))).reduce((a, b) => a + b, 0);
// With alpha (every texel's its own, 1..255): where the page has WebCodecs' ImageDecoder (a secure
// context, as this loopback page is), the bytes as stored, the same as the GPU holds from the
// ImageBitmap of the same file uploaded whole by three.js.
const translucent = source.slice();
for (let i = 3; i < translucent.length; i += 4) translucent[i] = 1 + ((i >> 2) % 255);
const alphaPng = await png(translucent), options = { premultiplyAlpha: 'none', colorSpaceConversion: 'none' };
const withAlpha = await worker.decodeImage(alphaPng, 'image/png', options, true);
const alphaWhole = make();
alphaWhole.image = await createImageBitmap(new Blob([alphaPng], { type: 'image/png' }), options);
renderer.initTexture(alphaWhole);
result.decoderHere = typeof ImageDecoder === 'function';
result.alphaPixels = withAlpha instanceof PixelImage;
result.alphaDiffers = result.alphaPixels ? differing(withAlpha.data, read(alphaWhole, 0)) : -1;
worker.terminate();
// One band would hold it all: three.js uploads it when first drawn.
copies = 0;
result.small = await uploadInBands(renderer, make(), W * H * 4);
result.smallCopies = copies;
window.__upload = result;
console.log('upload-test: done');
</script></body></html>`);

const { server, url } = await serve(meshmux, site);
const { context, close } = await launch(work, chromiumPath, { width: 320, height: 240 });
let failed = false;
const fail = (m) => { console.error(`FAIL: ${m}`); failed = true; };
try {
  const page = context.pages()[0] || (await context.newPage());
  page.on('pageerror', (e) => fail(`page error: ${e.message}`));
  const done = new Promise((resolve) => page.on('console', (m) => { if (m.text() === 'upload-test: done') resolve(); }));
  await page.goto(`${url}upload.html`);
  await Promise.race([done, new Promise((_, reject) => setTimeout(() => reject(new Error('timed out')), 120000))]);
  const r = await page.evaluate(() => window.__upload);
  console.log(`banded: ${r.copies} bands, longest task ${r.longest.toFixed(1)} ms; texels differing from three.js's whole upload by level: ${r.levels.map((l) => `${l.level}: ${l.differs}`).join(', ')}; level 0 from the source: ${r.sourceDiffers}`);
  console.log(`growing from 5 rows: ${r.grownCopies} bands, ${r.grownDiffers} bytes differ in levels 0, 1, 3`);
  console.log(`two at once: ${r.pairCopies} bands, bytes differing in levels 0, 1, 3: ${r.pairDiffers.join(', ')}`);
  if (r.pairDone.join() !== 'true,true' || r.pairDiffers.some((n) => n) || r.pairCopies !== 2 * Math.ceil(512 / 37))
    fail(`two textures uploading at once: ${r.pairDone}, ${r.pairCopies} bands, ${r.pairDiffers} bytes differ`);
  console.log(`stopped: ${r.stopped} after ${r.stoppedCopies} band(s); one band's worth: ${r.small}, ${r.smallCopies} bands`);
  if (r.done !== true) fail('the banded upload did not resolve true');
  if (r.copies !== Math.ceil(512 / 37)) fail(`${r.copies} bands, expected ${Math.ceil(512 / 37)}`);
  for (const l of r.levels) if (l.differs) fail(`mip level ${l.level}: ${l.differs} bytes differ from the whole upload`);
  if (r.sourceDiffers) fail(`level 0: ${r.sourceDiffers} bytes differ from the source image`);
  if (r.mipmapsAutoUpdate !== true) fail('the texture\'s mipmapsAutoUpdate was not restored');
  if (r.grownDone !== true || r.grownDiffers) fail(`growing bands: ${r.grownDone}, ${r.grownDiffers} bytes differ from the whole upload`);
  if (!(r.grownCopies >= 2 && r.grownCopies < Math.ceil(512 / 5))) fail(`growing bands: ${r.grownCopies} copies (expected fewer than ${Math.ceil(512 / 5)}, more than 1)`);
  if (r.stopped !== false || r.stoppedCopies !== 1) fail(`a stopped upload resolved ${r.stopped} after ${r.stoppedCopies} bands (expected false after 1)`);
  console.log(`worker-decoded opaque PNG: ${r.workerPixels ? 'bytes' : 'an ImageBitmap'}, ${r.workerDiffers} bytes differ from the source; banded from its bytes: ${r.pixelsCopies} bands, ${r.pixelsDiffers} bytes differ in levels 0, 1, 3, 6; with alpha: ${r.alphaPixels ? `bytes, ${r.alphaDiffers} differ from the GPU's copy of its ImageBitmap` : 'an ImageBitmap'} (ImageDecoder ${r.decoderHere ? '' : 'not '}here)`);
  if (!r.workerPixels || r.workerDiffers !== 0) fail(`the worker's opaque map: ${r.workerPixels ? `${r.workerDiffers} bytes differ from the source` : 'not given as bytes'}`);
  if (r.pixelsDone !== true || r.pixelsCopies !== Math.ceil(512 / 37) || r.pixelsDiffers) fail(`banded from bytes: ${r.pixelsDone}, ${r.pixelsCopies} bands, ${r.pixelsDiffers} bytes differ from the whole upload`);
  if (r.decoderHere && (!r.alphaPixels || r.alphaDiffers !== 0)) fail(`a map with alpha: ${r.alphaPixels ? `${r.alphaDiffers} bytes differ from its ImageBitmap's` : 'not given as bytes'}`);
  if (!r.decoderHere && r.alphaPixels) fail('a map with alpha came back as bytes without ImageDecoder (a 2D canvas premultiplies it)');
  if (r.small !== true || r.smallCopies !== 0) fail(`a texture within one band: ${r.small}, ${r.smallCopies} bands (expected true, 0)`);
} finally {
  await close();
  server.kill();
}
process.exit(failed ? 1 : 0);
