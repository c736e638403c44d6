// rd_client.mjs — the stream's orders judged in the three.js client's own frames (issue 47,
// deliverable 1). For each model, each display size and each view, the converted package is
// played in headless chromium through the viewer page (`meshmux serve` of the converted folder:
// index.html and viewer/, the library viewers/web/meshmux.js with the page's own lighting, colour
// management and capture), once per stored order (the table's "orders", stream/format.h: the
// rate-distortion order and the baselines mesh-first, texture-first, constant-ratio), stopped at
// matched byte counts, and each frame is measured against the client's own final frame (the whole
// package, same view, same size). The plain download of model.glb is measured on the same byte
// counts: below its size nothing (the cleared frame), from its size on model.glb's frame (three's
// GLTFLoader with DRACOLoader, its defaults, in the viewer's scene and lighting in place of the
// stream).
//
// What is measured:
//   - byte counts: --points N (default 16) from the base (header, table, base .glb and base faces:
//     the bytes the viewer holds before the first chunk) to the package's size, spaced
//     geometrically (--spacing log, default) or evenly (--spacing linear); the same counts for
//     every order. --spacing chunks: instead, every byte count at which a chunk of some stored
//     order completes (and model.glb's size), so that each order's picture is constant between
//     consecutive counts and its area is exact (a step integral, below); --points is ignored. At count b the stream has applied every chunk of its order that fits in b
//     (MeshmuxStream's budgetBytes, played again from where it stopped: no hook was needed).
//   - frames: the viewer's capture(W, H): W×H device pixels (pixel ratio 1) rendered offscreen,
//     cleared to transparent black, no multisampling (the page's own setting). The page's
//     viewport has the first display's aspect (at most 640 wide), so its default framing is
//     the one a window of that shape gets, and every display size sees the same cameras.
//   - distortion of a frame against the final one, as meshmux measures its own renders
//     (multiplex/distortion.cpp): over the pixels either frame covers (alpha > 0), an uncovered
//     pixel counting as black, (a) the MSE per RGB channel (0..255; its PSNR) and (b) the mean
//     CIEDE2000 (the package table's distortions are in one of them: its view.metric, "mse" in
//     today's packages, CIEDE2000 in those before the field). Pixels neither covers are
//     left out, as bench/fidelity.mjs does; a frame with nothing drawn scores the final frame's
//     covered pixels against black.
//   - area: the trapezoid integral of a distortion over bytes (linear axis) from the base to the
//     package's size (--spacing chunks: the step integral, each frame held until the next count,
//     as the viewer holds it until the next chunk), divided by that span: the mean distortion a viewer sees while the bytes
//     arrive. LOWER IS BETTER. Averaged over the views; the MSE table also gives the PSNR of the
//     averaged area (10·log10(255²/area)) for reading.
//   - predicted vs measured drop per step (rate-distortion order): between consecutive byte
//     counts, the drop of the table's distortion (the stream's stats.distortion: the package's
//     per-step distortion along the sequence played) against the drop measured in the frames
//     (mean CIEDE2000, and MSE), both averaged over the views; Spearman's rank correlation per
//     model and display over the steps where some chunk arrived (steps where none did are
//     identical frames and say nothing).
// Views (--views N, at most 6, first N of): the viewer's default camera; orbited about its up
// axis through the target by −30° and +30° (azimuth); tilted about its right axis by +20° and
// −20° (elevation); and the default direction at 0.6 of the distance (closer: the bounding
// sphere overflows the frame, texture detail is magnified). Near/far follow the page's rule
// (distance ∓ clip margin × radius).
// The viewer re-plans the rate-distortion order for its camera and its canvas when the package
// has a per-view table (view_plan.js); so does this bench by default, one play per view and
// display (the page told the display it is captured at: ?display / setDisplay), as a user at
// that view with that canvas would get it; --stored plays the stored sequence for every view (the page's ?adaptive=0). The
// baselines are never re-planned: one play serves every view.
// Frames are cached by (view, display, set of chunks applied): the scene is the same whichever
// order brought those chunks (mesh chunks keep their relative order in every order; a texture
// level shows the highest applied), so unchanged steps are not rendered again (--no-cache
// renders every frame, to check that).
//
// usage: node bench/rd_client.mjs [--meshmux BIN] --only NAME[,NAME] [--models DIR] [--corpus DIR]
//          [--packages DIR [DIR ...]] [--work DIR] [--display 640x360,1920x1080] [--views 6]
//          [--points 16] [--spacing log|linear|chunks] [--stored] [--no-cache] [--reuse]
//          [--json FILE] [--md FILE] [--chromium /usr/bin/chromium] [--dump]
//   --only: names of ../shared/models folders (converted from their main file) or of
//   ../shared/corpus models.tsv rows (converted as uploads: FOLDER --main MAIN), into WORK/NAME
//   (--reuse: keep a WORK/NAME that has a model.mmxp); --packages: folders `meshmux convert`
//   wrote already (index.html, viewer/, model.mmxp, model.glb). Writes WORK/rd_client.json and
//   WORK/rd_client.md (the tables, printed too); progress and times on stderr.
// Time (2 shared cores, Debian chromium's software GL, defaults): 1–5 min per model (4 corpus and
// shared models: 63–286 s); a 1920×1080 capture takes ~1.4–1.7 s, a 640×360 one ~0.3 s; with the
// cache 30–120 frames per display are rendered instead of 768. --views, --points and --display
// cut it further.
// Exit 77 when chromium is missing.
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import zlib from 'node:zlib';
import { launch, opt, serve, skip } from '../viewers/web/tests/harness.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const root = path.resolve(here, '..');
const args = process.argv.slice(2);
const meshmux = path.resolve(opt('--meshmux', path.join(root, 'build', 'meshmux')));
const modelsDir = path.resolve(opt('--models', path.join(root, '..', 'shared', 'models')));
const corpusDir = path.resolve(opt('--corpus', path.join(root, '..', 'shared', 'corpus')));
const only = opt('--only', '').split(',').filter(Boolean);
const work = path.resolve(opt('--work', path.join(root, 'build', 'rd_client')));
const displays = opt('--display', '640x360,1920x1080').split(',').map((d) => {
  const m = /^(\d+)x(\d+)$/.exec(d.trim());
  if (!m) throw new Error(`--display: "${d}" is not WxH`);
  return { w: Number(m[1]), h: Number(m[2]), name: d.trim() };
});
const viewCount = Math.min(6, Math.max(1, Number(opt('--views', '6')) || 6));
const pointCount = Math.max(2, Number(opt('--points', '16')) || 16);
const spacing = opt('--spacing', 'log');
const stored = args.includes('--stored');
const useCache = !args.includes('--no-cache');
const reuse = args.includes('--reuse');
const dump = args.includes('--dump');  // WORK/NAME-DISPLAY-{final,glb}.png: the default view's two frames
const chromiumPath = opt('--chromium', '/usr/bin/chromium');
const jsonOut = path.resolve(opt('--json', path.join(work, 'rd_client.json')));
const mdOut = path.resolve(opt('--md', path.join(work, 'rd_client.md')));
// --packages DIR [DIR ...]: every argument after it up to the next option.
const packages = [];
for (let i = args.indexOf('--packages') + 1; i > 0 && i < args.length && !args[i].startsWith('--'); i++) packages.push(path.resolve(args[i]));

