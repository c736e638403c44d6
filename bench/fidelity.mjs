// Fidelity harness (docs/ARCHITECTURE.md "Fidelity"): appearance of meshmux's output judged against
// the ORIGINAL input by a renderer we did not write. For each model it runs `meshmux convert IN -o
// DIR --no-report`, then three.js (npm's, the version the viewer embeds) in Debian's headless
// chromium loads the original (GLTFLoader with DRACOLoader and the meshopt decoder; ColladaLoader
// for .dae), model.glb and base.glb, and renders each from the default camera and 4 more views, lit
// (its MeshStandardMaterials under RoomEnvironment through PMREM) and unlit (base colour × alpha
// only). It reports PSNR over the pixels either image covers (all views' pixels pooled), the share
// of surface area whose shading normal faces against its triangle's winding, and the normal-map
// angular error: the mean angle between the shading normals three.js lights with (normal maps
// applied) of the original and of model.glb, over the pixels both cover.
//
// usage: node bench/fidelity.mjs --meshmux BIN [--models DIR] [--work DIR] [--only NAME[,NAME]]
//          [--json FILE] [--size 256] [--chromium /usr/bin/chromium] [--check] [--dump]
//          [--require NAME[,NAME]] [--convert-args "--no-atlas ..."]
//   (--dump also writes views-normals.png: the shading normals of original and model.glb, and
//    views-normal-maps.png: the same with normal maps applied, and their angle, 8 levels per °)
// --check: exit 1 unless every model meets the targets (below) the table prints as "met".
// Exit 77 when chromium or the models are missing (said on stderr).
//
// Corpus mode (the sweep, bench/sweep.sh; docs/ARCHITECTURE.md "Targets", appearance and uploads):
//        node bench/fidelity.mjs --corpus DIR [--work DIR] [--jobs 2] [--legacy-input]
//          [--timeout 900] [--md FILE] [--tsv FILE] [--json FILE] [--only ...] [--require ...]
// reads DIR/models.tsv and converts each model as an upload, `meshmux convert DIR/FOLDER --main
// MAIN_FILE -o WORK/FOLDER` (the whole pipeline, report included; --legacy-input: `meshmux
// convert DIR/FOLDER/MAIN_FILE --allow-outside`, for a meshmux without --main), each under
// /usr/bin/time for its wall time and peak RSS, in a pool of --jobs processes (one thread each)
// running ahead of the judge (--jobs 0: one at a time, all threads, nothing beside the judge).
// Judged on model.glb: unlit ≥ 30 dB, lit ≥ 28 dB, coverage IoU ≥ 0.99, normals against winding
// ≤ the original's + 0.1% of the area. Writes WORK/sweep.md (summary line, table, misses grouped
// by cause), WORK/sweep.tsv and WORK/sweep.json; prints the markdown. Exit 77 when DIR is absent.
import { spawn, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import zlib from 'node:zlib';
import { chromium } from 'playwright-core';

const here = path.dirname(fileURLToPath(import.meta.url));
const root = path.resolve(here, '..');
const args = process.argv.slice(2);
const opt = (name, fallback) => {
  const i = args.lastIndexOf(name);  // the last wins: wrappers put their defaults first
  return i >= 0 && i + 1 < args.length ? args[i + 1] : fallback;
};
const meshmux = opt('--meshmux', path.join(root, 'build', 'meshmux'));
const corpusDir = opt('--corpus', '') ? path.resolve(opt('--corpus')) : null;  // corpus mode
const modelsDir = path.resolve(opt('--models', path.join(root, '..', 'shared', 'models')));
const work = path.resolve(opt('--work', path.join(root, 'build', corpusDir ? 'sweep' : 'fidelity')));
const only = (opt('--only', '') || '').split(',').filter(Boolean);
const jsonOut = opt('--json', path.join(work, corpusDir ? 'sweep.json' : 'fidelity.json'));
const size = Number(opt('--size', '256'));
const chromiumPath = opt('--chromium', '/usr/bin/chromium');
const check = args.includes('--check');
const convertArgs = (opt('--convert-args', '') || '').split(' ').filter(Boolean);  // extra convert options
// --require A,B: exit 1 unless these models meet the targets (the others are reported only).
const required = (opt('--require', '') || '').split(',').filter(Boolean);
const dump = args.includes('--dump');  // also write WORK/NAME/views-unlit.png (rows: original, model.glb, base.glb,
                                       // 4× |original − model.glb|) and views-lit.png
// Corpus mode only: where the report goes, how conversions run.
const mdOut = opt('--md', path.join(work, 'sweep.md'));
const tsvOut = opt('--tsv', path.join(work, 'sweep.tsv'));
const legacyInput = args.includes('--legacy-input');
const jobs = Math.max(0, Number(opt('--jobs', '2')));
const convertTimeout = Number(opt('--timeout', '900'));  // seconds per conversion; then killed
// A page call that takes longer is a harness error (a hung loader must not stall the sweep).
const pageTimeout = Number(opt('--page-timeout', '300'));
// docs/ARCHITECTURE.md "Targets": appearance ≥ 30 dB, unlit and lit (lit too on every model, with
// physically based maps or without); normals against winding ≤ 0.5% of the area.
const kMinUnlit = 30, kMinLit = 30, kMaxAgainst = 0.005;
// The same table's corpus targets: unlit ≥ 30 dB, lit ≥ 28 dB (goal 30), IoU ≥ 0.99, normals
// against winding ≤ the input's + 0.1% (of the area).
const kCorpus = { unlit: 30, lit: 28, iou: 0.99, againstMargin: 0.001 };

const skip = (m) => { console.error(`SKIPPED: ${m}`); process.exit(77); };
if (!fs.existsSync(chromiumPath)) skip(`${chromiumPath} not installed (apt-get install chromium)`);
if (corpusDir && !fs.existsSync(path.join(corpusDir, 'models.tsv')))
  skip(`${corpusDir}/models.tsv not found (../shared/corpus absent)`);
if (!corpusDir && !fs.existsSync(modelsDir)) skip(`${modelsDir} not found (../shared/models absent)`);
if (!fs.existsSync(meshmux)) { console.error(`${meshmux}: no meshmux binary (build first)`); process.exit(2); }
if (corpusDir && !legacyInput && !/--main\b/.test(spawnSync(meshmux, ['convert', '--help'], { encoding: 'utf8' }).stdout || '')) {
  console.error(`${meshmux}: convert has no --main (folder uploads): pass --legacy-input to convert the main files`);
  process.exit(2);
}

// One model per folder: its main file.
function sharedModels() {
  return fs.readdirSync(modelsDir).sort()
    .filter((d) => fs.statSync(path.join(modelsDir, d)).isDirectory() && (!only.length || only.includes(d)))
    .map((d) => {
      const file = fs.readdirSync(path.join(modelsDir, d)).sort().find((f) => /\.(glb|gltf|dae)$/i.test(f));
      return file ? { name: d, dir: path.join(modelsDir, d), file } : null;
    }).filter(Boolean);
}
// The corpus's models.tsv (header: folder, main_file, format, triangles, textures, bytes,
// features), in its order; features are the "; "-separated tags.
function corpusModels() {
  const [header, ...lines] = fs.readFileSync(path.join(corpusDir, 'models.tsv'), 'utf8').split('\n').filter((l) => l.trim());
  const columns = header.split('\t');
  return lines.map((line) => {
    const f = Object.fromEntries(line.split('\t').map((v, i) => [columns[i], v]));
    return { name: f.folder, dir: path.join(corpusDir, f.folder), file: f.main_file, format: f.format,
      triangles: Number(f.triangles), bytes: Number(f.bytes),
      features: (f.features || '').split(';').map((t) => t.trim()).filter(Boolean) };
  }).filter((m) => !only.length || only.includes(m.name));
}
const models = corpusDir ? corpusModels() : sharedModels();
const unknown = only.filter((n) => !models.some((m) => m.name === n));
if (unknown.length) console.error(`--only: no such model: ${unknown.join(', ')}`);

// Models the source says have physically based maps (an annotation in the table: lit PSNR is
// judged on every model).
function sourceMaps(m) {
  if (/\.dae$/i.test(m.file)) return false;
  const text = fs.readFileSync(path.join(m.dir, m.file)).toString('latin1');
  return /"(normalTexture|occlusionTexture|metallicRoughnessTexture|emissiveTexture)"/.test(text);
}

fs.mkdirSync(work, { recursive: true });
const types = { '.js': 'text/javascript', '.mjs': 'text/javascript', '.html': 'text/html', '.wasm': 'application/wasm',
  '.json': 'application/json', '.png': 'image/png', '.jpg': 'image/jpeg', '.jpeg': 'image/jpeg', '.webp': 'image/webp',
  '.glb': 'model/gltf-binary', '.gltf': 'model/gltf+json', '.dae': 'model/vnd.collada+xml' };
// The originals are served from where they are, so three.js finds their sibling files.
const mounts = { '/three/': path.join(root, 'node_modules', 'three'), '/page/': path.join(here, 'fidelity'),
  '/models/': modelsDir, '/out/': work };
if (corpusDir) mounts['/corpus/'] = corpusDir;
const server = http.createServer((req, res) => {
  const url = decodeURIComponent(new URL(req.url, 'http://x').pathname);
  const prefix = Object.keys(mounts).find((p) => url.startsWith(p));
  const file = prefix && path.resolve(mounts[prefix], '.' + url.slice(prefix.length - 1));
  if (!file || !file.startsWith(mounts[prefix]) || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
    res.writeHead(404); res.end(); return;
  }
  res.writeHead(200, { 'Content-Type': types[path.extname(file).toLowerCase()] || 'application/octet-stream' });
  fs.createReadStream(file).pipe(res);
});
await new Promise((r) => server.listen(0, '127.0.0.1', r));
const base = `http://127.0.0.1:${server.address().port}`;
// URL of a file under a mount: each path segment encoded (names with spaces, '#', non-ASCII).
const urlOf = (mount, ...parts) => mount + parts.join('/').split('/').map(encodeURIComponent).join('/');

const context = await chromium.launchPersistentContext(fs.mkdtempSync(path.join(work, 'chromium-')), {
  executablePath: chromiumPath, headless: true, viewport: { width: size, height: size },
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--no-first-run', '--disable-background-networking',
    '--disable-component-update', '--disable-sync', '--enable-unsafe-swiftshader'],
});
const pageErrors = [];
let page = null;
// (Re)opens the harness page: after a harness error the old one may be hung or crashed (an
// out-of-memory tab), and the next model must not inherit it.
async function openPage() {
  const fresh = page ? await context.newPage() : context.pages()[0] || (await context.newPage());
  if (page) await page.close().catch(() => {});
  page = fresh;
  page.on('pageerror', (e) => pageErrors.push(e.message));
  await page.goto(`${base}/page/index.html?size=${size}`);
  await page.waitForFunction(() => document.body.dataset.ready === '1', null, { timeout: 60000 });
}
await openPage();
// Calls window.fidelity[name](...params) in the page, at most pageTimeout seconds.
async function call(name, ...params) {
  let timer;
  const late = new Promise((_, reject) => {
    timer = setTimeout(() => reject(new Error(`page: ${name} took over ${pageTimeout} s`)), pageTimeout * 1000);
  });
  try {
    return await Promise.race([page.evaluate(([n, p]) => window.fidelity[n](...p), [name, params]), late]);
  } finally {
    clearTimeout(timer);
  }
}
const normalPrecision = await call('normalPrecision');

