// The world bench (docs/ARCHITECTURE.md "Targets": many packages as one world): every model of a
// folder batch-converted (`meshmux batch`, its world.json: a grid), then played in headless
// chromium along one recorded camera path over one throttled link (throttle.mjs: the page's and
// its workers' requests share it, 20 ms latency), four ways:
//   world        MeshmuxWorld (world.js): one plan over every package, by gain on screen
//   independent  (a) every package's MeshmuxStream playing its own order at once
//   sequential   (b) packages one after another, each base then its chunks
//   gltf         (c) GLTFLoader loading every model.glb at once
//   open         the world's bases alone from the path's first camera, the page drawing no
//                frame until every base has joined the scene: "every base shown" is when the
//                first frame with all of them is finished (on software GL that frame compiles
//                every program's variants: --split takes it apart)
// Every 250 ms the page renders the path's camera (320x240) and keeps the pixels; once all is
// loaded it renders the same cameras again (the finished world) and measures each sample's mean
// squared error against its own final frame. Prints per bandwidth the area under that error over
// time (lower is better), the mean PSNR, when every base was shown, when all was loaded, and the
// main-thread stalls while loading outside the bench's own renders. Progress on stderr.
// Each mode decodes as its library does by default (MeshmuxStream / MeshmuxWorld: in workers).
// --trace: each run is also traced (main_thread.mjs), and a second table says whose the page's
// tasks over 16 ms were while loading: the library's (meshmux's scripts, or three's loaders), the
// bench's frames, the browser's commits of them, or other; the trace slows the page, so its
// runs' areas are not to be compared with untraced ones. Each traced run's tasks over 16 ms go
// to WORK/tasks-MBIT-MODE-RUN.json (owner, ms, s after the start, the library's busiest functions).
//
// usage: node bench/world.mjs --meshmux BIN [--models DIR | --corpus N] [--work DIR]
//        [--mbit 10[,1.5,50]] [--seconds 40] [--modes world,independent,sequential,gltf,open]
//        [--repeat K] [--trace] [--split] [--chromium PATH]
// --corpus N: N models spread evenly over ../shared/corpus/models.tsv instead of the shared
// models; --repeat K: K rounds of every mode, the modes interleaved, each figure the median.
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { launch, opt, serve } from '../viewers/web/tests/harness.mjs';
import { startTrace, taskOwners } from './main_thread.mjs';
import { throttle } from './throttle.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const meshmux = opt('--meshmux', path.join(here, '..', 'build', 'meshmux'));
const corpus = Number(opt('--corpus', '0'));  // > 0: that many corpus models instead of --models
const shared = path.join(here, '..', '..', 'shared');
const models = opt('--models', corpus > 0 ? path.join(shared, 'corpus') : path.join(shared, 'models'));
const work = path.resolve(opt('--work', path.join(here, '..', 'build', 'bench_world')));
const rates = opt('--mbit', '10').split(',').map(Number);
const seconds = Number(opt('--seconds', '40'));
const modes = opt('--modes', 'world,independent,sequential,gltf').split(',');
const repeat = Math.max(1, Number(opt('--repeat', '1')) || 1);
const chromiumPath = opt('--chromium', '/usr/bin/chromium');
const tracing = process.argv.includes('--trace');
// --split (mode open): the first frame taken apart: the bases' textures uploaded, each package
// drawn alone (its programs' first draws: software GL compiles them then), then the whole frame.
const split = process.argv.includes('--split');
// The loading libraries' scripts: meshmux's modules, three's loaders and decoders.
const LIBRARY = /\/viewer\/(world|meshmux|stream_\w+|package_reader|view_plan|world_plan|materials|lighting|upload|gltf_plugins|worker_client)\.js|\/addons\/(loaders|libs)\//;
if (!fs.existsSync(models)) { console.error(`SKIPPED: ${models} not found`); process.exit(77); }
if (!fs.existsSync(chromiumPath)) { console.error(`SKIPPED: ${chromiumPath} not installed`); process.exit(77); }