if (!fs.existsSync(chromiumPath)) skip(`${chromiumPath} not installed (apt-get install chromium)`);
if (!only.length && !packages.length) {
  console.error('usage: node bench/rd_client.mjs --only NAME[,NAME] | --packages DIR [DIR ...]  (see the top of the file)');
  process.exit(2);
}
fs.mkdirSync(work, { recursive: true });
const log = (m) => console.error(`rd_client: ${m}`);
const seconds = (t0) => (performance.now() - t0) / 1000;

// ---- Inputs ----------------------------------------------------------------------------------

// The convert command for a name: a shared model folder (its first .glb/.gltf/.dae) or a corpus
// row (as an upload); null when neither has it.
function convertArgs(name, out) {
  const shared = path.join(modelsDir, name);
  if (fs.existsSync(shared) && fs.statSync(shared).isDirectory()) {
    const file = fs.readdirSync(shared).sort().find((f) => /\.(glb|gltf|dae)$/i.test(f));
    if (file) return ['convert', path.join(shared, file), '-o', out, '-q'];
  }
  const tsv = path.join(corpusDir, 'models.tsv');
  if (fs.existsSync(tsv)) {
    const [header, ...lines] = fs.readFileSync(tsv, 'utf8').split('\n').filter((l) => l.trim());
    const cols = header.split('\t');
    for (const line of lines) {
      const f = Object.fromEntries(line.split('\t').map((v, i) => [cols[i], v]));
      if (f.folder === name) return ['convert', path.join(corpusDir, f.folder), '--main', f.main_file, '-o', out, '-q'];
    }
  }
  return null;
}

// Converts `name` into WORK/NAME; resolves { dir, convertSeconds } or { error }.
function convert(name) {
  const out = path.join(work, name);
  if (reuse && fs.existsSync(path.join(out, 'model.mmxp'))) return { dir: out, convertSeconds: null };
  const argv = convertArgs(name, out);
  if (!argv) return { error: `no such model in ${modelsDir} or ${corpusDir}/models.tsv` };
  fs.rmSync(out, { recursive: true, force: true });
  const t0 = performance.now();
  const r = spawnSync(meshmux, argv, { encoding: 'utf8' });
  if (r.status !== 0) return { error: `convert exited ${r.status}: ${(r.stderr || '').trim().split('\n').pop()}` };
  return { dir: out, convertSeconds: seconds(t0) };
}

// The package's JSON table (the header's length, then the deflated table).
function readTable(file) {
  const bytes = fs.readFileSync(file);
  return JSON.parse(zlib.inflateSync(bytes.subarray(12, 12 + bytes.readUInt32LE(8))).toString());
}

// ---- Geometry of the views and the byte counts --------------------------------------------------

