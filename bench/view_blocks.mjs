// A big mesh's block package refined by view in the browser (docs/ARCHITECTURE.md "Targets":
// big meshes in the browser): headless chromium plays a converted package's model.mmxp through
// one throttled link (throttle.mjs: 20 ms latency, the page's and its worker's requests share
// it) with MeshmuxStream's triangleBudget, drawing every change, in three steps:
//   1. open: the first picture (the base drawn and read back) after navigation starts;
//   2. the default view (the package's framing) refined until the stream settles;
//   3. the camera moves close to the surface at the view's centre (a ray from the screen's
//      centre; the view then spans `--close` of the model's diagonal, about 5 % of a scan's
//      surface at the default 0.22) and the stream refines there: the time until the
//      screen-space error of the blocks in view is ≤ 1 pixel (the stream's stats.screenError),
//      or what it is after --seconds.
// Throughout: resident triangles (faces held, stats.residentTriangles) checked against the
// budget at every event, and the page's main-thread tasks over 16 ms given to their owner
// (main_thread.mjs: a trace with a sampling profile; the library's, the bench's frames, the
// browser's commits, other). Prints the figures; writes WORK/view_blocks.json.
// --check: exit 1 when a target is missed (first picture ≤ 2 s, close region ≤ 1 px within
// --seconds, resident ≤ budget, no library task over 16 ms): the browser test's use, on a small
// package with a small budget.
//
// usage: node bench/view_blocks.mjs --meshmux BIN --package DIR (a `meshmux convert` output)
//        --work DIR [--budget 2000000] [--mbit 10] [--seconds 10] [--close 0.22]
//        [--size 960x540] [--check] [--chromium PATH]
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { launch, opt, serve, skip } from '../viewers/web/tests/harness.mjs';
import { startTrace, taskOwners } from './main_thread.mjs';
import { throttle } from './throttle.mjs';

const meshmux = opt('--meshmux'), dir = opt('--package'), work = opt('--work');
if (!meshmux || !dir || !work) {
  console.error('usage: node bench/view_blocks.mjs --meshmux BIN --package DIR --work DIR [--budget N] [--mbit 10] [--seconds 10] [--close 0.22] [--size WxH] [--check]');
  process.exit(2);
}
const budget = Number(opt('--budget', '2000000')), mbit = Number(opt('--mbit', '10')), seconds = Number(opt('--seconds', '10'));
const close = Number(opt('--close', '0.22')), [W, H] = opt('--size', '960x540').split('x').map(Number);
const timeout = Number(opt('--timeout', '300'));
const check = process.argv.includes('--check'), chromiumPath = opt('--chromium', '/usr/bin/chromium');
if (!fs.existsSync(chromiumPath)) skip(`${chromiumPath} not installed`);
if (!fs.existsSync(path.join(dir, 'model.mmxp'))) skip(`${dir} holds no model.mmxp`);
fs.mkdirSync(work, { recursive: true });
const LIBRARY = /\/viewer\/(meshmux|stream_\w+|package_reader|view_plan|view_stream|block_view|materials|lighting|upload|gltf_plugins|worker_client)\.js|\/addons\/(loaders|libs)\//;