// The cameras: meshmux's default framing (fov 45°, bounding sphere filling 80% of the view)
// from the default direction and four more around the original's bounds.
const directions = [[1, 0.6, 1.4], [-1, 0.3, -1.2], [0.05, 1, 0.1], [1.2, -0.5, -0.3], [-0.3, 0.2, 1]];
function cameras(center, radius) {
  const fov = 45, half = Math.atan(0.8 * Math.tan((fov * Math.PI) / 360));
  const r = radius > 0 && Number.isFinite(radius) ? radius : 1, d = r / Math.sin(half);
  return directions.map((v) => {
    const l = Math.hypot(...v), u = v.map((x) => x / l);
    return { eye: center.map((c, i) => c + u[i] * d), target: center, up: Math.abs(u[1]) > 0.99 ? [0, 0, 1] : [0, 1, 0],
      fov, near: Math.max(d - 1.5 * r, d * 1e-3), far: d + 1.5 * r };
  });
}

// Pooled squared error over the pixels either image covers; also the coverage counts: each
// image's, both (∧) and either (∨), for the coverage IoU.
function accumulate(acc, a, b) {
  for (let i = 0; i < a.length; i += 4) {
    const ca = a[i + 3] > 0, cb = b[i + 3] > 0;
    acc.a = (acc.a || 0) + ca;
    acc.b = (acc.b || 0) + cb;
    acc.both = (acc.both || 0) + (ca && cb);
    if (!ca && !cb) continue;
    acc.either = (acc.either || 0) + 1;
    for (let c = 0; c < 3; ++c) { const d = a[i + c] - b[i + c]; acc.sum += d * d; }
    acc.n += 3;
  }
}
// A minimal RGBA PNG (filter 0 per row, one zlib stream): for looking at the renders.
function png(width, height, rgba) {
  const crcTable = new Int32Array(256).map((_, n) => {
    let c = n;
    for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    return c;
  });
  const crc = (buf) => { let c = -1; for (const b of buf) c = crcTable[(c ^ b) & 255] ^ (c >>> 8); return (c ^ -1) >>> 0; };
  const chunk = (type, data) => {
    const head = Buffer.alloc(8); head.writeUInt32BE(data.length, 0); head.write(type, 4, 'latin1');
    const tail = Buffer.alloc(4); tail.writeUInt32BE(crc(Buffer.concat([head.subarray(4), data])), 0);
    return Buffer.concat([head, data, tail]);
  };
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(width, 0); ihdr.writeUInt32BE(height, 4); ihdr[8] = 8; ihdr[9] = 6;
  const raw = Buffer.alloc((width * 4 + 1) * height);
  for (let y = 0; y < height; ++y) rgba.copy(raw, y * (width * 4 + 1) + 1, y * width * 4, (y + 1) * width * 4);
  return Buffer.concat([Buffer.from([137, 80, 78, 71, 13, 10, 26, 10]), chunk('IHDR', ihdr),
    chunk('IDAT', zlib.deflateSync(raw)), chunk('IEND', Buffer.alloc(0))]);
}
// Tiles images (each size², RGBA) into rows × columns, opaque black background.
function tile(images, columns) {
  const rows = Math.ceil(images.length / columns), w = columns * size, out = Buffer.alloc(w * rows * size * 4);
  images.forEach((im, k) => {
    const x0 = (k % columns) * size, y0 = Math.floor(k / columns) * size;
    for (let y = 0; y < size; ++y)
      for (let x = 0; x < size; ++x) {
        const s = (y * size + x) * 4, d = ((y0 + y) * w + x0 + x) * 4;
        for (let c = 0; c < 3; ++c) out[d + c] = im[s + c];
        out[d + 3] = 255;
      }
  });
  return png(w, rows * size, out);
}
// Pooled angle between the shading normals of two 'perturbed' renders (float RGBA: rgb the
// view-space normal, averaged where multisampled, a the coverage) over the pixels both cover;
// with `heat`, also an RGBA image of the angle (8 levels per degree, saturating at ~32°).
function accumulateAngles(acc, a, b, heat) {
  for (let i = 0; i < a.length; i += 4) {
    if (!(a[i + 3] > 0 && b[i + 3] > 0)) continue;
    const la = Math.hypot(a[i], a[i + 1], a[i + 2]), lb = Math.hypot(b[i], b[i + 1], b[i + 2]);
    if (!(la > 1e-6 && lb > 1e-6)) continue;  // opposite normals averaged away at an edge
    const cos = (a[i] * b[i] + a[i + 1] * b[i + 1] + a[i + 2] * b[i + 2]) / (la * lb);
    const deg = (Math.acos(Math.max(-1, Math.min(1, cos))) * 180) / Math.PI;
    acc.sum += deg; acc.n += 1;
    if (heat) { const v = Math.min(255, Math.round(8 * deg)); heat[i] = heat[i + 1] = heat[i + 2] = v; heat[i + 3] = 255; }
  }
}
// A float normal render as 8-bit RGBA (n × 0.5 + 0.5, MeshNormalMaterial's colours), for dumps.
function normalImage(f) {
  const out = Buffer.alloc(f.length);
  for (let i = 0; i < f.length; i += 4) {
    const l = Math.hypot(f[i], f[i + 1], f[i + 2]) || 1;
    for (let c = 0; c < 3; ++c) out[i + c] = f[i + 3] > 0 ? Math.round(255 * (0.5 + 0.5 * f[i + c] / l)) : 0;
    out[i + 3] = 255;
  }
  return out;
}
const psnr = (acc) => (acc.n === 0 ? NaN : acc.sum === 0 ? Infinity : 10 * Math.log10((255 * 255) / (acc.sum / acc.n)));
const fmt = (x) => (Number.isFinite(x) ? x.toFixed(1) : x === Infinity ? '∞' : '—');
const deg = (x) => (Number.isFinite(x) ? `${x.toFixed(2)}°` : '—');
const pct = (x) => (x == null ? '—' : `${(100 * x).toFixed(2)}%`);

