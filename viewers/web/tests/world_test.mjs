// MeshmuxWorld in headless chromium: three packages (the built-in sample converted three times)
// placed with one behind the camera, and a fourth whose package is missing. The one behind gets
// no refinement bytes while the others stream ('waiting' once only it is left), then streams
// once the camera turns to it; the missing one is reported by name and the rest play to the end,
// every package showing its largest texture level at "complete" (levels go up beside later grants);
// no more than maxRequests range requests are ever in flight; decoding runs in the world's pool
// of 2 workers. A second world of the two ahead, its budget the bases' texels and one package's
// refinement triangles: no chunk passes it and it stops short. Then the page `meshmux batch` writes:
// four uploads batch-converted (two samples, two cubes whose packages are whole Draco-coded
// bases), OUTROOT served, world.html streams them to "complete" with no page error or failed
// request.
//
// usage: node world_test.mjs --meshmux BIN --work DIR [--chromium PATH]
// Exit: 0 pass, 1 fail, 77 skipped (no chromium: said on stderr).
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { fileURLToPath } from 'node:url';
import { launch, opt, serve, skip } from './harness.mjs';

const meshmux = opt('--meshmux');
const work = opt('--work');
const chromiumPath = opt('--chromium', '/usr/bin/chromium');
if (!meshmux || !work) {
  console.error('usage: node world_test.mjs --meshmux BIN --work DIR');
  process.exit(2);
}
if (!fs.existsSync(chromiumPath)) skip(`${chromiumPath} not installed (apt-get install chromium)`);
const web = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');

function run(cmd, argv) {
  const r = spawnSync(cmd, argv, { encoding: 'utf8', maxBuffer: 1 << 26 });
  if (r.status !== 0) throw new Error(`${cmd} ${argv.join(' ')} exited ${r.status}: ${r.stderr}`);
  return r.stdout;
}

fs.rmSync(work, { recursive: true, force: true });
const site = path.join(work, 'site');
fs.mkdirSync(site, { recursive: true });
const sample = path.join(work, 'sample.glb');
run(meshmux, ['sample', '-o', sample, '-q']);
for (const name of ['a', 'b', 'c']) run(meshmux, ['convert', sample, '-o', path.join(site, name), '-q']);
// The library beside them: a converted folder's viewer files, and the world's two modules.
const lib = path.join(site, 'a', 'viewer');
for (const f of ['world.js', 'world_plan.js']) fs.copyFileSync(path.join(web, f), path.join(lib, f));
const three = fs.readdirSync(lib).find((f) => f.startsWith('three-'));
const report = JSON.parse(fs.readFileSync(path.join(site, 'a', 'report.json'), 'utf8'));
const bounds = report.bounds;
const size = Math.hypot(bounds[3] - bounds[0], bounds[4] - bounds[1], bounds[5] - bounds[2]);
// Camera at the origin looking down −z: a and b ahead, c behind, "gone" ahead but missing.
const at = (x, z) => [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, x * size, 0, z * size, 1];
const world = {
  meshmux_world: 1,
  packages: ['a', 'b', 'c', 'gone'].map((n) => ({ name: n, url: `${n}/model.mmxp`, bounds, bytes: 1 })),
  placements: [{ package: 0, matrix: at(-0.7, -2) }, { package: 1, matrix: at(0.7, -2) },
    { package: 2, matrix: at(0, 2) }, { package: 3, matrix: at(0, -3) }],
};
fs.writeFileSync(path.join(site, 'world.json'), JSON.stringify(world));
// The budget world: a and b ahead, nothing else.
fs.writeFileSync(path.join(site, 'budget.json'), JSON.stringify({ ...world, packages: world.packages.slice(0, 2), placements: world.placements.slice(0, 2) }));
fs.writeFileSync(path.join(site, 'index.html'), `<!doctype html>
<html><head><meta charset="utf-8">
<script type="importmap">{"imports": {"three": "./a/viewer/${three}/three.module.js", "three/addons/": "./a/viewer/${three}/addons/"}}</script>
</head><body><script type="module">
import * as THREE from 'three';
import { MeshmuxWorld } from './a/viewer/world.js';
const renderer = new THREE.WebGLRenderer();
renderer.setSize(480, 360);
document.body.appendChild(renderer.domElement);
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(50, 4 / 3, ${size} * 0.01, ${size} * 100);
camera.position.set(${(bounds[0] + bounds[3]) / 2}, ${(bounds[1] + bounds[4]) / 2}, ${(bounds[2] + bounds[5]) / 2});
camera.lookAt(camera.position.x, camera.position.y, camera.position.z - 1);
const world = new MeshmuxWorld('world.json', { renderer, camera, maxRequests: 3, workers: 2 });
const per = () => Object.fromEntries(world.packages.map((p) => [p.name, p.stream && p.stream.table ? p.stream.stats.chunksApplied : -1]));
const log = { errors: [], waiting: null, final: null };
world.addEventListener('error', (e) => log.errors.push(e.detail.package + ': ' + e.detail.error.message));
world.addEventListener('chunk', () => renderer.render(scene, camera));
world.addEventListener('waiting', () => {
  if (log.waiting) return;
  log.waiting = per();
  // Turn around: c is ahead now.
  camera.lookAt(camera.position.x, camera.position.y, camera.position.z + 1);
  camera.updateMatrixWorld();
});
try {
  scene.add(await world.open());
  log.opened = per();
  log.opened.aTriangles = world.packages[0].stream.stats.triangles;
  const stats = await world.play();
  log.final = per();
  log.stats = { failed: stats.failed, requestsPeak: stats.requestsPeak, state: stats.state,
    chunksApplied: stats.chunksApplied, chunkCount: stats.chunkCount, decoder: stats.decoder,
    workersStarted: world.workers._workers.length, poolSize: world.workers.size, texels: stats.texels };
  // Texture levels go up beside the next grants: 'complete' waits for the last of them.
  log.stats.levelTexels = world.packages.filter((p) => p.stream && p.stream.table).reduce((sum, p) =>
    sum + Math.max(0, ...p.stream.table.chunks.filter((c) => c.kind === 'texture').map((c) => c.width * c.height)), 0);
  log.stats.uploadingAtEnd = world.packages.filter((p) => p.stream && p.stream.uploading).length;
  const a = world.packages[0].stream.stats;
  log.fullTriangles = a.triangles;  // package a complete
  // A budget that binds: the bases' texels, and triangles for one package's refinements over
  // the two (each of a and b would take them all). Checked at every chunk.
  const ahead = new THREE.PerspectiveCamera(50, 4 / 3, ${size} * 0.01, ${size} * 100);
  ahead.position.copy(camera.position);
  ahead.lookAt(camera.position.x, camera.position.y, camera.position.z - 1);
  const tight = new MeshmuxWorld('budget.json', { renderer, camera: ahead, budget: { triangles: Infinity, texels: Infinity } });
  await tight.open();
  const base = tight.stats;
  tight.options.budget = { triangles: base.triangles + (a.triangles - log.opened.aTriangles), texels: base.texels };
  log.budget = { ...tight.options.budget, baseTriangles: base.triangles, over: [] };
  tight.addEventListener('chunk', (e) => {
    if (e.detail.triangles > log.budget.triangles || e.detail.texels > log.budget.texels)
      log.budget.over.push([e.detail.triangles, e.detail.texels]);
  });
  const end = await tight.play();
  log.budget.end = { state: end.state, triangles: end.triangles, texels: end.texels, chunksApplied: end.chunksApplied, chunkCount: end.chunkCount };
} catch (e) {
  log.errors.push('fatal: ' + e.message);
}
window.__world = log;
console.log('meshmux-world: done');
</script></body></html>
`);