const sub = (a, b) => a.map((x, i) => x - b[i]);
const add = (a, b) => a.map((x, i) => x + b[i]);
const scale = (a, s) => a.map((x) => x * s);
const dot = (a, b) => a.reduce((s, x, i) => s + x * b[i], 0);
const norm = (a) => scale(a, 1 / Math.hypot(...a));
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
// Rodrigues' rotation of v about unit axis k by angle t.
const rotate = (v, k, t) => add(add(scale(v, Math.cos(t)), scale(cross(k, v), Math.sin(t))), scale(k, dot(k, v) * (1 - Math.cos(t))));

// The six views around the viewer's default one (see the top of the file); the first `viewCount`.
function viewsAround(v) {
  const offset = sub(v.eye, v.target), d = Math.hypot(...offset);
  const marginRadius = v.far - d;  // the page's far = d + clip margin × radius
  const up = norm(v.up), right = norm(cross(offset, up));
  const at = (o, name) => {
    const dist = Math.hypot(...o);
    return { name, eye: add(v.target, o), target: v.target, up: v.up, fov: v.fov,
      near: Math.max(dist - marginRadius, dist * 1e-3), far: dist + marginRadius };
  };
  const deg = Math.PI / 180;
  return [at(offset, 'default'), at(rotate(offset, up, -30 * deg), 'azimuth −30°'), at(rotate(offset, up, 30 * deg), 'azimuth +30°'),
    at(rotate(offset, right, 20 * deg), 'elevation +20°'), at(rotate(offset, right, -20 * deg), 'elevation −20°'),
    at(scale(offset, 0.6), 'closer (0.6×)')].slice(0, viewCount);
}

// `pointCount` byte counts from `base` to `total` (log: geometric; linear: even), rounded.
function bytePoints(base, total, table, glbBytes) {
  if (spacing === 'chunks') {
    const ends = new Set([base, total]);
    for (const order of table.orders) {
      let at = base;
      for (const c of order.chunks) ends.add(at += table.chunks[c].size);
    }
    if (glbBytes != null && glbBytes > base && glbBytes < total) ends.add(glbBytes);
    return [...ends].filter((b) => b >= base && b <= total).sort((a, b) => a - b);
  }
  const out = [];
  for (let k = 0; k < pointCount; k++) {
    const t = k / (pointCount - 1);
    out.push(Math.round(spacing === 'linear' ? base + t * (total - base) : base * (total / base) ** t));
  }
  out[0] = base;
  out[pointCount - 1] = total;
  return out;
}

// ---- Measures ----------------------------------------------------------------------------------

// sRGB bytes → CIE L*a*b* (D65; the white is the matrix's image of (1, 1, 1)) and CIEDE2000:
// image/color.cpp's formulas (IEC 61966-2-1, CIE 15:2004, Sharma, Wu and Dalal 2005 (1)–(22)).
const kLinear = Float64Array.from({ length: 256 }, (_, i) => { const c = i / 255; return c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4; });
const kM = [[0.4124564, 0.3575761, 0.1804375], [0.2126729, 0.7151522, 0.0721750], [0.0193339, 0.1191920, 0.9503041]];
const kWhite = kM.map((row) => row[0] + row[1] + row[2]);
const labF = (t) => (t > (6 / 29) ** 3 ? Math.cbrt(t) : t / (3 * (6 / 29) ** 2) + 4 / 29);
function lab(r8, g8, b8) {
  const r = kLinear[r8], g = kLinear[g8], b = kLinear[b8];
  const f = kM.map((row, i) => labF((row[0] * r + row[1] * g + row[2] * b) / kWhite[i]));
  return [116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])];
}
const DEG = 180 / Math.PI, RAD = Math.PI / 180, P25_7 = 6103515625;
function ciede2000([L1, a1, b1], [L2, a2, b2]) {
  const cbar7 = ((Math.hypot(a1, b1) + Math.hypot(a2, b2)) / 2) ** 7, g = 0.5 * (1 - Math.sqrt(cbar7 / (cbar7 + P25_7)));
  const a1p = (1 + g) * a1, a2p = (1 + g) * a2, c1p = Math.hypot(a1p, b1), c2p = Math.hypot(a2p, b2);
  const hue = (b, ap) => { if (b === 0 && ap === 0) return 0; const h = Math.atan2(b, ap) * DEG; return h < 0 ? h + 360 : h; };
  const h1p = hue(b1, a1p), h2p = hue(b2, a2p), cprod = c1p * c2p;
  let dhp = 0;
  if (cprod !== 0) { dhp = h2p - h1p; if (dhp > 180) dhp -= 360; else if (dhp < -180) dhp += 360; }
  const dLp = L2 - L1, dCp = c2p - c1p, dHp = 2 * Math.sqrt(cprod) * Math.sin((dhp * RAD) / 2);
  const Lbarp = (L1 + L2) / 2, Cbarp = (c1p + c2p) / 2;
  const hbarp = cprod === 0 ? h1p + h2p : Math.abs(h1p - h2p) <= 180 ? (h1p + h2p) / 2 : h1p + h2p < 360 ? (h1p + h2p + 360) / 2 : (h1p + h2p - 360) / 2;
  const t = 1 - 0.17 * Math.cos((hbarp - 30) * RAD) + 0.24 * Math.cos(2 * hbarp * RAD) + 0.32 * Math.cos((3 * hbarp + 6) * RAD) - 0.2 * Math.cos((4 * hbarp - 63) * RAD);
  const dtheta = 30 * Math.exp(-(((hbarp - 275) / 25) ** 2)), cbarp7 = Cbarp ** 7, rc = 2 * Math.sqrt(cbarp7 / (cbarp7 + P25_7));
  const l50 = (Lbarp - 50) ** 2, sl = 1 + (0.015 * l50) / Math.sqrt(20 + l50), sc = 1 + 0.045 * Cbarp, sh = 1 + 0.015 * Cbarp * t;
  const rt = -Math.sin(2 * dtheta * RAD) * rc, tl = dLp / sl, tc = dCp / sc, th = dHp / sh;
  return Math.sqrt(Math.max(0, tl * tl + tc * tc + th * th + rt * tc * th));
}