const iouOf = (acc) => (acc.either ? acc.both / acc.either : NaN);

// Renders the original (served at `originalUrl`) and what meshmux wrote to `out` (model.glb,
// and base.glb with `withBase`) from the five views and measures them against each other: PSNR
// unlit and lit, coverage, normals against winding, and with `withNormalError` the normal-map
// angular error. With --dump, writes the views into `out`. Throws on a harness error; the page
// is then reopened by the caller.
async function judge(originalUrl, out, { withBase, withNormalError }) {
  const outUrl = urlOf('/out/', path.relative(work, out));
  const original = await call('load', originalUrl);
  const model = await call('load', `${outUrl}/model.glb`);
  const basem = withBase ? await call('load', `${outUrl}/base.glb`) : null;
  const cams = cameras(original.center, original.radius);
  const acc = { lit: { sum: 0, n: 0 }, unlit: { sum: 0, n: 0 }, base: { sum: 0, n: 0 }, normal: { sum: 0, n: 0 } };
  const shots = { ol: [], ml: [], ou: [], mu: [], bu: [], on: [], mn: [], heat: [] };
  const shot = async (h, cam, mode) => Buffer.from(await call('render', h, cam, mode), 'base64');
  for (const cam of cams) {
    const [ol, ou, ml, mu] = [await shot(original.handle, cam, 'lit'), await shot(original.handle, cam, 'unlit'),
      await shot(model.handle, cam, 'lit'), await shot(model.handle, cam, 'unlit')];
    Object.entries({ ol, ml, ou, mu }).forEach(([k, v]) => shots[k].push(v));
    accumulate(acc.lit, ol, ml);
    accumulate(acc.unlit, ou, mu);
    if (basem) {
      const bu = await shot(basem.handle, cam, 'unlit');
      shots.bu.push(bu);
      accumulate(acc.base, ou, bu);
    }
    if (!withNormalError) continue;
    // Shading normals with normal maps applied (float RGBA, not 8-bit: see page.js).
    const floats = async (h) => {
      const b = await shot(h, cam, 'perturbed');
      return new Float32Array(b.buffer, b.byteOffset, b.length / 4);
    };
    const on = await floats(original.handle), mn = await floats(model.handle);
    const heat = dump ? Buffer.alloc(on.length) : null;
    accumulateAngles(acc.normal, on, mn, heat);
    if (dump) { shots.on.push(normalImage(on)); shots.mn.push(normalImage(mn)); shots.heat.push(heat); }
  }
  if (dump) {
    const diff = shots.ou.map((a, k) => {
      const b = shots.mu[k], d = Buffer.alloc(a.length);
      for (let i = 0; i < a.length; i += 4) {
        for (let c = 0; c < 3; ++c) d[i + c] = Math.min(255, 4 * Math.abs(a[i + c] - b[i + c]));
        d[i + 3] = 255;
      }
      return d;
    });
    fs.writeFileSync(path.join(out, 'views-unlit.png'), tile([...shots.ou, ...shots.mu, ...shots.bu, ...diff], cams.length));
    fs.writeFileSync(path.join(out, 'views-lit.png'), tile([...shots.ol, ...shots.ml], cams.length));
    // Shading normals alone (view space, MeshNormalMaterial): where lit differs but unlit
    // agrees, this shows whether the normals or the materials are the cause.
    const normals = [];
    for (const h of [original.handle, model.handle])
      for (const cam of cams) normals.push(await shot(h, cam, 'normals'));
    fs.writeFileSync(path.join(out, 'views-normals.png'), tile(normals, cams.length));
    if (withNormalError)
      fs.writeFileSync(path.join(out, 'views-normal-maps.png'), tile([...shots.on, ...shots.mn, ...shots.heat], cams.length));
  }
  for (const m of [original, model, basem]) if (m) await call('release', m.handle);
  const result = {
    coverage: { original: acc.unlit.a, model: acc.unlit.b },
    bounds: { original: [original.min, original.max], model: [model.min, model.max] },
    lightsRemoved: { original: original.lightsRemoved, model: model.lightsRemoved },
    materials: { original: original.materials, model: model.materials },
    unlit: psnr(acc.unlit), lit: psnr(acc.lit),
  };
  if (basem) result.base = psnr(acc.base);
  Object.assign(result, { againstIn: original.normals.share, againstOut: model.normals.share });
  if (withNormalError) Object.assign(result, { normalErrorDeg: acc.normal.n ? acc.normal.sum / acc.normal.n : null, normalErrorPixels: acc.normal.n });
  Object.assign(result, { iou: iouOf(acc.unlit), drawCalls: { original: original.drawCalls, model: model.drawCalls } });
  return result;
}

