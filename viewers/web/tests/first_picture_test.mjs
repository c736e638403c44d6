// Time to the first picture on a slow link, and what a repeat visit costs: converts a model, serves
// the output with `meshmux serve`, and in Debian's headless chromium (through playwright-core),
// with the network throttled by the DevTools protocol (Network.emulateNetworkConditions), measures
// from navigation start:
//   - the stream viewer (index.html) until the model is on screen (state "base");
//   - a plain three.js page (GLTFLoader + DRACOLoader, the same three.js files from the same
//     server, written here as glb.html) until model.glb is on screen;
// each in a fresh browser profile (a first visit), then the viewer again in the same profile (a
// repeat visit) with the bytes each visit transferred (headers included).
// Checks: viewer ≤ --max-seconds and ≤ --max-ratio × the plain page; repeat < --max-repeat of
// the first visit's bytes. Prints the figures and writes WORK/first_picture.json.
//
// usage: node first_picture_test.mjs --meshmux BIN --model FILE --work DIR [--mbps 1.5]
//        [--latency 40] [--max-seconds 5] [--max-ratio 0.5] [--max-repeat 0.05]
//        [--chromium /usr/bin/chromium] [--no-check]
// Exit: 0 pass, 1 fail, 77 skipped (no chromium / model missing: said on stderr).
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { launch, opt, serve, skip } from './harness.mjs';

const args = process.argv.slice(2);
const meshmux = opt('--meshmux');
const work = opt('--work');
const model = opt('--model');
const chromiumPath = opt('--chromium', '/usr/bin/chromium');
const mbps = Number(opt('--mbps', '1.5'));
const latency = Number(opt('--latency', '40'));
const maxSeconds = Number(opt('--max-seconds', '5'));
const maxRatio = Number(opt('--max-ratio', '0.5'));
const maxRepeat = Number(opt('--max-repeat', '0.05'));
const check = !args.includes('--no-check');

function fail(message) {
  console.error(`FAIL: ${message}`);
  process.exitCode = 1;
}
if (!meshmux || !work || !model) {
  console.error('usage: node first_picture_test.mjs --meshmux BIN --model FILE --work DIR');
  process.exit(2);
}
if (!fs.existsSync(chromiumPath)) skip(`${chromiumPath} not installed (apt-get install chromium)`);
if (!fs.existsSync(model)) skip(`${model} not found (../shared/models absent)`);

fs.rmSync(work, { recursive: true, force: true });
fs.mkdirSync(work, { recursive: true });
const out = path.join(work, 'out');
const r = spawnSync(meshmux, ['convert', model, '-o', out, '-q'], { encoding: 'utf8' });
if (r.status !== 0) throw new Error(`meshmux convert exited ${r.status}: ${r.stderr}`);

// The plain page: what a site does without meshmux (three.js's loaders, model.glb in one go),
// with the three.js files convert wrote (under viewer/three-r<release>/).
const three = fs.readdirSync(path.join(out, 'viewer')).find((n) => /^three-r\d+$/.test(n));
if (!three) throw new Error('convert wrote no viewer/three-r<release>/ folder');
fs.writeFileSync(path.join(out, 'glb.html'), `<!doctype html>
<html><head><meta charset="utf-8"><link rel="icon" href="data:,">
<script type="importmap">
{"imports": {"three": "./viewer/${three}/three.module.js", "three/addons/": "./viewer/${three}/addons/"}}
</script>
<script type="module">
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
const renderer = new THREE.WebGLRenderer({ canvas: document.getElementById('view') });
renderer.setSize(640, 480, false);
const draco = new DRACOLoader().setDecoderPath('./viewer/${three}/addons/libs/draco/gltf/');
new GLTFLoader().setDRACOLoader(draco).load('./model.glb', (gltf) => {
  const scene = new THREE.Scene();
  scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 2), gltf.scene);
  const box = new THREE.Box3().setFromObject(gltf.scene);
  const camera = new THREE.PerspectiveCamera(45, 4 / 3, 0.01, 1000);
  const c = box.getCenter(new THREE.Vector3()), r = box.getSize(new THREE.Vector3()).length();
  camera.position.set(c.x, c.y, c.z + r * 1.2);
  camera.lookAt(c);
  renderer.render(scene, camera);
  requestAnimationFrame(() => { window.shownAt = performance.now(); document.body.dataset.state = 'base'; });
}, undefined, (e) => { document.body.dataset.state = 'error'; console.error(String(e)); });
</script></head>
<body data-state="loading"><canvas id="view" width="640" height="480"></canvas></body></html>
`);