// The page, beside the package (the server serves that folder only), with the viewer's import
// map (three's folder is named by its version).
const importMap = /<script type="importmap">\s*([\s\S]*?)\s*<\/script>/.exec(fs.readFileSync(path.join(dir, 'index.html'), 'utf8'))[1];
const page = path.join(dir, 'bench_view.html');
fs.writeFileSync(page, `<!doctype html><html><head><meta charset="utf-8">
<script type="importmap">${importMap}</script>
</head><body style="margin:0"><script type="module">
performance.mark('bench-start');
import * as THREE from 'three';
import { MeshmuxStream, addStreamLighting } from './viewer/meshmux.js';
const W = ${W}, H = ${H}, budget = ${budget}, seconds = ${seconds}, closeShare = ${close};
const now = () => performance.now() / 1000;
const renderer = new THREE.WebGLRenderer({ antialias: false });
renderer.setPixelRatio(1);
renderer.setSize(W, H);
document.body.appendChild(renderer.domElement);
const scene = new THREE.Scene(), camera = new THREE.PerspectiveCamera(45, W / H, 0.01, 100);
const gl = renderer.getContext(), px = new Uint8Array(4);
function draw() { renderer.render(scene, camera); gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px); }
let pending = false;
const redraw = () => { if (!pending) { pending = true; requestAnimationFrame(() => { pending = false; draw(); }); } };
const stream = new MeshmuxStream('model.mmxp', { renderer, camera, triangleBudget: budget });
let peak = 0, over = 0, events = 0;
const watch = (e) => { events++; const r = e.detail.residentTriangles; if (r > peak) peak = r; if (r > budget) over++; };
for (const type of ['chunk', 'settled', 'base']) stream.addEventListener(type, (e) => { watch(e); redraw(); });
const object = await stream.open();
scene.add(object);
const view = stream.table.view;
addStreamLighting(view, scene, camera, renderer);
const box = stream.worldBounds(), centre = box.getCenter(new THREE.Vector3()), diagonal = box.getSize(new THREE.Vector3()).length();
const direction = new THREE.Vector3().fromArray(view.direction).normalize();
const fit = (distance) => { camera.near = distance / 1000; camera.far = distance + 2 * diagonal; camera.updateProjectionMatrix(); };
camera.position.copy(centre).addScaledVector(direction, diagonal / (2 * Math.tan(Math.PI * camera.fov / 360)));
camera.lookAt(centre); fit(camera.position.distanceTo(centre));
const baseReady = now();
draw();
const firstPicture = now();
const settled = () => new Promise((resolve) => stream.addEventListener('settled', resolve, { once: true }));
const playing = stream.play();
let s = await Promise.race([settled(), new Promise((r) => setTimeout(r, 60000))]);
const defaultView = { at: now(), ...pick(stream.stats) };
// Close: the surface at the view's centre, seen from a distance where the view spans closeShare
// of the diagonal, along the surface's normal there (facing the camera).
const hit = new THREE.Raycaster();
hit.setFromCamera(new THREE.Vector2(0, 0), camera);
const [first] = hit.intersectObject(object, true);
const target = first ? first.point : centre;
const normal = first && first.face ? first.face.normal.clone().transformDirection(first.object.matrixWorld) : direction.clone();
if (normal.dot(direction) < 0) normal.negate();
const distance = (closeShare * diagonal) / (2 * Math.tan(Math.PI * camera.fov / 360));
camera.position.copy(target).addScaledVector(normal, distance);
camera.lookAt(target); fit(distance);
const moved = now();
performance.mark('bench-moved');
redraw();
let sharp = null;
const deadline = moved + Math.max(seconds, 30);
while (now() < deadline) {
  const r = await Promise.race([settled().then(() => 'settled'), new Promise((res) => setTimeout(() => res('tick'), 250))]);
  if (stream.stats.screenError <= 1 && sharp === null) sharp = now() - moved;
  if (r === 'settled' && stream.stats.screenError <= 1) break;
  if (now() - moved > seconds && sharp === null && stream.stats.settled) break;
}
const closeView = { at: now() - moved, sharp, ...pick(stream.stats) };
performance.mark('bench-loaded');
stream.stop();
await playing;
function pick(x) { return { bytes: x.bytesReceived, resident: x.residentTriangles, screenError: x.screenError, blocksHeld: x.blocksHeld,
  blockCount: x.blockCount, blocksApplied: x.blocksApplied, rebuilds: x.rebuilds, applySeconds: x.applySeconds }; }
window.__bench = { baseReady, firstPicture, defaultView, closeView, peak, over, events, budget, hit: !!first, bytesTotal: stream.stats.bytesTotal };
console.log('bench-view: done');
</script></body></html>
`);