const { server, url } = await serve(meshmux, site);
const { context, close: closeBrowser } = await launch(work, chromiumPath);
const problems = [];
let log = null;
try {
  const page = context.pages()[0] || (await context.newPage());
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  const done = new Promise((resolve) => page.on('console', (m) => { if (m.text() === 'meshmux-world: done') resolve('done'); }));
  await page.goto(url);
  let timer;
  const timeout = new Promise((resolve) => { timer = setTimeout(() => resolve('timeout'), 240000); });
  if ((await Promise.race([done, timeout])) !== 'done') problems.push('the page did not finish in 240 s');
  clearTimeout(timer);
  log = await page.evaluate(() => window.__world);
} finally {
  await closeBrowser();
  server.kill();
}
// The batch's own world page.
const uploads = path.join(work, 'uploads');
fs.mkdirSync(uploads, { recursive: true });
for (const n of ['one', 'two']) fs.copyFileSync(sample, path.join(uploads, `${n}.glb`));
// Two cubes too: a model this small ships whole (a Draco-coded base, no refinements), and a
// world's packages share one Draco decoder; two of them show that sharing works.
{
  const p = new Float32Array([0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1]);
  const i = new Uint16Array([0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4, 3, 6, 2, 3, 7, 6, 1, 2, 6, 1, 6, 5, 0, 4, 7, 0, 7, 3]);
  const bin = Buffer.concat([Buffer.from(p.buffer), Buffer.from(i.buffer)]);
  const gltf = { asset: { version: '2.0' }, scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }],
    meshes: [{ primitives: [{ attributes: { POSITION: 0 }, indices: 1 }] }],
    buffers: [{ byteLength: bin.length, uri: `data:application/octet-stream;base64,${bin.toString('base64')}` }],
    bufferViews: [{ buffer: 0, byteOffset: 0, byteLength: 96 }, { buffer: 0, byteOffset: 96, byteLength: 72 }],
    accessors: [{ bufferView: 0, componentType: 5126, count: 8, type: 'VEC3', min: [0, 0, 0], max: [1, 1, 1] },
      { bufferView: 1, componentType: 5123, count: 36, type: 'SCALAR' }] };
  for (const n of ['cube1', 'cube2']) fs.writeFileSync(path.join(uploads, `${n}.gltf`), JSON.stringify(gltf));
}
const outroot = path.join(work, 'outroot');
run(meshmux, ['batch', uploads, '-o', outroot, '-q', '--jobs', '2']);
let pageEnd = null;
{
  const { server: server2, url: url2 } = await serve(meshmux, outroot);
  const { context: context2, close: close2 } = await launch(work, chromiumPath);
  try {
    const page = context2.pages()[0] || (await context2.newPage());
    page.on('pageerror', (e) => problems.push(`world.html: page error: ${e.message}`));
    page.on('response', (r) => { if (r.status() >= 400 && !r.url().endsWith('/favicon.ico')) problems.push(`world.html: HTTP ${r.status()}: ${r.url()}`); });
    const done = new Promise((resolve) => page.on('console', (m) => {
      if (m.type() === 'error') problems.push(`world.html: console error: ${m.text()}`);
      const s = /^meshmux: (\w+)/.exec(m.text());
      if (s) resolve(s[1]);
    }));
    await page.goto(url2 + 'world.html');
    let timer;
    const timeout = new Promise((resolve) => { timer = setTimeout(() => resolve('timeout'), 240000); });
    pageEnd = await Promise.race([done, timeout]);
    clearTimeout(timer);
  } finally {
    await close2();
    server2.kill();
  }
}