// 1. The world: every model converted (resumable: a second run reuses what is done).
const outroot = path.join(work, 'outroot');
fs.mkdirSync(work, { recursive: true });
// --corpus N: N uploads spread evenly over the corpus's list (models.tsv, its order), each its
// folder as uploaded (batch finds the model file inside; folders holding several model files
// are passed over, as batch would need to be told which); those that do not stream (or
// convert) are left out of the world.
let inputs = models;
if (corpus > 0) {
  const modelFiles = (dir) => fs.readdirSync(dir, { recursive: true }).filter((f) => /\.(gltf|glb|dae|zip)$/i.test(f)).length;
  const rows = fs.readFileSync(path.join(models, 'models.tsv'), 'utf8').trim().split('\n').slice(1)
    .map((l) => l.split('\t')).filter(([folder]) => modelFiles(path.join(models, folder)) === 1);
  const n = Math.min(corpus, rows.length), picked = [];
  for (let k = 0; k < n; k++) picked.push(rows[Math.floor((k * rows.length) / n)]);
  inputs = path.join(work, 'corpus.list');
  fs.writeFileSync(inputs, picked.map(([folder]) => path.join(models, folder)).join('\n') + '\n');
}
console.error(`world bench: converting ${inputs} into ${outroot}`);
const b = spawnSync(meshmux, ['batch', inputs, '-o', outroot, '-q', '--jobs', '2'], { encoding: 'utf8' });
if (!fs.existsSync(path.join(outroot, 'world.json'))) { console.error(b.stderr); process.exit(1); }
const world = JSON.parse(fs.readFileSync(path.join(outroot, 'world.json'), 'utf8'));
const three = fs.readdirSync(path.join(outroot, 'viewer')).find((f) => f.startsWith('three-'));
console.error(`world bench: ${world.packages.length} packages, ${world.placements.length} placements`);