// The shared models (../shared/models): each converted without its report, judged with base.glb and
// the normal-map error, against the thresholds above; prints the table.
async function sharedMode() {
  const rows = [];
  for (const m of models) {
    const t0 = Date.now();
    const out = path.join(work, m.name);
    fs.rmSync(out, { recursive: true, force: true });
    const conv = spawnSync(meshmux, ['convert', path.join(m.dir, m.file), '-o', out, '--no-report', '-q', ...convertArgs], { encoding: 'utf8' });
    const row = { model: m.name, maps: sourceMaps(m) };
    if (conv.status !== 0) {
      row.error = `convert exited ${conv.status}: ${(conv.stderr || String(conv.error)).trim().split('\n').pop()}`;
      rows.push(row);
      console.error(`${m.name}: ${row.error}`);
      continue;
    }
    try {
      Object.assign(row, await judge(urlOf('/models/', m.name, m.file), out, { withBase: true, withNormalError: true }));
      row.seconds = (Date.now() - t0) / 1000;
    } catch (e) {
      row.error = `harness: ${e.message.split('\n')[0]}`;
      await openPage();
    }
    row.met = !row.error && row.unlit >= kMinUnlit && row.lit >= kMinLit && row.againstOut <= kMaxAgainst;
    rows.push(row);
    console.error(`${m.name}: unlit ${fmt(row.unlit)} dB, lit ${fmt(row.lit)} dB, base ${fmt(row.base)} dB, ` +
      `against winding ${pct(row.againstIn)} → ${pct(row.againstOut)}, normal error ${deg(row.normalErrorDeg)}${row.error ? `; ${row.error}` : ''}`);
  }

  console.log(`| model | unlit PSNR model.glb (≥ ${kMinUnlit}) | lit PSNR model.glb (≥ ${kMinLit}) | ` +
    `unlit PSNR base.glb | normals against winding, input → model.glb (≤ 0.5%) | normal error (mean °) | met |`);
  console.log('|---|---:|---:|---:|---|---:|---|');
  for (const r of rows) {
    if (r.error) { console.log(`| ${r.model} | ${r.error} | | | | | no |`); continue; }
    console.log(`| ${r.model} | ${fmt(r.unlit)} | ${fmt(r.lit)}${r.maps ? ' (maps)' : ''} | ${fmt(r.base)} | ` +
      `${pct(r.againstIn)} → ${pct(r.againstOut)} | ${deg(r.normalErrorDeg)} | ${r.met ? 'yes' : 'no'} |`);
  }
  console.log(`\n${rows.filter((r) => r.met).length} of ${rows.length} models meet the appearance targets`);
  fs.writeFileSync(jsonOut, JSON.stringify({ size, views: directions.length, normalPrecision, rows }, null, 1));
  return rows;
}