const check = (ok, what) => { if (!ok) problems.push(what); };
check(pageEnd === 'complete', `world.html ended "${pageEnd}", not "complete"`);
{
  // The cubes' packages have whole (Draco-coded) bases: world.html played them above.
  const wj = JSON.parse(fs.readFileSync(path.join(outroot, 'world.json'), 'utf8'));
  check(wj.packages.length === 4, `world.json holds ${wj.packages.length} packages, not 4`);
  for (const n of ['cube1', 'cube2']) {
    const b = fs.readFileSync(path.join(outroot, n, 'model.mmxp'));
    const deflated = b.subarray(12, 12 + b.readUInt32LE(8));
    let table;
    try { table = JSON.parse(zlib.inflateSync(deflated)); } catch { table = JSON.parse(zlib.inflateRawSync(deflated)); }
    check(table.base.whole === true, `${n}: the base is not whole (${JSON.stringify(table.base)})`);
  }
}
if (log) {
  check(log.errors.length === 1 && /^gone: .*gone\/model\.mmxp/.test(log.errors[0]),
    `the missing package is reported once, by name: ${JSON.stringify(log.errors)}`);
  check(log.opened && log.opened.a === 0 && log.opened.c === 0, `bases only after open(): ${JSON.stringify(log.opened)}`);
  check(log.waiting !== null, 'no "waiting" while only the package behind the camera was left');
  if (log.waiting) {
    check(log.waiting.c === 0, `the package behind the camera got ${log.waiting.c} chunks before the camera turned`);
    check(log.waiting.a > 0 && log.waiting.b > 0, `the packages ahead streamed first: ${JSON.stringify(log.waiting)}`);
  }
  check(log.final && log.final.c > 0, `the package behind streamed once the camera turned: ${JSON.stringify(log.final)}`);
  check(log.stats && log.stats.state === 'complete', `the world ended ${log.stats && log.stats.state}, not complete`);
  check(log.stats && log.stats.chunksApplied === log.stats.chunkCount, `chunks ${JSON.stringify(log.stats)}`);
  check(log.stats && log.stats.levelTexels > 0 && log.stats.texels === log.stats.levelTexels && log.stats.uploadingAtEnd === 0,
    `at "complete" every package shows its largest texture level: ${JSON.stringify(log.stats)}`);
  check(log.stats && log.stats.requestsPeak <= 3, `${log.stats && log.stats.requestsPeak} requests in flight (at most 3)`);
  // Decoding off the main thread, in the world's shared pool (not a worker per package).
  check(log.stats && log.stats.decoder === 'worker', `decoded on the ${log.stats && log.stats.decoder}`);
  check(log.stats && log.stats.workersStarted <= 2 && log.stats.poolSize === 2,
    `${log.stats && log.stats.workersStarted} workers for 3 packages (pool of ${log.stats && log.stats.poolSize}, asked 2)`);
  const b = log.budget;
  check(b && b.end, `the budget world did not end: ${JSON.stringify(b)}`);
  if (b && b.end) {
    check(b.over.length === 0, `the budget was passed at ${b.over.length} chunks: ${JSON.stringify(b.over.slice(0, 3))} (budget ${b.triangles} triangles, ${b.texels} texels)`);
    check(b.end.triangles <= b.triangles && b.end.texels <= b.texels, `the budget world ended past its budget: ${JSON.stringify(b)}`);
    check(b.end.triangles > b.baseTriangles, `the budget world refined nothing: ${JSON.stringify(b)}`);
    check(b.end.state === 'stopped' && b.end.chunksApplied < b.end.chunkCount, `the budget did not stop the world: ${JSON.stringify(b.end)}`);
  }
}
for (const p of problems) console.error(`FAIL: ${p}`);
console.log(`world: ${JSON.stringify(log)}; world.html: ${pageEnd}`);
process.exitCode = problems.length ? 1 : 0;
