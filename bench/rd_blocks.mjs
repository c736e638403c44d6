// A block package's order judged in the three.js client's own frames from the default view
// (docs/ARCHITECTURE.md "Targets": rate-distortion of block hierarchies): headless chromium plays
// the package, from the viewer's default camera (the package's framing), three ways, and after
// every chunk or block applied draws the frame and measures it against the full detail's frame:
//   by view   MeshmuxStream with a triangle budget (--budget, default 10M: it never binds
//             here) and the camera: the client's own choice of blocks (block_view.js planBlocks:
//             projected error removed × screen area per byte, parents first), which stops where
//             nothing in view is over a pixel;
//   level     the same package in its stored order: the blocks by level, the root's pieces, then
//             the coarsest level's blocks to the finest's (breadth first, as 3D Tiles would send
//             them);
//   chain     with --chain DIR: the same mesh converted as one chain (meshmux convert
//             --blocks-above 0), its stored order: today's single chain.
// The reference: the block package's every chunk applied (level order played to its end), the
// same camera and canvas. Distortion of a frame (as bench/rd_client.mjs measures the client's
// frames): the MSE per RGB channel (0..255) over the pixels either frame covers (alpha > 0, the
// canvas cleared to transparent black), a pixel one of them leaves uncovered counting as black.
// Area: the step integral of that distortion over the bytes applied (stats.bytesReceived, which
// counts what was applied, not what is in flight), each frame held until the next arrives and
// the blank frame's distortion before the base, divided by the span: over the bytes the by-view
// play used (where it settled) and over the whole package. LOWER IS BETTER. The plays are
// unthrottled (the axis is bytes, not time). Prints a table; writes WORK/rd_blocks.json with
// every play's curve.
//
// usage: node bench/rd_blocks.mjs --meshmux BIN --package DIR (a block package's `meshmux
//        convert` output) [--chain DIR] --work DIR [--size 960x540] [--budget 10000000]
//        [--chromium PATH] [--timeout 900]
import fs from 'node:fs';
import path from 'node:path';

import { launch, opt, serve, skip } from '../viewers/web/tests/harness.mjs';

const meshmux = opt('--meshmux'), dir = opt('--package'), chainDir = opt('--chain'), work = opt('--work');
if (!meshmux || !dir || !work) {
  console.error('usage: node bench/rd_blocks.mjs --meshmux BIN --package DIR [--chain DIR] --work DIR [--size WxH] [--budget N]');
  process.exit(2);
}
const [W, H] = opt('--size', '960x540').split('x').map(Number), budget = Number(opt('--budget', '10000000'));
const timeout = Number(opt('--timeout', '900')), chromiumPath = opt('--chromium', '/usr/bin/chromium');
if (!fs.existsSync(chromiumPath)) skip(`${chromiumPath} not installed`);
for (const d of [dir, chainDir].filter(Boolean))
  if (!fs.existsSync(path.join(d, 'model.mmxp'))) skip(`${d} holds no model.mmxp`);
fs.mkdirSync(work, { recursive: true });

// The page is served beside the block package; the chain package's model.mmxp is linked into
// that folder under another name (the server serves one folder).
const chainName = 'rd_blocks_chain.mmxp';
if (chainDir) {
  fs.rmSync(path.join(dir, chainName), { force: true });
  fs.linkSync(path.join(chainDir, 'model.mmxp'), path.join(dir, chainName));
}
const importMap = /<script type="importmap">\s*([\s\S]*?)\s*<\/script>/.exec(fs.readFileSync(path.join(dir, 'index.html'), 'utf8'))[1];
const page = path.join(dir, 'bench_rd_blocks.html');
fs.writeFileSync(page, `<!doctype html><html><head><meta charset="utf-8">
<script type="importmap">${importMap}</script>
</head><body style="margin:0"><script type="module">
import * as THREE from 'three';
import { MeshmuxStream, addStreamLighting } from './viewer/meshmux.js';
const W = ${W}, H = ${H};
const renderer = new THREE.WebGLRenderer({ antialias: false, alpha: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setSize(W, H);
renderer.setClearColor(0x000000, 0);
document.body.appendChild(renderer.domElement);
const gl = renderer.getContext();
const camera = new THREE.PerspectiveCamera(45, W / H, 0.01, 100);
let scene;
// The frame as drawn now: RGBA rows as WebGL reads them (the same for every play).
function frame() {
  renderer.render(scene, camera);
  const px = new Uint8Array(W * H * 4);
  gl.readPixels(0, 0, W, H, gl.RGBA, gl.UNSIGNED_BYTE, px);
  return px;
}
function mse(a, ref) {
  let sum = 0, n = 0;
  for (let i = 0; i < a.length; i += 4) {
    if (a[i + 3] === 0 && ref[i + 3] === 0) continue;
    const ca = a[i + 3] === 0 ? 0 : 1, cr = ref[i + 3] === 0 ? 0 : 1;
    for (let k = 0; k < 3; k++) { const d = ca * a[i + k] - cr * ref[i + k]; sum += d * d; }
    n += 3;
  }
  return n ? sum / n : 0;
}
// One play from the default view: after the base and every chunk or block applied, the frame's
// distortion against ref (or the frames' own list when ref is null: the last is kept).
async function play(url, options, ref) {
  scene = new THREE.Scene();
  const stream = new MeshmuxStream(url, { renderer, camera, ...options });
  const object = await stream.open();
  scene.add(object);
  const view = stream.table.view;
  camera.removeFromParent();  // the lights follow the camera into this play's scene
  const unlight = addStreamLighting(view, scene, camera, renderer);
  const box = stream.worldBounds();
  const centre = box.getCenter(new THREE.Vector3()), diagonal = box.getSize(new THREE.Vector3()).length();
  const direction = new THREE.Vector3().fromArray(view.direction).normalize();
  const distance = diagonal / (2 * Math.tan(Math.PI * camera.fov / 360));
  camera.position.copy(centre).addScaledVector(direction, distance);
  camera.lookAt(centre);
  camera.near = distance / 1000; camera.far = distance + 2 * diagonal;
  camera.updateProjectionMatrix();
  camera.updateMatrixWorld();
  const curve = [];
  let last = null;
  const sample = () => {
    const px = frame();
    if (ref) curve.push({ bytes: stream.stats.bytesReceived, mse: mse(px, ref), triangles: stream.stats.residentTriangles });
    last = px;
  };
  const blank = ref ? mse(new Uint8Array(W * H * 4), ref) : 0;
  sample();  // the base
  stream.addEventListener('chunk', sample);
  const settled = new Promise((resolve) => { stream.addEventListener('settled', resolve); stream.addEventListener('complete', resolve); });
  const playing = stream.play();
  await Promise.race([settled, playing]);
  stream.stop();
  await playing;
  const out = { curve, blank, byView: stream.byView, bytesTotal: stream.stats.bytesTotal, last };
  unlight();
  stream.dispose();
  return out;
}
const reference = await play('model.mmxp', {}, null);
const ref = reference.last;
const plays = {};
plays.view = await play('model.mmxp', { triangleBudget: ${budget} }, ref);
plays.level = await play('model.mmxp', {}, ref);
if (${!!chainDir}) plays.chain = await play('${chainName}', {}, ref);
for (const p of Object.values(plays)) delete p.last;
window.__rd = plays;
console.log('bench-rd: done');
</script></body></html>
`);

