// A big mesh's block package refined by view in the browser (docs/ARCHITECTURE.md "Targets":
// big meshes in the browser): headless chromium plays a converted package's model.mmxp through
// one throttled link (throttle.mjs: 20 ms latency, the page's and its worker's requests share
// it) with MeshmuxStream's triangleBudget, drawing every change, in three steps:
//   1. open: the first picture (the base drawn and read back) after navigation starts;
//   2. the default view (the package's framing) refined until the stream settles;
//   3. the camera moves close to the surface at the view's centre (a ray from the screen's
//      centre; the view then spans `--close` of the model's diagonal vertically, about 5 % of a
//      scan's surface at the default 0.17: the share is measured and printed) and the stream refines there: the time until the
//      screen-space error of the blocks in view is ≤ 1 pixel (the stream's stats.screenError),
//      or what it is after --seconds.
//   4. the budget halved there: detail dropped (the mesh decoded again from the blocks kept)
//      until the faces held fit it.
// --page-decoder: the blocks decoded on the page (MeshmuxStream worker: false) instead of in
// the library's worker.
// --world: the package placed twice side by side in a MeshmuxWorld (world.js), which plays a
// block package by view over both placements within its share of the world's budget.
// Throughout: resident triangles (faces held, stats.residentTriangles) checked against the
// budget at every event, and the page's main-thread tasks over 16 ms given to their owner
// (main_thread.mjs: a trace with a sampling profile; the library's, the bench's frames, the
// browser's commits, other); the library's are judged by the thread's own time in them. Prints the figures; writes WORK/view_blocks.json and each close
// view's refined frame, WORK/close-1.png and close-2.png.
// --check: exit 1 when a target is missed (first picture ≤ 2 s, close region ≤ 1 px within
// --seconds, resident ≤ budget, no library task over 16 ms): the browser test's use, on a small
// package with a small budget.
//
// usage: node bench/view_blocks.mjs --meshmux BIN --package DIR (a `meshmux convert` output)
//        --work DIR [--budget 2000000] [--mbit 10] [--seconds 10] [--close 0.17]
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
const close = Number(opt('--close', '0.17')), [W, H] = opt('--size', '960x540').split('x').map(Number);
const timeout = Number(opt('--timeout', '300'));
const worldMode = process.argv.includes('--world'), pageDecoder = process.argv.includes('--page-decoder');
const sceneBounds = JSON.parse(fs.readFileSync(path.join(dir, 'report.json'), 'utf8')).bounds;
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
const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setSize(W, H);
document.body.appendChild(renderer.domElement);
const scene = new THREE.Scene(), camera = new THREE.PerspectiveCamera(45, W / H, 0.01, 100);
const gl = renderer.getContext(), px = new Uint8Array(4);
// A frame drawn and finished (a pixel read back: the page waits for the GPU), for the first
// picture's time and the saved views; the frames while streaming are only submitted, as an
// application's are (reading back each one would hold the page's thread for the whole frame on
// software GL, and the stream's pacing with it).
function draw() { renderer.render(scene, camera); gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px); }
let pending = false;
// The frame drawn by an animation frame (named: a task that draws it is the frame's, not the
// library's, though the library's own animation-frame callbacks may run in the same task).
function frame() { pending = false; renderer.render(scene, camera); }
const redraw = () => { if (!pending) { pending = true; requestAnimationFrame(frame); } };
let stream, object, box;
let peak = 0, over = 0, events = 0;
const watch = (e) => { events++; const r = e.detail.residentTriangles; if (r > peak) peak = r; if (r > budget) over++; };
if (${worldMode}) {
  // Two placements of the package side by side in a MeshmuxWorld whose triangle budget gives
  // the block package (half the world's, over its two placements) the budget asked for.
  const { MeshmuxWorld } = await import('./viewer/world.js');
  const { WORLD_VERSION } = await import('./viewer/stream_format.js');
  const b = ${JSON.stringify(sceneBounds)}, shift = 1.2 * (b[3] - b[0]);
  const world = new MeshmuxWorld({ meshmux_world: WORLD_VERSION, packages: [{ url: 'model.mmxp', bounds: b }],
    placements: [{ package: 0, matrix: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1] }, { package: 0, matrix: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, shift, 0, 0, 1] }] },
    { renderer, camera, budget: { triangles: 4 * budget, texels: 2 ** 28, gpuBytes: 2 ** 30 } });
  scene.add(world.object);
  await world.open();
  stream = world.packages[0].stream;
  if (!stream.byView) throw new Error('the world plays the package in its stored order');
  object = world.object;
  box = new THREE.Box3().setFromObject(object);
  for (const type of ['chunk', 'settled']) stream.addEventListener(type, (e) => { watch(e); redraw(); });
  world.play();
} else {
  stream = new MeshmuxStream('model.mmxp', { renderer, camera, triangleBudget: budget, worker: ${!pageDecoder} });
  for (const type of ['chunk', 'settled', 'base']) stream.addEventListener(type, (e) => { watch(e); redraw(); });
  object = await stream.open();
  scene.add(object);
  box = stream.worldBounds();
}
stream.addEventListener('error', (e) => console.error('stream error: ' + e.detail.error.message));
const baseReady = now();  // the first picture joined the scene
const view = stream.table.view;
addStreamLighting(view, scene, camera, renderer);
const centre = box.getCenter(new THREE.Vector3()), diagonal = box.getSize(new THREE.Vector3()).length();
const direction = new THREE.Vector3().fromArray(view.direction).normalize();
const fit = (distance) => { camera.near = distance / 1000; camera.far = distance + 2 * diagonal; camera.updateProjectionMatrix(); };
const home = () => {
  camera.position.copy(centre).addScaledVector(direction, diagonal / (2 * Math.tan(Math.PI * camera.fov / 360)));
  camera.lookAt(centre); fit(camera.position.distanceTo(centre));
};
home();
draw();
const firstPicture = now();
// Resolved in a task of its own: the bench's code after it would otherwise run inside the
// library's task that dispatched the event (a promise's continuations run before the task ends)
// and count as the library's time.
// One listener however often it is asked for (the close views ask every 250 ms until it comes).
let settledWait = null;
const settled = () => (settledWait ||= new Promise((resolve) => stream.addEventListener('settled', () => { settledWait = null; setTimeout(resolve, 0); }, { once: true })));
const playing = stream.play();
await Promise.race([settled(), new Promise((r) => setTimeout(r, 60000))]);
const defaultView = { at: now(), ...pick(stream.stats) };
// The share of the surface in view: of the area of the triangles drawn (the surface at the
// detail held), that of the triangles whose centres are in the view and which face the camera.
function viewShare() {
  const frustum = new THREE.Frustum().setFromProjectionMatrix(new THREE.Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse));
  const eye = camera.position, a = new THREE.Vector3(), b = new THREE.Vector3(), c = new THREE.Vector3(), n = new THREE.Vector3(), e = new THREE.Vector3();
  let all = 0, seen = 0;
  object.traverse((x) => {
    const m = stream.meshes.find((mm) => mm.geometry === x.geometry);
    if (!m) return;
    const P = m.position, I = m.indices, M = x.matrixWorld;
    for (let f = 0; f < m.faces; f++) {
      a.fromArray(P, 3 * I[3 * f]).applyMatrix4(M); b.fromArray(P, 3 * I[3 * f + 1]).applyMatrix4(M); c.fromArray(P, 3 * I[3 * f + 2]).applyMatrix4(M);
      n.subVectors(b, a).cross(e.subVectors(c, a));
      const area = n.length() / 2;
      all += area;
      e.copy(a).add(b).add(c).multiplyScalar(1 / 3);
      if (frustum.containsPoint(e) && n.dot(e.sub(eye)) < 0) seen += area;
    }
  });
  return all > 0 ? seen / all : NaN;
}
// Close: the surface where a ray from the home view meets it (screen point [x, y]), seen from a
// distance where the view spans closeShare of the diagonal, along the surface's normal there.
// The bench's own work (a raycast, the share of the surface in view) starts a task of its own:
// awaited after the stream's 'settled' event, it would otherwise run inside the library's task
// that dispatched it, and count as the library's time.
const nextTask = () => new Promise((resolve) => setTimeout(resolve, 0));
async function closeUp([x, y], mark) {
  await nextTask();
  home();
  camera.updateMatrixWorld();
  const ray = new THREE.Raycaster();
  let first = null;
  for (let k = 1; k > 0.1 && !first; k /= 2) {  // nearer the centre until the ray meets the surface
    ray.setFromCamera(new THREE.Vector2(k * x, k * y), camera);
    [first] = ray.intersectObject(object, true);
  }
  const target = first ? first.point : centre;
  const normal = first && first.face ? first.face.normal.clone().transformDirection(first.object.matrixWorld) : direction.clone();
  if (normal.dot(direction) < 0) normal.negate();
  const distance = (closeShare * diagonal) / (2 * Math.tan(Math.PI * camera.fov / 360));
  camera.position.copy(target).addScaledVector(normal, distance);
  camera.lookAt(target); fit(distance);
  camera.updateMatrixWorld();
  const share = viewShare(), moved = now();
  performance.mark(mark);
  redraw();
  let sharp = null;
  const deadline = moved + Math.max(seconds, 30);
  while (now() < deadline) {
    const r = await Promise.race([settled().then(() => 'settled'), new Promise((res) => setTimeout(() => res('tick'), 250))]);
    if (stream.stats.screenError <= 1 && stream.stats.settled && sharp === null) sharp = now() - moved;
    if (sharp !== null) break;
    if (now() - moved > seconds && stream.stats.settled) break;
  }
  draw();
  shots.push(renderer.domElement.toDataURL('image/png'));
  return { at: now() - moved, sharp, hit: !!first, share, ...pick(stream.stats) };
}
const shots = [];
const closeView = await closeUp([0, 0], 'bench-moved');
const secondView = await closeUp([0.5, 0.35], 'bench-moved-again');
// The budget halved where the stream stands: detail dropped until it fits.
const before = stream.stats.rebuilds, halvedAt = now();
stream.triangleBudget = Math.floor(budget / 2);
await Promise.race([settled(), new Promise((r) => setTimeout(r, 30000))]);
const halved = { at: now() - halvedAt, drops: stream.stats.rebuilds - before, ...pick(stream.stats) };
performance.mark('bench-loaded');
stream.stop();
await playing;
function pick(x) { return { bytes: x.bytesReceived, resident: x.residentTriangles, screenError: x.screenError, blocksHeld: x.blocksHeld,
  blockCount: x.blockCount, blocksApplied: x.blocksApplied, rebuilds: x.rebuilds, applySeconds: x.applySeconds }; }