// 2. The page: one run of one mode, its result in window.__bench.
fs.writeFileSync(path.join(outroot, 'bench_world.html'), `<!doctype html>
<html><head><meta charset="utf-8">
<script type="importmap">{"imports": {"three": "./viewer/${three}/three.module.js", "three/addons/": "./viewer/${three}/addons/"}}</script>
</head><body style="margin:0"><script type="module">
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
import { MeshmuxStream, addStreamLighting } from './viewer/meshmux.js';
import { MeshmuxWorld } from './viewer/world.js';
const q = new URLSearchParams(location.search), mode = q.get('mode'), T = Number(q.get('seconds'));
const W = 320, H = 240, STEP = 250;
const renderer = new THREE.WebGLRenderer({ preserveDrawingBuffer: true });
renderer.setSize(W, H);
document.body.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x202124);
const camera = new THREE.PerspectiveCamera(45, W / H, 0.01, 1000);
const world = await (await fetch('world.json')).json();
// The world's box, and the path: one turn around it, closing in half way, over T seconds.
const box = new THREE.Box3(), one = new THREE.Box3();
for (const pl of world.placements) {
  const p = world.packages[pl.package];
  one.set(new THREE.Vector3(...p.bounds.slice(0, 3)), new THREE.Vector3(...p.bounds.slice(3)));
  box.union(one.applyMatrix4(new THREE.Matrix4().fromArray(pl.matrix)));
}
const centre = box.getCenter(new THREE.Vector3()), radius = box.getSize(new THREE.Vector3()).length() / 2;
camera.near = radius / 1000; camera.far = radius * 20; camera.updateProjectionMatrix();
function pose(t) {
  const a = 2 * Math.PI * t / T, r = radius * (1.6 - 1.1 * Math.sin(Math.PI * Math.min(1, t / T)));
  camera.position.set(centre.x + r * Math.cos(a), centre.y + 0.5 * r, centre.z + r * Math.sin(a));
  camera.lookAt(centre);
  camera.updateMatrixWorld();
}
pose(0);
// Main-thread stalls: a 4 ms timer's lateness (the longtask API starts at 50 ms; this sees a
// task of 16 ms, and is an upper bound on the longest task where short ones queue). Stalls that
// hold one of the bench's own frame renders are the bench's; the rest are the loading's
// (meshmux, GLTFLoader, the browser's decoding on the page).
const long = [], renders = [];
let tick = performance.now();
(function probe() {
  const t = performance.now();
  if (t - tick - 4 > 16) long.push([tick + 4, t - tick - 4]);
  tick = t;
  if (!window.__bench) setTimeout(probe, 4);
})();
// One lighting for every mode, set up (its environment map made, an empty frame drawn) before
// the clock starts: lighting that arrived with the first package would rebuild every shader
// already compiled, in whichever mode it happened. The GPU finishes that frame before the clock
// starts (a pixel read back): on software GL its environment map takes ~3 s of the GPU's time,
// which the first sample's read-back then waited for, the page's thread with it.
addStreamLighting({ physical: true, environment: 1, lightIntensity: 2, lightDirection: [0.5, 1, 0.8], lightFollowsCamera: true }, scene, camera, renderer);
renderer.render(scene, camera);
{
  const gl = renderer.getContext();
  gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
}
performance.mark('bench-start');
const t0 = performance.now(), now = () => (performance.now() - t0) / 1000;
let basesAt = NaN, doneAt = NaN;
let received = () => 0;  // bytes the mode's streams received so far (meshmux modes)
const placeAll = (object, pkg) => world.placements.forEach((pl, k) => {
  if (pl.package !== pkg) return;
  const g = new THREE.Group();
  g.matrixAutoUpdate = false;
  g.matrix.fromArray(pl.matrix);
  g.add(object.parent ? object.clone() : object);
  scene.add(g);
});
const baseTimes = [];
async function load() {
  if (mode === 'open') {
    const w = new MeshmuxWorld('world.json', { renderer, camera });
    received = () => w.stats.bytesReceived;
    w.addEventListener('base', (e) => baseTimes.push([now(), e.detail && e.detail.package]));
    scene.add(w.object);
    const gl = renderer.getContext(), px = new Uint8Array(4);
    await w.open();
    if (q.get('split')) {
      const texs = new Set(); let texels = 0;
      scene.traverse((o) => { if (o.material) for (const m of [o.material].flat()) for (const v of Object.values(m)) if (v && v.isTexture && !texs.has(v)) { texs.add(v); texels += (v.image?.width || 0) * (v.image?.height || 0); } });
      const a = now();
      for (const t of texs) renderer.initTexture(t);
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
      const b = now();
      renderer.compile(scene, camera);
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
      const c0 = now();
      const groups = w.packages.map((p) => [p.name, p.placements.map((pl) => pl.group).filter(Boolean)]);
      for (const [, gs] of groups) for (const g of gs) g.visible = false;
      const per = [];
      for (const [name, gs] of groups) {
        for (const g of gs) g.visible = true;
        const a0 = now();
        renderer.render(scene, camera);
        gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
        per.push([now() - a0, name]);
        for (const g of gs) g.visible = false;
      }
      for (const [, gs] of groups) for (const g of gs) g.visible = true;
      per.sort((x, y) => y[0] - x[0]);
      console.log('split: one package at a time ' + (now() - c0).toFixed(2) + ' s, programs ' + renderer.info.programs.length + ': ' + per.slice(0, 12).map(([t, n]) => n + ' ' + t.toFixed(2)).join(', '));
      const c = now();
      renderer.render(scene, camera);
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
      const d = now();
      renderer.render(scene, camera);
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
      console.log('split: opened ' + a.toFixed(2) + ' s, ' + texs.size + ' textures ' + (texels / 1e6).toFixed(1) + ' Mtexels up ' + (b - a).toFixed(2) + ' s, compile ' + (c - b).toFixed(2) + ' s, first frame ' + (d - c).toFixed(2) + ' s, second ' + (now() - d).toFixed(2) + ' s');
    }
    renderer.render(scene, camera);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
    basesAt = now();
    return;
  }
  if (mode === 'world') {
    const w = new MeshmuxWorld('world.json', { renderer, camera });
    received = () => w.stats.bytesReceived;
    scene.add(w.object);  // each base shows as it arrives
    await w.open();
    basesAt = now();
    await w.play();
    return;
  }
  const urls = world.packages.map((p) => p.url);
  if (mode === 'gltf') {
    const loader = new GLTFLoader().setMeshoptDecoder(MeshoptDecoder)
      .setDRACOLoader(new DRACOLoader().setDecoderPath('./viewer/${three}/addons/libs/draco/gltf/'));
    let n = 0;
    await Promise.all(urls.map(async (u, i) => {
      try { placeAll((await loader.loadAsync(u.replace(/model\\.mmxp$/, 'model.glb'))).scene, i); } catch (e) { console.log('gltf: ' + u + ': ' + e.message); }
      if (++n === urls.length) basesAt = now();
    }));
    return;
  }
  const streams = urls.map((u) => new MeshmuxStream(u, { renderer, camera }));
  received = () => streams.reduce((s, x) => s + x.stats.bytesReceived, 0);
  if (mode === 'independent') {
    let n = 0;
    await Promise.all(streams.map(async (s, i) => {
      try {
        placeAll(await s.open(), i);
        if (++n === streams.length) basesAt = now();
        await s.play();
      } catch (e) { console.log('stream: ' + e.message); }
    }));
    return;
  }
  for (let i = 0; i < streams.length; i++) {  // sequential
    try {
      placeAll(await streams[i].open(), i);
      await streams[i].play();
    } catch (e) { console.log('stream: ' + e.message); }
  }
  basesAt = now();  // the last base came after every earlier package's chunks
}
// Samples along the path while loading (and until T).
const samples = [];
const grab = () => {
  const px = new Uint8Array(W * H * 4), r0 = performance.now();
  renderer.render(scene, camera);
  const gl = renderer.getContext();
  gl.readPixels(0, 0, W, H, gl.RGBA, gl.UNSIGNED_BYTE, px);
  renders.push([r0, performance.now()]);
  return px;
};
let finished = false;
const loading = load().then(() => { doneAt = now(); finished = true; performance.mark('bench-loaded'); });
for (let t = 0; t <= (mode === 'open' ? -1 : T);) {  // the area counts the path; what is left then loads at full speed
  while (now() < t) await new Promise((r) => setTimeout(r, Math.max(1, (t - now()) * 1000)));
  pose(t);
  samples.push({ t, px: grab(), bytes: received() });
  // The next sample on the 250 ms grid after this one's frame: a frame that took longer than a
  // step (a large world on software GL) skips the samples it overran instead of queueing them.
  t = Math.max(t + STEP / 1000, Math.ceil(now() / (STEP / 1000)) * (STEP / 1000));
}
window.__unthrottle = true;
// The finished world is the reference: loading gets 10 minutes past the path to finish. The
// world plans from the camera, and what the path's last pose does not see would wait for a turn
// that never comes: it finishes from far enough to see the whole grid.
if (mode === 'world') {
  camera.position.set(centre.x, centre.y + 2 * radius, centre.z + 3 * radius);
  camera.lookAt(centre);
  camera.updateMatrixWorld();
}
let unfinished = false;
await Promise.race([loading, new Promise((r) => setTimeout(r, 600000))]);
if (!finished) unfinished = true;
// The finished world from the same cameras; each sample's error counts until the next sample.
let area = 0, psnr = 0;
const errors = [];
for (let k = 0; k < samples.length; k++) {
  pose(samples[k].t);
  const ref = grab(), px = samples[k].px;
  let se = 0;
  for (let i = 0; i < px.length; i += 4)
    for (let c = 0; c < 3; c++) { const d = (px[i + c] - ref[i + c]) / 255; se += d * d; }
  const mse = se / (W * H * 3);
  const dt = (k + 1 < samples.length ? samples[k + 1].t : T) - samples[k].t;
  samples[k].dt = dt;
  errors.push(mse);
  area += mse * dt;
  psnr += (mse > 0 ? -10 * Math.log10(mse) : 100) * dt;
}
const loadingEnd = t0 + doneAt * 1000;
const loadingTasks = long.filter(([s, d]) => s < loadingEnd && !renders.some(([a, b]) => a < s + d && b > s)).map(([, d]) => d);
const renderMs = renders.slice(0, samples.length).map(([a, b]) => b - a).sort((a, b) => a - b);
window.__bench = { mode, unfinished, renderMs: renderMs[renderMs.length >> 1], samples: samples.length,
  times: samples.map((s) => s.t), bytes: samples.map((s) => s.bytes), area, psnr: psnr / T, basesAt, doneAt, longMax: loadingTasks.length ? Math.max(...loadingTasks) : 0,
  longCount: loadingTasks.length, errors, baseTimes };
console.log('bench-world: done');
</script></body></html>
`);