const { server, url } = await serve(meshmux, out);

const problems = [];
// One browser profile: `visits` loads of `page` in it, each throttled; per visit the time to
// the first picture (ms from navigation start) and the bytes transferred.
async function visits(pageName, count) {
  const { context, close: closeBrowser } = await launch(work, chromiumPath);
  const results = [];
  try {
    const page = context.pages()[0] || (await context.newPage());
    page.on('pageerror', (e) => problems.push(`${pageName}: page error: ${e.message}`));
    page.on('console', (m) => {
      if (m.type() === 'error') problems.push(`${pageName}: console error: ${m.text()}`);
    });
    const cdp = await context.newCDPSession(page);
    await cdp.send('Network.enable');
    await cdp.send('Network.emulateNetworkConditions', {
      offline: false, latency, downloadThroughput: (mbps * 1e6) / 8, uploadThroughput: (mbps * 1e6) / 8,
    });
    let bytes = 0;
    cdp.on('Network.loadingFinished', (e) => { bytes += e.encodedDataLength; });
    for (let v = 0; v < count; ++v) {
      bytes = 0;
      await page.goto(url + pageName, { waitUntil: 'commit' });
      // (document.body is null while the head is parsed: its scripts run first.)
      await page.waitForFunction(() => document.body && ['base', 'streaming', 'complete', 'stopped', 'error']
        .includes(document.body.dataset.state), null, { timeout: 120000, polling: 'raf' });
      const shown = await page.evaluate(() => window.shownAt ?? performance.now());
      const state = await page.evaluate(() => document.body.dataset.state);
      if (state === 'error') problems.push(`${pageName}: the page ended in error`);
      // Let the page finish what it fetches (the stream plays on), so the bytes are the visit's.
      await page.waitForFunction(() => !['loading', 'base', 'streaming'].includes(document.body.dataset.state)
        || window.shownAt !== undefined, null, { timeout: 300000, polling: 200 });
      await page.waitForLoadState('networkidle', { timeout: 300000 }).catch(() => {});
      results.push({ seconds: shown / 1000, bytes });
    }
  } finally {
    await closeBrowser();
  }
  return results;
}

const result = { model, mbps, latency };
try {
  const [first, repeat] = await visits('index.html', 2);
  const [plain] = await visits('glb.html', 1);
  Object.assign(result, {
    viewer_seconds: first.seconds, plain_seconds: plain.seconds,
    ratio: first.seconds / plain.seconds, first_visit_bytes: first.bytes,
    repeat_visit_bytes: repeat.bytes, repeat_share: repeat.bytes / first.bytes,
    repeat_seconds: repeat.seconds, plain_bytes: plain.bytes,
  });
  console.log(`at ${mbps} Mbit/s, ${latency} ms: first picture ${first.seconds.toFixed(2)} s ` +
    `(model.glb page ${plain.seconds.toFixed(2)} s, ratio ${result.ratio.toFixed(2)}); ` +
    `repeat visit ${repeat.bytes} of ${first.bytes} bytes (${(100 * result.repeat_share).toFixed(2)}%), ` +
    `picture in ${repeat.seconds.toFixed(2)} s`);
  if (check) {
    if (first.seconds > maxSeconds) fail(`first picture after ${first.seconds.toFixed(2)} s (limit ${maxSeconds} s)`);
    if (result.ratio > maxRatio) fail(`first picture at ${result.ratio.toFixed(2)}× the model.glb page's (limit ${maxRatio})`);
    if (result.repeat_share >= maxRepeat) fail(`a repeat visit transfers ${(100 * result.repeat_share).toFixed(2)}% of the first's bytes (limit ${100 * maxRepeat}%)`);
  }
  for (const p of problems) fail(p);
} finally {
  server.kill();
}
fs.writeFileSync(path.join(work, 'first_picture.json'), JSON.stringify(result, null, 2));