// A frame (RGBA bytes) against the reference, as meshmux measures its renders
// (multiplex/distortion.cpp): over the pixels either covers (alpha > 0), an uncovered pixel
// counting as black; { mse: per RGB channel (0..255), de: mean CIEDE2000 }; 0 when neither covers any.
function measureFrame(ref, img) {
  let sum = 0, sumDe = 0, n = 0;
  for (let i = 0; i < ref.length; i += 4) {
    const inRef = ref[i + 3] !== 0, inImg = img[i + 3] !== 0;
    if (!inRef && !inImg) continue;
    const r1 = inRef ? ref[i] : 0, g1 = inRef ? ref[i + 1] : 0, b1 = inRef ? ref[i + 2] : 0;
    const r2 = inImg ? img[i] : 0, g2 = inImg ? img[i + 1] : 0, b2 = inImg ? img[i + 2] : 0;
    sum += (r1 - r2) ** 2 + (g1 - g2) ** 2 + (b1 - b2) ** 2;
    if (r1 !== r2 || g1 !== g2 || b1 !== b2) sumDe += ciede2000(lab(r1, g1, b1), lab(r2, g2, b2));
    n++;
  }
  return n ? { mse: sum / (3 * n), de: sumDe / n } : { mse: 0, de: 0 };
}
const psnrOf = (m) => (m > 0 ? 10 * Math.log10((255 * 255) / m) : Infinity);

// An RGBA PNG of a frame, made opaque (--dump): filter 0 per row, one zlib stream.
function png(w, h, rgba) {
  const table = new Int32Array(256).map((_, n) => { let c = n; for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1; return c; });
  const crc = (buf) => { let c = -1; for (const b of buf) c = table[(c ^ b) & 255] ^ (c >>> 8); return (c ^ -1) >>> 0; };
  const chunk = (type, data) => {
    const head = Buffer.alloc(8), tail = Buffer.alloc(4);
    head.writeUInt32BE(data.length, 0); head.write(type, 4, 'latin1');
    tail.writeUInt32BE(crc(Buffer.concat([head.subarray(4), data])), 0);
    return Buffer.concat([head, data, tail]);
  };
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(w, 0); ihdr.writeUInt32BE(h, 4); ihdr[8] = 8; ihdr[9] = 6;
  const raw = Buffer.alloc((w * 4 + 1) * h);
  for (let y = 0; y < h; ++y) rgba.copy(raw, y * (w * 4 + 1) + 1, y * w * 4, (y + 1) * w * 4);
  for (let i = 0; i < raw.length; i++) if ((i % (w * 4 + 1)) % 4 === 0 && i % (w * 4 + 1) > 0) raw[i] = 255;
  return Buffer.concat([Buffer.from([137, 80, 78, 71, 13, 10, 26, 10]), chunk('IHDR', ihdr), chunk('IDAT', zlib.deflateSync(raw)),
    chunk('IEND', Buffer.alloc(0))]);
}

// The trapezoid integral of ys over xs (--spacing chunks: the step integral, ys[k] held until
// xs[k + 1]), divided by the span of xs.
function meanArea(xs, ys) {
  let a = 0;
  for (let k = 0; k + 1 < xs.length; k++)
    a += (spacing === 'chunks' ? ys[k] : 0.5 * (ys[k] + ys[k + 1])) * (xs[k + 1] - xs[k]);
  return xs.at(-1) > xs[0] ? a / (xs.at(-1) - xs[0]) : ys[0];
}

// Ranks (1-based, ties averaged).
function ranks(xs) {
  const idx = xs.map((x, i) => [x, i]).sort((p, q) => p[0] - q[0]), r = new Array(xs.length);
  for (let i = 0; i < idx.length;) {
    let j = i;
    while (j + 1 < idx.length && idx[j + 1][0] === idx[i][0]) j++;
    for (let k = i; k <= j; k++) r[idx[k][1]] = (i + j) / 2 + 1;
    i = j + 1;
  }
  return r;
}
// Spearman's rank correlation (Pearson's of the ranks); NaN with fewer than 3 pairs or no spread.
function spearman(xs, ys) {
  if (xs.length < 3) return NaN;
  const rx = ranks(xs), ry = ranks(ys), mx = rx.reduce((s, x) => s + x, 0) / rx.length, my = ry.reduce((s, y) => s + y, 0) / ry.length;
  let sxy = 0, sxx = 0, syy = 0;
  for (let i = 0; i < rx.length; i++) {
    sxy += (rx[i] - mx) * (ry[i] - my);
    sxx += (rx[i] - mx) ** 2;
    syy += (ry[i] - my) ** 2;
  }
  return sxx > 0 && syy > 0 ? sxy / Math.sqrt(sxx * syy) : NaN;
}