// 3. Every mode at every rate, each in a fresh browser profile (no cache between runs).
const { server, url: direct } = await serve(meshmux, outroot);
const results = {};
try {
  for (const mbit of rates) for (let round = 0; round < repeat; round++) {
    for (const mode of modes) {
      const { context, close } = await launch(work, chromiumPath, { width: 400, height: 300 });
      const link = await throttle(direct, { bytesPerSecond: (mbit * 1e6) / 8, latencyMs: 20 });
      const url = link.url;
      try {
        const page = context.pages()[0] || (await context.newPage());
        page.on('console', (m) => { if (/^(gltf|stream|split):/.test(m.text())) console.error(`  ${mode}: ${m.text()}`); });
        const done = new Promise((resolve) => page.on('console', (m) => { if (m.text() === 'bench-world: done') resolve(); }));
        let trace = null;
        if (tracing) {  // the page's origin first: the bench page then runs in the traced renderer
          await page.goto(`${url}world.json`);
          trace = await startTrace(await context.newCDPSession(page));
        }
        await page.goto(`${url}bench_world.html?mode=${mode}&seconds=${seconds}${split ? '&split=1' : ''}`);
        // Past the path, the rest loads at full speed (only the references need it).
        const lift = setInterval(async () => {
          if (await page.evaluate(() => window.__unthrottle === true).catch(() => false)) {
            clearInterval(lift);
            link.setRate(Infinity);
          }
        }, 500);
        await done;
        clearInterval(lift);
        const r = await page.evaluate(() => window.__bench);
        if (trace) {
          const { events, profile } = await trace.stop();
          r.tasks = taskOwners(events, profile, { start: 'bench-start', end: 'bench-loaded', library: LIBRARY, frameFunctions: ['grab'] });
          const lib = r.tasks.tasks.filter((x) => x.owner === 'library').sort((a, b) => b.ms - a.ms).slice(0, 5);
          // Every task over 16 ms, with its owner and the library's busiest functions, for a closer look.
          const dump = path.join(work, `tasks-${mbit}-${mode}-${((results[mbit] || {})[mode] || []).length}.json`);
          fs.writeFileSync(dump, JSON.stringify(r.tasks.tasks, null, 1));
          console.error(`world bench: ${mbit} Mbit/s ${mode}: longest library tasks ${lib.map((x) => `${x.ms.toFixed(0)} ms (thread ${x.cpuMs === null ? '?' : x.cpuMs.toFixed(0)} ms) at ${x.at.toFixed(1)} s (${x.top.join(', ')})`).join('; ') || 'none'}`);
        }
        ((results[mbit] ||= {})[mode] ||= []).push(r);
        if (mode === 'open') {
          const at = [...r.baseTimes].sort((x, y) => x[0] - y[0]);
          console.error(`world bench: ${mbit} Mbit/s open: ${at.length} bases, half by ${at[(at.length - 1) >> 1][0].toFixed(2)} s, the last joined ${at[at.length - 1][0].toFixed(2)} s, every base drawn ${r.basesAt.toFixed(2)} s; the last four: ${at.slice(-4).map(([t, n]) => `${n} ${t.toFixed(2)}`).join(', ')}`);
          continue;
        }
        console.error(`world bench: ${mbit} Mbit/s ${mode}: area ${r.area.toFixed(4)}, PSNR ${r.psnr.toFixed(1)} dB, bases ${r.basesAt.toFixed(1)} s, loaded ${r.doneAt.toFixed(1)} s, frame render ${r.renderMs.toFixed(0)} ms, ${r.samples} frames${r.unfinished ? ', NOT FINISHED (its last state is the reference)' : ''}, MB at 5 s marks ${[5, 10, 15, 20, 25, 30].map((m) => { const k = r.times.findLastIndex((t) => t <= m); return k >= 0 ? (r.bytes[k] / 1e6).toFixed(1) : '–'; }).join(' ')}, area per 5 s ${r.errors.reduce((o, e, k) => { const end = k + 1 < r.times.length ? r.times[k + 1] : seconds; const b = Math.min(5, Math.floor(r.times[k] / 5)); o[b] = (o[b] || 0) + e * (end - r.times[k]); return o; }, []).map((x) => x.toFixed(3)).join(' ')}`);
      } finally {
        await close();
        await link.close();
      }
    }
  }
} finally {
  server.kill();
}