// ---- Corpus mode: the sweep ----

// Runs `fn`s at most `limit` at a time, in the order given.
function pool(limit) {
  let active = 0;
  const queue = [];
  const run = () => {
    while (active < limit && queue.length) {
      const { fn, resolve } = queue.shift();
      ++active;
      fn().then(resolve).finally(() => { --active; run(); });
    }
  };
  return (fn) => new Promise((resolve) => { queue.push({ fn, resolve }); run(); });
}

// Converts model `m` as an upload (its folder, --main its main file; or with --legacy-input the
// main file itself, allowed to read beside it) into WORK/NAME, under /usr/bin/time for the wall
// time and peak RSS of that one process. Conversions in the background pool get one thread each
// (MESHMUX_THREADS, and LP_NUM_THREADS for llvmpipe) so that two of them and the judge share 2
// cores without oversubscribing; the environment may override. Not -q: it silences warnings.
// Resolves to { status, signal, stderr, seconds, peakRssKb, timedOut }.
function convertUpload(m) {
  const out = path.join(work, m.name), logs = path.join(work, 'logs');
  fs.rmSync(out, { recursive: true, force: true });
  fs.mkdirSync(logs, { recursive: true });
  const timeFile = path.join(logs, `${m.name}.time`);
  fs.rmSync(timeFile, { force: true });
  const input = legacyInput ? [path.join(m.dir, m.file), '--allow-outside'] : [m.dir, '--main', m.file];
  const env = jobs > 0 ? { MESHMUX_THREADS: '1', LP_NUM_THREADS: '1', ...process.env } : process.env;
  const t0 = Date.now();
  return new Promise((resolve) => {
    // Its own process group, so that a timeout kills meshmux and not only /usr/bin/time.
    const child = spawn('/usr/bin/time', ['-f', '%e %M', '-o', timeFile, meshmux, 'convert', ...input, '-o', out, ...convertArgs],
      { env, detached: true, stdio: ['ignore', 'ignore', 'pipe'] });
    let stderr = '', timedOut = false;
    child.stderr.on('data', (d) => { stderr += d; });
    const timer = setTimeout(() => {
      timedOut = true;
      try { process.kill(-child.pid, 'SIGKILL'); } catch { /* already gone */ }
    }, convertTimeout * 1000);
    const done = (status, signal, error) => {
      clearTimeout(timer);
      fs.writeFileSync(path.join(logs, `${m.name}.stderr`), stderr + (error ? `\n${error}\n` : ''));
      // /usr/bin/time's last line is "%e %M"; "Command exited with non-zero status N" or
      // "Command terminated by signal N" (meshmux crashed: time itself exits normally) may precede it.
      const timed = fs.existsSync(timeFile) ? fs.readFileSync(timeFile, 'utf8').trim().split('\n') : [];
      const last = timed.at(-1) || '', crash = /terminated by signal (\d+)/.exec(timed.join('\n'));
      const [secs, rss] = /^[\d.]+ \d+$/.test(last) ? last.split(' ').map(Number) : [(Date.now() - t0) / 1000, null];
      resolve({ status: error ? -1 : status, signal: signal || (crash && `signal ${crash[1]}`),
        stderr: stderr + (error ? `\n${error}` : ''), seconds: secs, peakRssKb: rss, timedOut });
    };
    child.on('error', (e) => done(null, null, String(e)));
    child.on('close', (status, signal) => done(status, signal));
  });
}

