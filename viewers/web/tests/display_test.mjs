// The order follows the canvas, in Debian's headless chromium through the viewer page: one
// package, ordered for the default display (1920×1080), on a textured sphere built here whose
// 2048² texture holds checkers at every octave, the one-texel one only in the top level. Played
// in a 1920×1080 window, the top level comes before the last mesh layer; in a 480×270 window the
// client re-reads the package's per-view table for its canvas (view_plan.js textureAxis) and the
// top level comes after every mesh layer. The same package, the same camera: only the canvas
// differs. Why 480×270 and not 640×360: the converter keeps the level a quarter of the top's side
// below it (the middle one does not pay for its bytes), and on a 640×360 canvas that 512² level
// under-resolves the sphere (256 texels across the visible half for 288 pixels), so the top level
// still shows there (the client reads it at 21 % of its display gain); at 480×270 (216 pixels) the
// 512² level is all the canvas can show.
//
// usage: node display_test.mjs --meshmux BIN --work DIR [--chromium PATH]
// Exit: 0 pass, 1 fail, 77 skipped (no chromium: said on stderr).
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { browserTestArgs, checks, launch, serve } from './harness.mjs';

const { meshmux, work, chromiumPath } = browserTestArgs('display_test.mjs');
const { check, failures } = checks();

// ---- The model --------------------------------------------------------------------------------

// A PNG of RGB rows (filter type 0 on each), with its chunks' CRC-32s.
const crcTable = Array.from({ length: 256 }, (_, n) => {
  let c = n;
  for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
  return c >>> 0;
});
function crc32(bytes) {
  let c = 0xffffffff;
  for (const b of bytes) c = crcTable[(c ^ b) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}
function chunk(type, data) {
  const out = Buffer.alloc(12 + data.length);
  out.writeUInt32BE(data.length, 0);
  out.write(type, 4, 'latin1');
  data.copy(out, 8);
  out.writeUInt32BE(crc32(out.subarray(4, 8 + data.length)), 8 + data.length);
  return out;
}
function png(width, height, pixel) {
  const raw = Buffer.alloc(height * (1 + 3 * width));
  for (let y = 0, o = 0; y < height; y++) {
    raw[o++] = 0;
    for (let x = 0; x < width; x++, o += 3) pixel(x, y, raw, o);
  }
  const header = Buffer.alloc(13);
  header.writeUInt32BE(width, 0);
  header.writeUInt32BE(height, 4);
  header[8] = 8;  // bit depth
  header[9] = 2;  // RGB
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]), chunk('IHDR', header),
    chunk('IDAT', zlib.deflateSync(raw)), chunk('IEND', Buffer.alloc(0))]);
}

// A UV sphere (rings × segments quads), positions, normals and uv, as a glTF with the texture.
function sphereGltf(rings, segments, imageUri) {
  const pos = [], nor = [], uv = [], idx = [];
  for (let r = 0; r <= rings; r++) {
    const theta = (Math.PI * r) / rings;
    for (let s = 0; s <= segments; s++) {
      const phi = (2 * Math.PI * s) / segments;
      const n = [Math.sin(theta) * Math.cos(phi), Math.cos(theta), Math.sin(theta) * Math.sin(phi)];
      pos.push(...n); nor.push(...n); uv.push(s / segments, r / rings);
    }
  }
  const row = segments + 1;
  for (let r = 0; r < rings; r++)
    for (let s = 0; s < segments; s++) {
      const a = r * row + s, b = a + row;
      if (r > 0) idx.push(a, a + 1, b);
      if (r < rings - 1) idx.push(a + 1, b + 1, b);
    }
  const f32 = (a) => Buffer.from(new Float32Array(a).buffer), u32 = Buffer.from(new Uint32Array(idx).buffer);
  const parts = [f32(pos), f32(nor), f32(uv), u32];
  let offset = 0;
  const views = parts.map((p) => { const v = { buffer: 0, byteOffset: offset, byteLength: p.length }; offset += p.length; return v; });
  const count = pos.length / 3;
  return {
    bin: Buffer.concat(parts),
    json: {
      asset: { version: '2.0' }, scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }],
      meshes: [{ primitives: [{ attributes: { POSITION: 0, NORMAL: 1, TEXCOORD_0: 2 }, indices: 3, material: 0 }] }],
      materials: [{ pbrMetallicRoughness: { baseColorTexture: { index: 0 }, metallicFactor: 0, roughnessFactor: 1 } }],
      textures: [{ source: 0 }], images: [{ uri: imageUri }],
      buffers: [{ uri: 'sphere.bin', byteLength: offset }], bufferViews: views,
      accessors: [
        { bufferView: 0, componentType: 5126, count, type: 'VEC3', min: [-1, -1, -1], max: [1, 1, 1] },
        { bufferView: 1, componentType: 5126, count, type: 'VEC3' },
        { bufferView: 2, componentType: 5126, count, type: 'VEC2' },
        { bufferView: 3, componentType: 5125, count: idx.length, type: 'SCALAR' },
      ],
    },
  };
}