// 4. The tables.
const f = (x, d = 2) => (Number.isFinite(x) ? x.toFixed(d) : '–');
const median = (xs) => { const v = xs.filter(Number.isFinite).sort((a, b) => a - b); return v.length ? (v[(v.length - 1) >> 1] + v[v.length >> 1]) / 2 : NaN; };
// A mode's runs as one row: each figure the median over the runs (the areas' range beside).
const summary = (runs) => runs && {
  area: median(runs.map((r) => r.area)), areas: runs.map((r) => r.area), psnr: median(runs.map((r) => r.psnr)),
  basesAt: median(runs.map((r) => r.basesAt)), doneAt: median(runs.map((r) => r.doneAt)),
  unfinished: runs.filter((r) => r.unfinished).length,
  longCount: median(runs.map((r) => r.longCount)), longMax: Math.max(...runs.map((r) => r.longMax)) };
console.log(`# World bench\n\n${world.packages.length} packages of ${corpus > 0 ? `${corpus} corpus uploads` : models}, ${repeat} run(s) of each mode interleaved (medians), one camera path of ${seconds} s (a turn around the grid, closing in), frames 320x240 every 250 ms against the finished world from the same camera; chromium headless, software GL.\n`);
for (const mbit of rates) {
  const rs = Object.fromEntries(Object.entries(results[mbit] || {}).map(([m, runs]) => [m, summary(runs)])), ref = rs.independent;
  console.log(`## ${mbit} Mbit/s\n\n| order | area under error (s) | vs (a) | mean PSNR dB (exact frames 100) | every base shown s | all loaded s (full speed after the path) | main-thread stalls > 16 ms outside the bench's renders, while loading (longest ms) |\n|---|---:|---:|---:|---:|---:|---:|`);
  for (const mode of modes) {
    const r = rs[mode];
    if (!r) continue;
    const vs = ref && ref.area > 0 ? `${f((r.area / ref.area - 1) * 100, 1)}%` : '–';
    const range = r.areas.length > 1 ? ` (${f(Math.min(...r.areas), 4)}-${f(Math.max(...r.areas), 4)})` : '';
    const note = r.unfinished ? ` (${r.unfinished} run(s) did not finish in 10 min past the path)` : '';
    console.log(`| ${mode}${note} | ${f(r.area, 4)}${range} | ${vs} | ${f(r.psnr, 1)} | ${f(r.basesAt, 1)} | ${f(r.doneAt, 1)} | ${r.longCount} (${f(r.longMax, 0)}) |`);
  }
  console.log('');
  if (!tracing) continue;
  // Whose the tasks over 16 ms were, while loading (the runs' medians; the longest over all runs).
  // A task's wall time holds the time its thread waited for a core (two cores shared with
  // software GL's threads, the workers and the bench's frames): its thread time (the trace's
  // tdur) is the page's own work in it, and the library's column says both.
  console.log(`Main-thread tasks over 16 ms while loading, by owner (traced runs): count, over 50 ms, longest ms; for the library also: tasks whose own thread time is over 16 ms, the longest thread time ms\n\n| order | library (meshmux / three's loaders) | library by thread time | the bench's frames | the browser's commits of them | other |\n|---|---:|---:|---:|---:|---:|`);
  for (const mode of modes) {
    const runs = (results[mbit] || {})[mode];
    if (!runs) continue;
    const cell = (owner) => {
      const os = runs.map((r) => (r.tasks && r.tasks.owners[owner]) || { tasks: 0, over50: 0, longest: 0 });
      return `${median(os.map((o) => o.tasks))}, ${median(os.map((o) => o.over50))}, ${f(Math.max(...os.map((o) => o.longest)), 0)}`;
    };
    const cpu = (owner) => {
      const os = runs.map((r) => (r.tasks && r.tasks.owners[owner]) || { cpuOver: 0, cpuLongest: 0 });
      return `${median(os.map((o) => o.cpuOver || 0))}, ${f(Math.max(...os.map((o) => o.cpuLongest || 0)), 0)}`;
    };
    console.log(`| ${mode} | ${cell('library')} | ${cpu('library')} | ${cell('frame')} | ${cell('commit')} | ${cell('other')} |`);
  }
  console.log('');
}