// ---- The page ------------------------------------------------------------------------------------

// The page's side, called through page.evaluate: the viewer's own window.meshmuxViewer, plus the
// plain download (model.glb put in the viewer's scene in place of the stream, under its lights).
const pageCalls = {
  state: () => {
    const s = window.meshmuxViewer.stream;
    // The chunks applied (the order's sequence as played, re-planned or not), for the frame cache.
    const applied = Array.isArray(s._sequence) ? s._sequence.slice(0, s._position) : null;
    return { ...s.stats, applied, pageState: document.body.dataset.state, error: document.body.dataset.error || null };
  },
  playTo: async (bytes) => {
    const s = window.meshmuxViewer.stream;
    s.budgetBytes = bytes;
    await s.play();
  },
  showGlb: async (url) => {
    // three's loaders from the folder's own copy (the page's import map), by absolute URL.
    const importMap = JSON.parse(document.querySelector('script[type="importmap"]').textContent).imports;
    const addons = new URL(importMap['three/addons/'], location.href).href;
    const { GLTFLoader } = await import(addons + 'loaders/GLTFLoader.js');
    const { DRACOLoader } = await import(addons + 'loaders/DRACOLoader.js');
    const { MeshoptDecoder } = await import(addons + 'libs/meshopt_decoder.module.js');
    const draco = new DRACOLoader().setDecoderPath(addons + 'libs/draco/gltf/');
    // KTX2 images (--textures ktx2, or a kept material's KTX2 upload): the stream's KTX2Loader,
    // the page's one.
    const gltf = await new GLTFLoader().setDRACOLoader(draco).setMeshoptDecoder(MeshoptDecoder)
      .setKTX2Loader(await window.meshmuxViewer.stream.ktx2Loader()).loadAsync(url);
    draco.dispose();
    const glb = gltf.scene || gltf.scenes[0], lights = [];
    glb.traverse((o) => { if (o.isLight) lights.push(o); });
    for (const l of lights) l.removeFromParent();  // the viewer's rig only, as for the stream
    const s = window.meshmuxViewer.stream, scene = s.object.parent;
    s.object.visible = false;
    scene.add(glb);
    window.__rdGlb = glb;
  },
  hideGlb: () => {
    const glb = window.__rdGlb, s = window.meshmuxViewer.stream;
    glb.removeFromParent();
    glb.traverse((o) => {
      if (!o.isMesh) return;
      o.geometry.dispose();
      for (const m of [].concat(o.material)) {
        for (const v of Object.values(m)) if (v && v.isTexture) v.dispose();
        m.dispose();
      }
    });
    window.__rdGlb = null;
    s.object.visible = true;
  },
};

class Client {
  constructor(page) { this.page = page; this.captureSeconds = {}; this.captures = {}; }
  call(name, arg) { return this.page.evaluate(pageCalls[name], arg); }
  setView(v) { return this.page.evaluate((x) => { window.meshmuxViewer.setView(x); }, v); }
  // The display the client plans for (the capture's size; null: the page's canvas).
  setDisplay(d) { return this.page.evaluate((x) => { window.meshmuxViewer.setDisplay(x); }, d ? [d.w, d.h] : null); }
  async replay(order) { await this.page.evaluate((o) => window.meshmuxViewer.replay(o, 0).then(() => null), order); }
  async shot(d) {
    const t0 = performance.now();
    const b64 = await this.page.evaluate(([w, h]) => window.meshmuxViewer.capture(w, h).then((r) => r.rgba), [d.w, d.h]);
    const pixels = Buffer.from(b64, 'base64');
    this.captureSeconds[d.name] = (this.captureSeconds[d.name] || 0) + seconds(t0);
    this.captures[d.name] = (this.captures[d.name] || 0) + 1;
    return pixels;
  }
}

// ---- One model -------------------------------------------------------------------------------------