fs.rmSync(work, { recursive: true, force: true });
fs.mkdirSync(work, { recursive: true });
const input = path.join(work, 'input');
fs.mkdirSync(input);
// Checkers at every octave from one texel to 128 (±12 each around grey, a different phase per
// channel): each level of the pyramid holds the octaves as fine as its texels, so every level pays
// for itself and none is dropped, and the top level alone holds the one-texel octave.
fs.writeFileSync(path.join(input, 'checker.png'), png(2048, 2048, (x, y, out, o) => {
  for (let ch = 0; ch < 3; ch++) {
    let v = 128;
    for (let k = 0; k < 8; k++) v += (((x >> k) + (y >> k) + ch * (k & 1)) & 1) ? 12 : -12;
    out[o + ch] = v;
  }
}));
const model = sphereGltf(150, 300, 'checker.png');
fs.writeFileSync(path.join(input, 'sphere.bin'), model.bin);
fs.writeFileSync(path.join(input, 'sphere.gltf'), JSON.stringify(model.json));
const out = path.join(work, 'out');
const converted = spawnSync(meshmux, ['convert', path.join(input, 'sphere.gltf'), '-o', out, '-q'], { encoding: 'utf8' });
if (converted.status !== 0) throw new Error(`meshmux convert exited ${converted.status}: ${converted.stderr}`);

// ---- The two windows --------------------------------------------------------------------------

const { server, url } = await serve(meshmux, out);
const { context, close: closeBrowser } = await launch(work, chromiumPath, { width: 1920, height: 1080 });
const settled = (page) => page.waitForFunction(() => ['complete', 'stopped', 'error'].includes(document.body.dataset.state),
  null, { timeout: 300000, polling: 100 });
// The sequence played: per chunk its kind, and where the top texture level and the last mesh
// layer came.
const played = (page) => page.evaluate(() => {
  const s = window.meshmuxViewer.stream, chunks = s.table.chunks, seq = s._sequence;
  const textures = seq.filter((c) => chunks[c].kind === 'texture'), meshes = seq.filter((c) => chunks[c].kind !== 'texture');
  const top = Math.max(...textures);
  return { state: document.body.dataset.state, followed: s.stats.orderFollowed, display: s.table.view.display,
    canvas: s.canvasSize(), kinds: seq.map((c) => chunks[c].kind[0]).join(''),
    top: seq.indexOf(top), lastMesh: Math.max(...meshes.map((c) => seq.indexOf(c))), meshes: meshes.length };
});
try {
  const page = context.pages()[0] || (await context.newPage());
  await page.goto(url);
  await settled(page);
  const large = await played(page);
  console.log(`1920×1080 window: ${large.kinds} (followed ${large.followed}, canvas ${large.canvas}, package display ${large.display})`);
  check(large.state === 'complete', `the 1920×1080 play completes (${large.state})`);
  check(String(large.display) === '1920,1080', `the package was ordered for 1920×1080 (${large.display})`);
  check(large.meshes >= 3, `the order has mesh layers to interleave (${large.meshes})`);
  check(large.top < large.lastMesh, `on 1920×1080 the top texture level comes before the last mesh layer (at ${large.top}, last mesh at ${large.lastMesh})`);

  await page.setViewportSize({ width: 480, height: 270 });
  await page.evaluate(() => window.meshmuxViewer.replay().then(() => null));
  await settled(page);
  const small = await played(page);
  console.log(`480×270 window: ${small.kinds} (followed ${small.followed}, canvas ${small.canvas})`);
  check(small.state === 'complete', `the 480×270 play completes (${small.state})`);
  check(String(small.canvas) === '480,270', `the stream plans for its canvas (${small.canvas})`);
  check(small.top > small.lastMesh, `on 480×270 the top texture level comes after every mesh layer (at ${small.top}, last mesh at ${small.lastMesh})`);
  check(small.followed === 'view-adapted', `the order was re-planned for the canvas (${small.followed})`);

  // ?display= plans for a display other than the canvas (bench/rd_client.mjs captures at sizes the
  // window is not): the 480×270 window planning for 1920×1080 orders as the 1920×1080 window did.
  await page.goto(url + '?display=1920x1080');
  await settled(page);
  const asked = await played(page);
  check(asked.top < asked.lastMesh && String(asked.canvas) === '1920,1080',
    `?display=1920x1080 in a 480×270 window plans for 1920×1080 (top at ${asked.top}, last mesh at ${asked.lastMesh})`);
} finally {
  await closeBrowser();
  server.kill();
}
if (failures.length) {
  console.error(`${failures.length} check(s) failed`);
  process.exit(1);
}
console.log('display: ok');