window.__shots = shots;
window.__bench = { baseReady, firstPicture, defaultView, closeView, secondView, halved, peak, over, events, budget, bytesTotal: stream.stats.bytesTotal };
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
  // What each close view drew once refined, for a look: WORK/close-K.png.
  (await tab.evaluate(() => window.__shots)).forEach((url, k) => fs.writeFileSync(path.join(work, `close-${k + 1}.png`), Buffer.from(url.split(',')[1], 'base64')));
  const { events, profile } = await trace.stop();
  // Tasks that run the bench's own drawing or measuring (frames, the close views' raycast and
  // surface share) are the bench's ('frame'), whatever library callback shares them.
  const tasks = taskOwners(events, profile, { start: 'bench-start', end: 'bench-loaded', library: LIBRARY, frameFunctions: ['draw', 'frame', 'closeUp', 'viewShare'] });
  // The library's tasks over 16 ms of the thread's own time (its CPU time where the trace has
  // it: on two cores shared with a software GL drawing the frames, a task's wall time is mostly
  // the thread waiting for a core), the longest first, and the longest by wall time beside.
  const own = (t) => (t.cpuMs === null ? t.ms : t.cpuMs);
  const library = tasks.tasks.filter((t) => t.owner === 'library');
  result.libraryTasks = library.filter((t) => own(t) > 16).sort((a, b) => own(b) - own(a)).slice(0, 5)
    .map((t) => ({ ms: t.ms, cpuMs: t.cpuMs, at: t.at, top: t.top, leaves: t.leaves, inside: t.inside }));
  result.libraryOwn = [...library].sort((a, b) => own(b) - own(a)).slice(0, 3).map((t) => ({ ms: t.ms, cpuMs: t.cpuMs, at: t.at, top: t.top, leaves: t.leaves, inside: t.inside }));
  result.libraryWall = library.sort((a, b) => b.ms - a.ms).slice(0, 3).map((t) => ({ ms: t.ms, cpuMs: t.cpuMs, at: t.at, top: t.top }));
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
console.log(`${worldMode ? 'in a world, placed twice: ' : ''}${pageDecoder ? 'decoded on the page: ' : ''}package ${(result.bytesTotal / 1e6).toFixed(2)} MB at ${mbit} Mbit/s, budget ${budget} triangles, ${W}x${H}`);
console.log(`first picture: joined the scene ${f(result.baseReady)} s after navigation, first frame drawn ${f(result.firstPicture)} s (lighting and shaders on this GL)`);
console.log(`default view: settled at ${f(d.at)} s, ${d.resident} triangles held, ${d.blocksHeld}/${d.blockCount} blocks, ${(d.bytes / 1e6).toFixed(2)} MB, screen error ${f(d.screenError)} px`);
for (const [name, c] of [['close view', result.closeView], ['second close view', result.secondView]]) {
  console.log(`${name} (${c.hit ? 'surface hit' : 'no surface hit: the centre'}, ${f(100 * c.share, 1)} % of the surface in view): ≤ 1 px after ${c.sharp === null ? 'never' : `${f(c.sharp)} s`}; at ${f(c.at)} s: ${c.resident} triangles, ${c.blocksHeld} blocks held, ${c.blocksApplied} applied, ${c.rebuilds} drops, ${(c.bytes / 1e6).toFixed(2)} MB, screen error ${f(c.screenError)} px, worker ${f(c.applySeconds)} s`);
}
console.log(`budget halved: ${result.halved.resident} triangles held after ${f(result.halved.at)} s (${result.halved.drops} drops), screen error ${f(result.halved.screenError)} px`);
console.log(`resident: peak ${result.peak} of ${budget} (${result.over} events over, ${result.events} events)`);
const task = (t) => `${f(t.ms, 1)} ms (thread ${t.cpuMs === null ? '?' : f(t.cpuMs, 1)} ms) at ${f(t.at, 1)} s (${t.top.slice(0, 2).join(', ')})`;
console.log(`library main-thread tasks over 16 ms of the thread's own time: ${result.libraryTasks.length ? result.libraryTasks.map(task).join('; ') : 'none'}`);
console.log(`longest library tasks by wall time: ${result.libraryWall.length ? result.libraryWall.map(task).join('; ') : 'none over 16 ms'}`);
if (check) {
  const failures = [];
  const firstLimit = opt('--first-picture');  // seconds; checked when given
  if (firstLimit !== undefined && !(result.baseReady <= Number(firstLimit))) failures.push(`first picture joined ${f(result.baseReady)} s > ${firstLimit} s`);
  for (const [name, v] of [['close', result.closeView], ['second close', result.secondView]]) {
    if (!(v.sharp !== null && v.sharp <= seconds)) failures.push(`${name} region not ≤ 1 px within ${seconds} s (${v.sharp === null ? 'never' : f(v.sharp)})`);
    if (!v.hit) failures.push(`the ${name} view hit no surface`);
  }
  if (result.peak > budget || result.over) failures.push(`resident ${result.peak} > budget ${budget}`);
  const h = result.halved;
  if (!(h.resident <= Math.floor(budget / 2) && h.drops > 0)) failures.push(`the budget halved: ${h.resident} triangles held, ${h.drops} drops`);
  if (result.libraryTasks.length) failures.push(`library task of ${f(lib.cpuMs === null ? lib.ms : lib.cpuMs, 1)} ms of the thread's own time`);
  for (const x of failures) console.log(`FAIL ${x}`);
  process.exit(failures.length ? 1 : 0);
}