// Plays every order of the package in folder `dir` and measures its frames; returns the model's
// result (see the JSON's description in the markdown).
async function measure(name, dir, context) {
  const t0 = performance.now();
  const table = readTable(path.join(dir, 'model.mmxp'));
  const packageBytes = fs.statSync(path.join(dir, 'model.mmxp')).size;
  const glbBytes = fs.existsSync(path.join(dir, 'model.glb')) ? fs.statSync(path.join(dir, 'model.glb')).size : null;
  const { server, url } = await serve(meshmux, dir);
  const page = await context.newPage();
  const pageErrors = [];
  page.on('pageerror', (e) => pageErrors.push(e.message));
  const client = new Client(page);
  try {
    // The whole package in the default order and view: the reference frames.
    await page.goto(`${url}?adaptive=${stored ? 0 : 1}`);
    await page.waitForFunction(() => ['complete', 'stopped', 'error'].includes(document.body.dataset.state), null,
      { timeout: 900000, polling: 200 });
    const final = await client.call('state');
    if (final.pageState !== 'complete') throw new Error(`the viewer ended in state ${final.pageState}: ${final.error || ''}`);
    const views = viewsAround(await page.evaluate(() => window.meshmuxViewer.view()));
    const orders = await page.evaluate(() => window.meshmuxViewer.orders());
    const openSeconds = seconds(t0);
    const refs = {}, cache = new Map();
    const keyOf = (v, d, applied) => `${v}|${d.name}|${[...applied].sort((a, b) => a - b).join(',')}`;
    for (const [v, view] of views.entries()) {
      await client.setView(view);
      for (const d of displays) {
        refs[`${v}|${d.name}`] = await client.shot(d);
        if (final.applied) cache.set(keyOf(v, d, final.applied), { mse: 0, de: 0 });
      }
    }
    // The plain download's two frames per view and display: nothing, and model.glb.
    const plain = { blank: {}, glb: {} };
    for (const d of displays)
      for (const v of views.keys()) plain.blank[`${v}|${d.name}`] = measureFrame(refs[`${v}|${d.name}`], Buffer.alloc(d.w * d.h * 4));
    if (glbBytes != null) {
      await client.call('showGlb', `${url}model.glb`);
      for (const [v, view] of views.entries()) {
        await client.setView(view);
        for (const d of displays) {
          const frame = await client.shot(d);
          plain.glb[`${v}|${d.name}`] = measureFrame(refs[`${v}|${d.name}`], frame);
          if (dump && v === 0) {
            fs.writeFileSync(path.join(work, `${name}-${d.name}-glb.png`), png(d.w, d.h, frame));
            fs.writeFileSync(path.join(work, `${name}-${d.name}-final.png`), png(d.w, d.h, refs[`0|${d.name}`]));
          }
        }
      }
      await client.call('hideGlb');
    }

    // Every order, stopped at each byte count; per view (re-planned rate-distortion) or once.
    const curves = {};  // order → view → display → { mse: [], de: [], bytes: [], distortion: [], chunks: [], followed: [] }
    let points = null, baseBytes = null, playSeconds = 0, rendered = 0, reused = 0;
    for (const order of orders) {
      const perView = !stored && order === orders[0] && !!table.view_table;
      // Re-planned: one play per view and display (the client plans for its camera and canvas);
      // a baseline: one play for all.
      const groups = perView ? views.flatMap((_, v) => displays.map((d) => ({ group: [v], shown: [d] })))
        : [{ group: views.map((_, v) => v), shown: displays }];
      curves[order] = {};
      for (const { group, shown } of groups) {
        await client.setView(views[group[0]]);
        await client.setDisplay(perView ? shown[0] : null);
        const tp = performance.now();
        await client.replay(order);
        playSeconds += seconds(tp);
        const base = await client.call('state');
        if (base.order !== order) throw new Error(`asked for order ${order}, the viewer plays ${base.order}`);
        if (!points) { baseBytes = base.bytesReceived; points = bytePoints(baseBytes, packageBytes, table, glbBytes); }
        for (const v of group) {
          curves[order][v] = curves[order][v] || {};
          for (const d of shown) curves[order][v][d.name] = { mse: [], de: [], bytes: [], distortion: [], chunks: [], followed: [] };
        }
        for (const b of points) {
          const tq = performance.now();
          await client.call('playTo', b);
          playSeconds += seconds(tq);
          const st = await client.call('state');
          if (!['stopped', 'complete'].includes(st.state)) throw new Error(`order ${order} at ${b} bytes: state ${st.state} ${st.error || ''}`);
          for (const v of group) {
            if (group.length > 1) await client.setView(views[v]);
            for (const d of shown) {
              const key = st.applied && useCache ? keyOf(v, d, st.applied) : null;
              let m = key != null ? cache.get(key) : undefined;
              if (m === undefined) {
                m = measureFrame(refs[`${v}|${d.name}`], await client.shot(d));
                rendered++;
                if (key != null) cache.set(key, m);
              } else reused++;
              const c = curves[order][v][d.name];
              c.mse.push(m.mse); c.de.push(m.de); c.bytes.push(st.bytesReceived); c.distortion.push(st.distortion);
              c.chunks.push(st.chunksApplied); c.followed.push(st.orderFollowed);
            }
          }
        }
        log(`${name}: ${order}${perView ? ` (view ${group[0]}, ${shown[0].name})` : ''} done, ${rendered} frames rendered, ${reused} reused`);
      }
    }
    return summarize({ name, dir, table, packageBytes, glbBytes, baseBytes, points, views, orders, curves, plain,
      pageErrors, times: { openSeconds, playSeconds, totalSeconds: seconds(t0),
        captureSeconds: client.captureSeconds, captures: client.captures, rendered, reused } });
  } finally {
    await page.close().catch(() => {});
    server.kill();
  }
}