// The warnings a conversion printed ("meshmux: warning: TEXT"; past two of a kind, meshmux
// prints "... and N more like "TEXT"" instead): their count and distinct texts.
function warningsOf(stderr) {
  const texts = new Set();
  let count = 0;
  for (const line of stderr.split('\n')) {
    if (!line.startsWith('meshmux: warning: ')) continue;
    const text = line.slice('meshmux: warning: '.length);
    const more = /^\.\.\. and (\d+) more like "/.exec(text);
    if (more) { count += Number(more[1]); continue; }
    ++count;
    texts.add(text);
  }
  return { count, texts: [...texts] };
}
// The one-line error of a refusal: the last stderr line that is neither progress nor a warning
// (meshmux prints the warning tally after the error).
function errorLine(conv) {
  if (conv.timedOut) return `killed after ${convertTimeout} s (--timeout)`;
  const lines = conv.stderr.split('\n').filter((l) => l.trim() && !l.startsWith('meshmux: warning: ') && !/^meshmux: \[/.test(l));
  const last = lines.pop() || '';
  if (conv.signal) return `killed by ${conv.signal}${last ? `: ${last}` : ''}`;
  return last || '(no message)';
}
// A refusal's cause without what names the model: paths, file names and quoted names blanked,
// so that the same refusal of different models groups as one.
function causeOfError(line, m) {
  return line
    .replaceAll(corpusDir + '/', '').replaceAll(m.name + '/', '').replaceAll(m.file, 'FILE')
    .replace(/(['"`])[^'"`]*\1/g, '…')
    .replace(/[^\s:'"(),]+\.(gltf|glb|dae|bin|png|jpe?g|webp|ktx2|tga|bmp|gif|tiff?|dds)\b/gi, 'FILE')
    .replace(/^meshmux: /, '')
    .replace(/\s+/g, ' ').trim();
}

// Which corpus feature tags plausibly explain a miss of which metric (models.tsv's features
// column; the tag as printed, then the metrics it can move). Encodings (Draco, meshopt,
// quantization, byteStride, data URIs) and ordinary structure (instance counts, units, raw
// coordinate ranges) are left out: they do not change what is drawn.
const kExplains = [
  [/^(transmission|volume|ior)$/, 'transmission/volume', ['lit', 'unlit', 'iou']],  // meshmux: alpha blending
  [/^(clearcoat|sheen|specular|iridescence|anisotropy|emissive_strength)$/, null, ['lit']],
  [/^(unlit|required: unlit)$/, 'unlit material', ['lit']],
  [/^(phong|blinn|lambert|constant\/lambert)$/, 'COLLADA phong/blinn/lambert', ['lit']],
  [/^TANGENT$/, 'normal maps with TANGENT', ['lit']],
  [/^(texture_transform|required: texture_transform.*)$/, 'texture_transform', ['unlit', 'lit']],
  [/^(UVs outside \[0,1\]|CLAMP_TO_EDGE)/, 'REPEAT/UVs outside [0,1]', ['unlit', 'lit']],
  [/^NPOT textures$/, null, ['unlit', 'lit']],
  [/^KTX2/, 'KTX2', ['unlit', 'lit']],
  [/^vertex colou?rs$/, 'vertex colours', ['unlit', 'lit']],
  [/^primitive without material$/, 'no material', ['unlit', 'lit']],
  [/^(TEXCOORD set 1|TEXCOORD_1|texCoord 1 used)/, 'TEXCOORD_1', ['unlit', 'lit']],
  [/^variants$/, 'material variants', ['unlit', 'lit']],
  [/^(alpha BLEND|alpha MASK|<transparent>)/, null, ['unlit', 'lit', 'iou']],
  [/^(morph targets|skin|skin controller|animations)$/, null, ['unlit', 'lit', 'iou', 'normals']],
  [/^(doubleSided|double_sided extra)$/, 'double-sided', ['lit', 'iou', 'normals']],
  [/^no NORMAL$/, null, ['lit', 'normals']],
  [/^(negative scale|non-uniform scale)$/, null, ['lit', 'normals']],
  [/^(points|lines|line strips|line loops|<lines>.*|.*line segments)$/, 'points/lines', ['unlit', 'lit', 'iou']],
  [/^(multiple scenes|unreferenced geometry|\d+ instance_node)/, null, ['unlit', 'lit', 'iou']],
  [/^\+\d+ more \.dae parts/, 'several .dae parts', ['unlit', 'lit', 'iou']],
  [/^sparse accessors$/, null, ['unlit', 'lit', 'iou']],
];
// meshmux's own warnings that name a cause more precisely than any tag (listed first, in place
// of the tags they make redundant).
const kWarningCauses = [
  [/transparency makes it invisible/, 'COLLADA transparency 0 (three.js: invisible, meshmux: opaque)', ['<transparent>']],
  [/skin\(s\) dropped/, 'skin dropped (bind pose)', ['skin', 'skin controller']],
  [/KTX2 images are not supported/, 'KTX2 textures dropped', ['KTX2']],
  [/points\/lines primitive skipped|<lines> skipped/, 'points/lines skipped', ['points/lines']],
];
// What plausibly explains the misses of row `r` of model `m`: first what the measurements and
// meshmux's warnings show, then the feature tags that can move the primary missed metric. A
// coverage miss also costs both PSNRs, and an unlit miss also costs lit, so tags are matched
// against the first of IoU, unlit, lit that missed (and normals), not against the consequences.
function explainingTags(m, r) {
  const tags = [], redundant = [];
  if (r.coverage && r.coverage.original === 0) tags.push('original draws nothing in three.js');
  for (const [re, label, replaces] of kWarningCauses)
    if (r.warnings.texts.some((t) => re.test(t))) { tags.push(label); redundant.push(...replaces); }
  const primary = ['iou', 'unlit', 'lit'].find((x) => r.missed.includes(x));
  const metrics = [primary, r.missed.includes('normals') && 'normals'].filter(Boolean);
  for (const [re, label, moves] of kExplains) {
    if (!moves.some((x) => metrics.includes(x))) continue;
    const hit = m.features.find((f) => re.test(f));
    const tag = hit && (label || hit.replace(/ \(.*$/, ''));
    if (tag && !tags.includes(tag) && !redundant.includes(tag)) tags.push(tag);
  }
  return tags;
}
// The judge's reading (a product decision): COLLADA <transparency>0</transparency> under A_ONE,
// which three.js's ColladaLoader reads as invisible, is opaque where the simulator the models come
// from and their authoring tools show it opaque; meshmux converts it opaque and says so in a
// warning. Such misses are listed apart, each with one line of evidence, and the appearance
// target is counted on the other converted models.
const kGazeboTransparency = 'Gazebo draws it opaque: its COLLADA loader blends A_ONE with source factor ' +
  '1 − a·transparency = 1 (gazebo/common/ColladaLoader.cc, LoadTransparent)';
function judgesReading(m, r) {
  if (!r.converted || r.met || !r.warnings.texts.some((t) => /transparency makes it invisible/.test(t))) return null;
  let tool = '';
  try {
    const text = fs.readFileSync(path.join(m.dir, m.file)).toString('utf8');
    tool = (/<authoring_tool>([^<]*)<\/authoring_tool>/.exec(text) || [])[1] || '';
  } catch {
    // unreadable: the evidence goes without the tool
  }
  return `${m.name.startsWith('gazebo-') ? kGazeboTransparency : 'meshmux reads <transparency>0 as opaque'}` +
    `${tool ? `; authored with ${tool.trim()}` : ''}`;
}

const kMetricText = { unlit: `unlit < ${kCorpus.unlit} dB`, lit: `lit < ${kCorpus.lit} dB`, iou: `IoU < ${kCorpus.iou}`,
  normals: 'normals > input + 0.1%' };
// The corpus targets a judged row misses (NaN, nothing to compare, misses).
function missed(r) {
  const out = [];
  if (!(r.unlit >= kCorpus.unlit)) out.push('unlit');
  if (!(r.lit >= kCorpus.lit)) out.push('lit');
  if (!(r.iou >= kCorpus.iou)) out.push('iou');
  if (!(r.againstOut <= r.againstIn + kCorpus.againstMargin)) out.push('normals');
  return out;
}

const fileBytes = (f) => (fs.existsSync(f) ? fs.statSync(f).size : null);
const mb = (b) => (b == null ? '—' : b >= 1e6 ? `${(b / 1e6).toFixed(2)} MB` : `${(b / 1e3).toFixed(1)} kB`);
const cell = (s) => String(s).replace(/\|/g, '\\|').replace(/\n/g, ' ');

// The sweep: every corpus model converted as an upload (a pool of conversions running ahead of
// the judge) and judged against the corpus targets; writes sweep.md/.tsv/.json.
async function corpusMode() {
  const t0 = Date.now();
  const limit = pool(Math.max(1, jobs));
  // Queued in order now, so the pool starts the next ones while the judge works on the first.
  const conversions = jobs > 0 ? models.map((m) => limit(() => convertUpload(m))) : [];
  const rows = [];
  for (const [k, m] of models.entries()) {
    const conv = jobs > 0 ? await conversions[k] : await convertUpload(m);
    const out = path.join(work, m.name);
    const row = { model: m.name, format: m.format, converted: conv.status === 0, exit: conv.signal || conv.status,
      error: conv.status === 0 ? null : errorLine(conv), timedOut: conv.timedOut, crashed: !conv.timedOut && !!conv.signal,
      warnings: warningsOf(conv.stderr),
      inputBytes: m.bytes, glbBytes: fileBytes(path.join(out, 'model.glb')), mmxpBytes: fileBytes(path.join(out, 'model.mmxp')),
      baseBytes: fileBytes(path.join(out, 'base.glb')),
      seconds: conv.seconds, peakRssKb: conv.peakRssKb, features: m.features };
    if (row.converted) {
      try {
        Object.assign(row, await judge(urlOf('/corpus/', m.name, m.file), out, { withBase: false, withNormalError: false }));
      } catch (e) {
        row.harnessError = e.message.split('\n')[0].replace(/^page\.evaluate: (Error: )?/, '');
        await openPage();
      }
    }
    row.missed = row.converted && !row.harnessError ? missed(row) : [];
    row.met = row.converted && !row.harnessError && !row.missed.length;
    row.causeTags = row.missed.length ? explainingTags(m, row) : [];
    row.judgesReading = judgesReading(m, row);
    rows.push(row);
    console.error(`[${k + 1}/${models.length}] ${m.name}: ` + (!row.converted ? `not converted (exit ${row.exit}): ${row.error}`
      : row.harnessError ? `harness: ${row.harnessError}`
        : `unlit ${fmt(row.unlit)} dB, lit ${fmt(row.lit)} dB, IoU ${row.iou.toFixed(4)}, against winding ` +
          `${pct(row.againstIn)} → ${pct(row.againstOut)}, ${row.drawCalls.model} draws, ${conv.seconds} s, ` +
          `${conv.peakRssKb ? Math.round(conv.peakRssKb / 1024) : '?'} MB${row.met ? '' : ` — missed ${row.missed.join(', ')}`}`));
    write(rows, (Date.now() - t0) / 1000);  // after every model: an interrupted sweep leaves its partial report
  }
  console.log(write(rows, (Date.now() - t0) / 1000));
  console.error(`wrote ${mdOut}, ${tsvOut} and ${jsonOut}`);
  return rows;
}

// Writes sweep.md, .tsv and .json for the rows so far; returns the markdown.
function write(rows, seconds) {
  const md = sweepMarkdown(rows, seconds);
  fs.writeFileSync(mdOut, md);
  fs.writeFileSync(tsvOut, sweepTsv(rows));
  fs.writeFileSync(jsonOut, JSON.stringify({ mode: 'corpus', corpus: corpusDir, input: legacyInput ? 'legacy' : 'upload', jobs,
    size, views: directions.length, seconds, rows }, null, 1));
  return md;
}

// The summary line of the sweep.
function sweepSummary(rows) {
  const converted = rows.filter((r) => r.converted), met = rows.filter((r) => r.met);
  const judged = converted.filter((r) => !r.judgesReading);
  const share = (a, b) => (b ? `${((100 * a) / b).toFixed(1)} %` : '—');
  return `${converted.length} of ${rows.length} convert (${share(converted.length, rows.length)}); ` +
    `${converted.length - judged.length} in the judge's-reading column (below); of the other ${judged.length} converted ` +
    `${met.length} (${share(met.length, judged.length)}) meet unlit ≥ ${kCorpus.unlit}, lit ≥ ${kCorpus.lit}, ` +
    `IoU ≥ ${kCorpus.iou}, normals ≤ input + 0.1 % (of all converted: ${share(met.length, converted.length)})`;
}

// The judge's-reading column: the models whose misses are three.js's reading of the file, not
// what its authors meant, each with its line of evidence.
function judgesReadingSection(rows) {
  const list = rows.filter((r) => r.judgesReading);
  const lines = ["## Judge's reading", ''];
  if (!list.length) lines.push('None.');
  for (const r of list) lines.push(`- ${r.model} (missed ${r.missed.join(', ')}): ${r.judgesReading}`);
  return lines.join('\n') + '\n';
}

// Misses grouped by cause: refusals by their error line (names blanked), harness errors by
// their message, and misses by the metrics missed, then by the feature tags that can explain them.
function missesByCause(rows) {
  const groups = new Map();  // heading → (cause → models)
  const add = (heading, cause, model) => {
    if (!groups.has(heading)) groups.set(heading, new Map());
    const g = groups.get(heading);
    g.set(cause, [...(g.get(cause) || []), model]);
  };
  for (const r of rows) {
    const m = models.find((x) => x.name === r.model);
    if (!r.converted) add('not converted (refused, crashed or timed out)', causeOfError(r.error, m), r.model);
    else if (r.harnessError) add('harness error (not judged)', causeOfError(r.harnessError, m), r.model);
    else if (!r.met) {
      add(r.missed.map((x) => kMetricText[x]).join(' and '), r.causeTags.join(', ') || 'no feature tag explains it', r.model);
    }
  }
  const lines = ['## Misses by cause', ''];
  if (!groups.size) lines.push('None.');
  const count = (g) => [...g.values()].reduce((n, list) => n + list.length, 0);
  for (const [heading, g] of [...groups].sort((a, b) => count(b[1]) - count(a[1]))) {
    lines.push(`### ${heading} (${count(g)})`, '');
    for (const [cause, list] of [...g].sort((a, b) => b[1].length - a[1].length))
      lines.push(`- ${cause} (${list.length}): ${list.join(', ')}`);
    lines.push('');
  }
  return lines.join('\n');
}

function sweepMarkdown(rows, seconds) {
  const count = rows.length < models.length ? `So far ${rows.length} of ${models.length}` : rows.length;
  const how = legacyInput ? 'from their main files (--legacy-input: FILE --allow-outside)' : 'as uploads (FOLDER --main FILE)';
  const pace = jobs > 0 ? `${jobs} conversions at a time (1 thread each) beside the judge` : 'one at a time';
  const lines = [`# Corpus sweep`, '', sweepSummary(rows), '',
    `${count} models of ${corpusDir}, converted ${how}, ${pace}; judged by three.js, ${directions.length} views at ` +
    `${size}²; ${(seconds / 60).toFixed(1)} min. Time and peak RSS are each conversion's own process (/usr/bin/time); ` +
    'IoU is the unlit coverage (alpha > 0) of original and model.glb, pooled over the views.', '',
    `| model | format | result | unlit dB (≥ ${kCorpus.unlit}) | lit dB (≥ ${kCorpus.lit}) | IoU (≥ ${kCorpus.iou}) | ` +
    'normals against winding, input → model.glb | input | model.glb | model.mmxp | draw calls (original → model.glb) | ' +
    "time s | peak RSS MB | met | judge's reading | warnings |",
    '|---|---|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---|---|---|'];
  for (const r of rows) {
    const judged = r.converted && !r.harnessError;
    const result = !r.converted ? `${r.crashed ? 'crashed' : r.timedOut ? 'timed out' : `refused (exit ${r.exit})`}: ${r.error}`
      : r.harnessError ? `converted; harness: ${r.harnessError}` : 'converted';
    const warn = r.warnings.count ? `${r.warnings.count}: ${r.warnings.texts.join('; ')}` : '0';
    lines.push(`| ${[r.model, r.format, result,
      judged ? fmt(r.unlit) : '', judged ? fmt(r.lit) : '', judged ? (Number.isFinite(r.iou) ? r.iou.toFixed(4) : '—') : '',
      judged ? `${pct(r.againstIn)} → ${pct(r.againstOut)}` : '',
      mb(r.inputBytes), mb(r.glbBytes), mb(r.mmxpBytes), judged ? `${r.drawCalls.original} → ${r.drawCalls.model}` : '',
      r.seconds == null ? '—' : r.seconds.toFixed(2), r.peakRssKb == null ? '—' : (r.peakRssKb / 1024).toFixed(0),
      r.met ? 'yes' : `no${r.missed.length ? ` (${r.missed.join(', ')})` : ''}`, r.judgesReading ? 'yes' : '', warn]
      .map(cell).join(' | ')} |`);
  }
  lines.push('', judgesReadingSection(rows), missesByCause(rows.filter((r) => !r.judgesReading)));
  return lines.join('\n') + '\n';
}

// The same columns, one row per model, raw values (bytes, seconds, kB; empty when not measured).
function sweepTsv(rows) {
  const columns = ['model', 'format', 'converted', 'exit', 'error', 'warnings', 'warning_texts', 'unlit_db', 'lit_db', 'iou',
    'against_in', 'against_out', 'input_bytes', 'glb_bytes', 'mmxp_bytes', 'base_bytes', 'draw_calls_original',
    'draw_calls', 'seconds', 'peak_rss_kb', 'harness_error', 'met', 'missed', 'cause_tags', 'judges_reading'];
  const v = (x) => (x == null || Number.isNaN(x) ? '' : x === Infinity ? 'inf' : String(x).replace(/[\t\n]/g, ' '));
  const lines = [columns.join('\t')];
  for (const r of rows)
    lines.push([r.model, r.format, r.converted ? 1 : 0, r.exit, r.error, r.warnings.count, r.warnings.texts.join(' | '),
      r.unlit, r.lit, r.iou, r.againstIn, r.againstOut, r.inputBytes, r.glbBytes, r.mmxpBytes, r.baseBytes,
      r.drawCalls?.original, r.drawCalls?.model, r.seconds, r.peakRssKb, r.harnessError, r.met ? 1 : 0,
      r.missed.join(','), r.causeTags.join(', '), r.judgesReading].map(v).join('\t'));
  return lines.join('\n') + '\n';
}

const rows = corpusDir ? await corpusMode() : await sharedMode();
await context.close();
server.close();
if (pageErrors.length) console.error(`page errors: ${pageErrors.slice(0, 5).join('; ')}`);
if (check && rows.some((r) => !r.met)) process.exit(1);
const short = required.filter((name) => !rows.some((r) => r.model === name && r.met));
if (short.length) {
  console.error(`FAIL: required models below the targets: ${short.join(', ')}`);
  process.exit(1);
}