const { server, url: direct } = await serve(meshmux, dir);
const link = await throttle(direct, { bytesPerSecond: (mbit * 1e6) / 8, latencyMs: 20 });
const { context, close: closeBrowser } = await launch(work, chromiumPath, { width: W, height: H });
let result;
try {
  const tab = context.pages()[0] || (await context.newPage());
  tab.on('console', (m) => { if (m.type() === 'error') console.error(`  page: ${m.text()}`); });
  tab.on('pageerror', (e) => console.error(`  page error: ${e.message}`));
  tab.on('response', (r) => { if (r.status() >= 400) console.error(`  page: ${r.status()} ${r.url()}`); });
  const done = new Promise((resolve) => tab.on('console', (m) => { if (m.text() === 'bench-view: done') resolve(); }));
  await tab.goto(`${link.url}report.json`).catch(() => {});  // the origin first: the bench page then runs in the traced renderer
  const trace = await startTrace(await context.newCDPSession(tab));
  const t0 = Date.now();
  await tab.goto(`${link.url}bench_view.html`);
  await Promise.race([done, new Promise((_, reject) => setTimeout(() => reject(new Error(`the page did not finish in ${timeout} s`)), timeout * 1000))]);
  result = await tab.evaluate(() => window.__bench);
  const { events, profile } = await trace.stop();
  const tasks = taskOwners(events, profile, { start: 'bench-start', end: 'bench-loaded', library: LIBRARY, frameFunctions: ['draw'] });
  result.libraryTasks = tasks.tasks.filter((t) => t.owner === 'library').sort((a, b) => b.ms - a.ms).slice(0, 5)
    .map((t) => ({ ms: t.ms, cpuMs: t.cpuMs, at: t.at, top: t.top }));
  result.owners = tasks.owners;
  result.wallSeconds = (Date.now() - t0) / 1000;
} finally {
  await closeBrowser();
  await link.close();
  server.kill();
  fs.rmSync(page, { force: true });
}
fs.writeFileSync(path.join(work, 'view_blocks.json'), JSON.stringify(result, null, 1));
const d = result.defaultView, c = result.closeView, lib = result.libraryTasks[0];
const f = (x, n = 2) => (Number.isFinite(x) ? x.toFixed(n) : '–');
console.log(`package ${(result.bytesTotal / 1e6).toFixed(2)} MB at ${mbit} Mbit/s, budget ${budget} triangles, ${W}x${H}`);
console.log(`first picture: ${f(result.firstPicture)} s after navigation (the base ready ${f(result.baseReady)} s; the rest is the first frame: lighting and shaders)`);
console.log(`default view: settled at ${f(d.at)} s, ${d.resident} triangles held, ${d.blocksHeld}/${d.blockCount} blocks, ${(d.bytes / 1e6).toFixed(2)} MB, screen error ${f(d.screenError)} px`);
console.log(`close view (${result.hit ? 'surface hit' : 'no surface hit: the centre'}): ≤ 1 px after ${c.sharp === null ? 'never' : `${f(c.sharp)} s`}; at ${f(c.at)} s: ${c.resident} triangles, ${c.blocksHeld} blocks held, ${c.blocksApplied} applied, ${c.rebuilds} drops, ${(c.bytes / 1e6).toFixed(2)} MB, screen error ${f(c.screenError)} px, worker ${f(c.applySeconds)} s`);
console.log(`resident: peak ${result.peak} of ${budget} (${result.over} events over, ${result.events} events)`);
console.log(`library main-thread tasks over 16 ms: ${result.libraryTasks.length ? result.libraryTasks.map((t) => `${f(t.ms, 1)} ms at ${f(t.at, 1)} s (${t.top.slice(0, 2).join(', ')})`).join('; ') : 'none'}`);
if (check) {
  const failures = [];
  if (!(result.firstPicture <= 2)) failures.push(`first picture ${f(result.firstPicture)} s > 2 s`);
  if (!(c.sharp !== null && c.sharp <= seconds)) failures.push(`close region not ≤ 1 px within ${seconds} s (${c.sharp === null ? 'never' : f(c.sharp)})`);
  if (result.peak > budget || result.over) failures.push(`resident ${result.peak} > budget ${budget}`);
  if (result.libraryTasks.length) failures.push(`library task of ${f(lib.ms, 1)} ms`);
  if (!result.hit) failures.push('the close view hit no surface');
  if (!(c.rebuilds >= 0 && d.blocksHeld > 0)) failures.push('no block applied');
  for (const x of failures) console.log(`FAIL ${x}`);
  process.exit(failures.length ? 1 : 0);
}