// Areas per measure, display and order (averaged over the views), the plain download's, and
// the predicted-vs-measured steps of the first (rate-distortion) order.
function summarize(r) {
  const xs = r.points, nv = r.views.length, avg = (f) => r.views.reduce((s, _, v) => s + f(v), 0) / nv;
  r.areas = { mse: {}, de: {} };
  r.steps = {};
  for (const d of displays) {
    for (const m of ['mse', 'de']) {
      const a = {};
      for (const order of r.orders) a[order] = avg((v) => meanArea(xs, r.curves[order][v][d.name][m]));
      if (r.glbBytes != null) {
        const at = (v, b) => (b >= r.glbBytes ? r.plain.glb : r.plain.blank)[`${v}|${d.name}`][m];
        a['plain download'] = avg((v) => meanArea(xs, xs.map((b) => at(v, b))));
      }
      r.areas[m][d.name] = a;
    }
    // Steps of the rate-distortion order.
    const rd = r.orders[0], steps = [];
    for (let k = 0; k + 1 < xs.length; k++) {
      const c = (v) => r.curves[rd][v][d.name];
      const arrived = r.views.some((_, v) => c(v).chunks[k + 1] !== c(v).chunks[k]);
      steps.push({ from: xs[k], to: xs[k + 1], arrived,
        chunks: [avg((v) => c(v).chunks[k]), avg((v) => c(v).chunks[k + 1])],
        predicted: avg((v) => c(v).distortion[k] - c(v).distortion[k + 1]),
        measuredDe: avg((v) => c(v).de[k] - c(v).de[k + 1]),
        measuredMse: avg((v) => c(v).mse[k] - c(v).mse[k + 1]),
        de: [avg((v) => c(v).de[k]), avg((v) => c(v).de[k + 1])],
        psnr: [psnrOf(avg((v) => c(v).mse[k])), psnrOf(avg((v) => c(v).mse[k + 1]))] });
    }
    const live = steps.filter((x) => x.arrived), predicted = live.map((x) => x.predicted);
    r.steps[d.name] = { steps, n: live.length,
      spearman: { de: spearman(predicted, live.map((x) => x.measuredDe)), mse: spearman(predicted, live.map((x) => x.measuredMse)) } };
  }
  delete r.table;  // large; the package is in r.dir
  return r;
}

// ---- Report ---------------------------------------------------------------------------------------

const kb = (b) => (b == null ? '—' : b >= 1e6 ? `${(b / 1e6).toFixed(2)} MB` : `${(b / 1e3).toFixed(1)} kB`);
const db = (x) => (x === Infinity ? '∞' : Number.isFinite(x) ? x.toFixed(1) : '—');
const area = (x) => (Number.isFinite(x) ? `${x < 10 ? x.toFixed(2) : x.toFixed(1)} (${db(psnrOf(x))} dB)` : '—');

// One areas table: a row per model and display, a column per order and the plain download.
function areasTable(results, m, fmt) {
  const names = ['rate-distortion', 'mesh-first', 'texture-first', 'constant-ratio'];
  const lines = [`| model | display | package | base | model.glb | ${names.join(' | ')} | other orders | plain download | ` +
    `model.glb's frame against the final | rate-distortion lowest |`, `|---|---|---:|---:|---:|${names.map(() => '---:').join('|')}|---|---:|---:|---|`];
  for (const r of results) {
    if (r.error) { lines.push(`| ${r.name} | error: ${r.error} |`); continue; }
    for (const d of displays) {
      const a = r.areas[m][d.name], others = Object.keys(a).filter((k) => !names.includes(k) && k !== 'plain download');
      const rd = a['rate-distortion'], above = Object.entries(a).filter(([k, x]) => k !== 'rate-distortion' && rd > x * (1 + 1e-9)).map(([k]) => k);
      const glb = r.views.reduce((sum, _, v) => sum + (r.plain.glb[`${v}|${d.name}`]?.[m] ?? NaN), 0) / r.views.length;
      lines.push(`| ${r.name} | ${d.name} | ${kb(r.packageBytes)} | ${kb(r.baseBytes)} | ${kb(r.glbBytes)} | ` +
        `${names.map((n) => fmt(a[n])).join(' | ')} | ${others.map((k) => `${k}: ${fmt(a[k])}`).join('; ') || '—'} | ` +
        `${fmt(a['plain download'])} | ${fmt(glb)} | ${above.length ? `no (above ${above.join(', ')})` : 'yes'} |`);
    }
  }
  return lines;
}