const { server, url } = await serve(meshmux, dir);
const { context, close } = await launch(work, chromiumPath, { width: W, height: H });
let plays;
try {
  const tab = context.pages()[0] || (await context.newPage());
  tab.on('console', (m) => { if (m.type() === 'error') console.error(`  page: ${m.text()}`); });
  tab.on('pageerror', (e) => console.error(`  page error: ${e.message}`));
  const done = new Promise((resolve) => tab.on('console', (m) => { if (m.text() === 'bench-rd: done') resolve(); }));
  await tab.goto(`${url}bench_rd_blocks.html`);
  await Promise.race([done, new Promise((_, reject) => setTimeout(() => reject(new Error(`the page did not finish in ${timeout} s`)), timeout * 1000))]);
  plays = await tab.evaluate(() => window.__rd);
} finally {
  await close();
  server.kill();
  fs.rmSync(page, { force: true });
  if (chainDir) fs.rmSync(path.join(dir, chainName), { force: true });
}

// The step integral over [0, span] of a play's distortion: blank until its first sample, each
// sample held until the next, the last held to the span's end; divided by the span.
function area(p, span) {
  let sum = 0, at = 0, value = p.blank;
  for (const s of p.curve) {
    const b = Math.min(s.bytes, span);
    sum += value * (b - at);
    at = b, value = s.mse;
    if (at >= span) break;
  }
  if (at < span) sum += value * (span - at);
  return sum / span;
}
const view = plays.view, viewBytes = view.curve[view.curve.length - 1].bytes;
const spans = [['to the by-view play\'s settled bytes', viewBytes], ['to the whole block package', view.bytesTotal]];
const result = { size: `${W}x${H}`, budget, viewSettledBytes: viewBytes, plays, areas: {} };
const f = (x, n = 2) => (Number.isFinite(x) ? x.toFixed(n) : '–');
console.log(`${W}x${H}, default view; block package ${(view.bytesTotal / 1e6).toFixed(2)} MB${plays.chain ? `, chain package ${(plays.chain.bytesTotal / 1e6).toFixed(2)} MB` : ''}; by view (${view.byView ? 'played by view' : 'NOT played by view'}) settled at ${(viewBytes / 1e6).toFixed(2)} MB, ${view.curve[view.curve.length - 1].triangles} triangles`);
console.log('\n| span | ' + Object.keys(plays).join(' | ') + ' |\n|---|' + Object.keys(plays).map(() => '---:').join('|') + '|');
for (const [name, span] of spans) {
  result.areas[name] = {};
  for (const [k, p] of Object.entries(plays)) result.areas[name][k] = area(p, span);
  console.log(`| ${name} (${(span / 1e6).toFixed(2)} MB) | ` + Object.values(result.areas[name]).map((a) => f(a, 3)).join(' | ') + ' |');
}
console.log('\narea: mean MSE per RGB channel (0..255) against the full detail over the bytes applied; lower is better');
for (const [k, p] of Object.entries(plays))
  console.log(`${k}: ${p.curve.length} frames, final ${f(p.curve[p.curve.length - 1].mse, 3)} at ${(p.curve[p.curve.length - 1].bytes / 1e6).toFixed(2)} MB`);
fs.writeFileSync(path.join(work, 'rd_blocks.json'), JSON.stringify(result, null, 1));