function markdown(results) {
  const rho = (x) => (Number.isFinite(x) ? x.toFixed(2) : '—');
  const lines = ['# The stream orders in the three.js client\'s frames (bench/rd_client.mjs)', '',
    `Displays ${displays.map((d) => d.name).join(', ')} device pixels; ${viewCount} views (default, azimuth ∓30°, ` +
    `elevation ±20°, 0.6× distance: the first ${viewCount}); ${pointCount} byte counts (${spacing}) from the base to the package; ` +
    `rate-distortion ${stored ? 'as stored (--stored)' : 're-planned for each view as the viewer does (when the package has a per-view table)'}. ` +
    'Each frame against the client\'s final frame (same view and size) over the pixels either covers (alpha > 0; uncovered = black), ' +
    `as meshmux measures its renders. Area = that distortion integrated over bytes (${spacing === 'chunks' ? 'steps: every count where a chunk of some order completes' : 'trapezoids'}) from the base to the package size, ` +
    'divided by the span, averaged over the views: **lower is better**. Plain download: nothing below model.glb\'s size, ' +
    'model.glb (GLTFLoader + DRACOLoader defaults, KTX2Loader, the viewer\'s lights) from it.', '',
    '## Areas: MSE per RGB channel (in parentheses the PSNR of the area)', '',
    ...areasTable(results, 'mse', area), '',
    '## Areas: mean CIEDE2000', '',
    ...areasTable(results, 'de', (x) => (Number.isFinite(x) ? x.toFixed(3) : '—')), '',
    '## Predicted vs measured drop per step (rate-distortion order)', '',
    'Per step between consecutive byte counts where some chunk arrived: the drop of the package table\'s distortion ' +
    '(meshmux\'s renders in the table\'s measure, view.metric: MSE, or CIEDE2000 in older packages; the stream\'s stats.distortion along the sequence played) against the drop measured ' +
    'in the client\'s frames (mean CIEDE2000, and MSE), both averaged over the views; Spearman\'s ρ over those steps.', '',
    `| model | ${displays.map((d) => `ρ ΔE ${d.name} | ρ MSE ${d.name} | steps`).join(' | ')} |`,
    `|---|${displays.map(() => '---:|---:|---:').join('|')}|`];
  for (const r of results) {
    if (r.error) continue;
    lines.push(`| ${r.name} | ${displays.map((d) => { const x = r.steps[d.name]; return `${rho(x.spearman.de)} | ${rho(x.spearman.mse)} | ${x.n}`; }).join(' | ')} |`);
  }
  for (const r of results) {
    if (r.error) continue;
    for (const d of displays) {
      lines.push('', `### ${r.name}, ${d.name}`, '',
        '| bytes | chunks applied (mean over views) | predicted drop (table\'s measure) | measured drop (ΔE) | measured ΔE before → after | measured drop (MSE) | PSNR before → after |',
        '|---|---|---:|---:|---|---:|---|');
      for (const x of r.steps[d.name].steps.filter((y) => y.arrived)) {
        lines.push(`| ${kb(x.from)} → ${kb(x.to)} | ${x.chunks.map((c) => c.toFixed(1)).join(' → ')} | ${x.predicted.toFixed(3)} | ` +
          `${x.measuredDe.toFixed(3)} | ${x.de.map((e) => e.toFixed(3)).join(' → ')} | ${x.measuredMse.toFixed(2)} | ${db(x.psnr[0])} → ${db(x.psnr[1])} |`);
      }
    }
  }
  lines.push('', '## Time', '', `| model | convert s | measure s | open + reference s | playing s | ${displays.map((d) => `captures ${d.name} (s)`).join(' | ')} | frames rendered / reused |`,
    `|---|---:|---:|---:|---:|${displays.map(() => '---:').join('|')}|---|`);
  for (const r of results) {
    if (r.error) continue;
    const t = r.times;
    lines.push(`| ${r.name} | ${r.convertSeconds == null ? '—' : r.convertSeconds.toFixed(1)} | ${t.totalSeconds.toFixed(0)} | ${t.openSeconds.toFixed(1)} | ` +
      `${t.playSeconds.toFixed(1)} | ${displays.map((d) => `${t.captures[d.name] || 0} (${(t.captureSeconds[d.name] || 0).toFixed(1)})`).join(' | ')} | ${t.rendered} / ${t.reused} |`);
  }
  return lines.join('\n') + '\n';
}

// ---- Main -------------------------------------------------------------------------------------------

const first = displays[0], vw = Math.min(640, first.w);
const { context, close } = await launch(work, chromiumPath, { width: vw, height: Math.round((vw * first.h) / first.w) });
const results = [];
try {
  const inputs = [...only.map((n) => ({ name: n })), ...packages.map((dir) => ({ name: path.basename(dir), dir }))];
  for (const input of inputs) {
    let { dir } = input, convertSeconds = null;
    if (!dir) {
      log(`${input.name}: converting`);
      const c = convert(input.name);
      if (c.error) { results.push({ name: input.name, error: c.error }); log(`${input.name}: ${c.error}`); continue; }
      ({ dir, convertSeconds } = c);
    }
    try {
      const r = await measure(input.name, dir, context);
      r.convertSeconds = convertSeconds;
      results.push(r);
      log(`${input.name}: ${r.times.totalSeconds.toFixed(0)} s; MSE areas ${JSON.stringify(r.areas.mse)}`);
    } catch (e) {
      results.push({ name: input.name, error: e.message.split('\n')[0] });
      log(`${input.name}: ${e.message}`);
    }
    fs.writeFileSync(jsonOut, JSON.stringify({ displays, views: viewCount, points: pointCount, spacing, stored, results }, null, 1));
    fs.writeFileSync(mdOut, markdown(results));
  }
} finally {
  await close();
}
console.log(markdown(results));
log(`wrote ${mdOut} and ${jsonOut}`);
