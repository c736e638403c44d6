// viewer.js — the meshmux viewer page: plays a stream package in a full-window canvas.
//
// URL parameters: src (package URL, default "model.mmxp"), order (default "rate-distortion"),
// budget (fraction 0..1 of the file's bytes, default 1), autoplay (1/0, default 1), adaptive
// (1/0, default 1: 0 plays the stored order as it is, never re-planned for the camera or the
// canvas), display (WxH device pixels: the canvas size the order is re-planned for, default the
// page's own canvas; a capture of another size is judged with it), triangles (a big mesh's block
// package is played by view, refined where the camera looks and coarsened where it left, with at
// most this many triangles held: default 2000000; 0 plays it in the stored order).
//
// Test hooks: document.body.dataset.state ("loading" → "base" → "streaming" → "complete" |
// "stopped", or "error"; played by view: "streaming" ↔ "settled" as the camera moves) and window.meshmuxViewer (stats, view, setView, capture, replay, setDisplay).
// Rendering happens on demand only: after applied chunks, camera changes and resizes.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { MeshmuxStream, addStreamLighting } from './meshmux.js';

const PAGE_BACKGROUND = new THREE.Color().setRGB(0.15, 0.15, 0.15, THREE.LinearSRGBColorSpace);

// ---- Parameters ----------------------------------------------------------------------------

const params = new URLSearchParams(location.search);
const src = params.get('src') || 'model.mmxp';
let orderName = params.get('order') || 'rate-distortion';
let budgetFraction = clamp01(parseFloat(params.get('budget') ?? '1'), 1);
const autoplay = !['0', 'false', 'no'].includes((params.get('autoplay') || '1').toLowerCase());
const adaptive = !['0', 'false', 'no'].includes((params.get('adaptive') || '1').toLowerCase());
const triangles = Math.max(0, Number(params.get('triangles') ?? '2000000')) || 0;

// The display to plan for: null (the canvas) unless ?display=WxH names two positive integers.
let display = displayParam(params.get('display'));
function displayParam(text) {
  const m = /^(\d{1,5})x(\d{1,5})$/.exec(text || '');
  return m && +m[1] > 0 && +m[2] > 0 ? [+m[1], +m[2]] : null;
}

// The package's distortion in its measure (the table's view.metric): the mean squared error as
// PSNR (dB; "final" at 0), CIEDE2000 as ΔE.
function formatDistortion(d, metric) {
  if (!Number.isFinite(d)) return '–';
  if (metric !== 'mse') return `ΔE ${d.toFixed(2)}`;
  return d > 0 ? `PSNR ${(10 * Math.log10((255 * 255) / d)).toFixed(1)} dB` : 'final';
}

function clamp01(x, fallback) { return Number.isFinite(x) ? Math.min(1, Math.max(0, x)) : fallback; }

// ---- Page elements -------------------------------------------------------------------------

const $ = (id) => document.getElementById(id);
const canvas = $('view');
const ui = {
  state: $('state-label'), bar: $('progress-bar'), mark: $('budget-mark'), message: $('message'),
  bytes: $('stat-bytes'), triangles: $('stat-triangles'), texture: $('stat-texture'),
  distortion: $('stat-distortion'), chunks: $('stat-chunks'), speed: $('stat-speed'),
  budget: $('budget'), budgetValue: $('budget-value'), order: $('order'), replay: $('replay'),
  reset: $('reset-view'), followed: $('stat-followed'),
};

function setState(state) {
  document.body.dataset.state = state;
  ui.state.textContent = state;
}

function showError(error) {
  const message = error && error.message ? error.message : String(error);
  document.body.dataset.error = message;
  ui.message.textContent = message;
  setState('error');
}

// ---- Renderer, scene, camera, controls -----------------------------------------------------

let renderer;
try {
  renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
} catch (e) {
  showError(new Error(`WebGL is not available (${e.message})`));
  throw e;
}
renderer.setPixelRatio(1);                       // reproducible pixels
renderer.outputColorSpace = THREE.LinearSRGBColorSpace;  // colour management off: bytes as stored
renderer.toneMapping = THREE.NoToneMapping;
renderer.setClearColor(PAGE_BACKGROUND, 1);

const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(45, 1, 0.1, 100);  // framed from the package's "view" on open
let controls = makeControls();
let frame = { center: new THREE.Vector3(), radius: 1, clipMargin: 1.5 };  // bounding sphere, clip margin (from "view")
let framed = false;
let framing = null;   // {box, view} of the default framing, for resizes and "Reset view"
let userMoved = false;  // the user orbited, zoomed or panned since the default framing

function makeControls() {
  const c = new OrbitControls(camera, canvas);
  c.enableDamping = false;  // a still page renders nothing
  c.addEventListener('change', () => { fitClipPlanes(); requestRender(); });
  c.addEventListener('start', () => { userMoved = true; });
  return c;
}

// Near/far as the default framing sets them, for the current distance (after user motion).
function fitClipPlanes() {
  const d = camera.position.distanceTo(frame.center), r = frame.radius, m = frame.clipMargin;
  camera.near = Math.max(d - m * r, d * 1e-3);
  camera.far = d + m * r;
  camera.updateProjectionMatrix();
}

// meshmux's default camera, as the package's "view" says the distortion was measured: the
// bounding sphere fills `fill` of the smaller half-extent, seen from `direction`.
function frameDefault(box, view) {
  const center = box.isEmpty() ? new THREE.Vector3() : box.getCenter(new THREE.Vector3());
  let radius = box.isEmpty() ? 1 : 0.5 * box.getSize(new THREE.Vector3()).length();
  if (!(radius > 0) || !Number.isFinite(radius)) radius = 1;
  frame = { center, radius, clipMargin: view.clipMargin };
  const side = Math.min(1, camera.aspect > 0 ? camera.aspect : 1);
  let half = Math.atan(view.fill * Math.tan(THREE.MathUtils.degToRad(view.fov) / 2) * side);
  if (!(half > 0)) half = THREE.MathUtils.degToRad(view.fov) / 2;
  const distance = radius / Math.sin(half);
  const direction = new THREE.Vector3(...view.direction).normalize();
  camera.fov = view.fov;
  camera.up.set(0, Math.abs(direction.y) > 0.99 ? 0 : 1, Math.abs(direction.y) > 0.99 ? 1 : 0);
  camera.position.copy(center).addScaledVector(direction, distance);
  camera.near = Math.max(distance - view.clipMargin * radius, distance * 1e-3);
  camera.far = distance + view.clipMargin * radius;
  camera.lookAt(center);
  camera.updateProjectionMatrix();
  controls.target.copy(center);
  // Zoom stays between close-up and a speck: a fifth of the bounding sphere's distance up to ten
  // times it (the clip planes follow the distance).
  controls.minDistance = 0.2 * radius;
  controls.maxDistance = 10 * distance;
  framed = true;
  framing = { box: box.clone(), view };
  userMoved = false;
}

// Back to the default framing (the "Reset view" button, or a resize before the user moved).
function resetView() {
  if (!framing) return;
  frameDefault(framing.box, framing.view);
  requestRender();
}

// A resize or a phone's rotation re-frames the model for the new shape, unless the user has
// moved the camera (then only the aspect follows).
function resize() {
  const w = Math.max(1, window.innerWidth), h = Math.max(1, window.innerHeight);
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  if (framing && !userMoved) frameDefault(framing.box, framing.view);
  requestRender();
}
window.addEventListener('resize', resize);
if (screen.orientation) screen.orientation.addEventListener('change', resize);

// ---- On-demand rendering -------------------------------------------------------------------

let renderQueued = false;
function requestRender() {
  if (renderQueued) return;
  renderQueued = true;
  requestAnimationFrame(() => { renderQueued = false; renderNow(); });
}
function renderNow() {
  renderer.render(scene, camera);
  updatePanel();
}
// Resolves after the next frame (or shortly, when the page is hidden and frames do not come).
const nextFrame = () => new Promise((resolve) => {
  const timer = setTimeout(resolve, 100);
  requestAnimationFrame(() => { clearTimeout(timer); resolve(); });
});

// ---- Panel ---------------------------------------------------------------------------------

// Decimal units, as the command line prints them (1 kB = 1000 bytes).
function formatBytes(n) {
  if (!Number.isFinite(n)) return '?';
  if (n < 1000) return `${n} B`;
  if (n < 1e6) return `${(n / 1e3).toFixed(1)} kB`;
  return `${(n / 1e6).toFixed(2)} MB`;
}

function updatePanel() {
  const s = stream ? stream.stats : null;
  if (!s) return;
  const total = s.bytesTotal;
  const share = total > 0 ? s.bytesReceived / total : 0;
  ui.bar.style.width = `${(100 * Math.min(1, share)).toFixed(2)}%`;
  ui.bytes.textContent = `${formatBytes(s.bytesReceived)} / ${formatBytes(total)} (${(100 * share).toFixed(0)}%)`;
  ui.triangles.textContent = s.triangles.toLocaleString('en-US');
  ui.texture.textContent = s.textureWidth ? `${s.textureWidth}×${s.textureHeight}` : 'none';
  ui.distortion.textContent = formatDistortion(s.distortion, stream && stream.table ? stream.table.view.metric : null);
  ui.chunks.textContent = `${s.chunksApplied} of ${s.chunkCount}`;
  ui.followed.textContent = s.orderFollowed === 'view-adapted' ? 'adapted to this view' : s.orderFollowed;
  ui.speed.textContent = s.applySeconds > 0
    ? `${(s.trianglesApplied / s.applySeconds / 1e6).toFixed(1)} million triangles/s` : '–';
}

function showBudget() {
  ui.budget.value = String(Math.round(budgetFraction * 100));
  ui.budgetValue.textContent = `${Math.round(budgetFraction * 100)}%`;
  ui.mark.style.left = `${100 * budgetFraction}%`;
}

function fillOrders(orders) {
  ui.order.replaceChildren(...orders.map((o) => {
    const option = document.createElement('option');
    option.value = option.textContent = o.name;
    return option;
  }));
  ui.order.value = orderName;
}

// ---- Loading and playing -------------------------------------------------------------------

let stream = null;
let removeLighting = null;  // the physical shading's light rig (addStreamLighting), while shown
let loading = null;   // the promise of the current load (resolves when it finished playing)

// Loads the package from scratch in `order` and plays it up to `fraction` of the file. Resolves
// with the final stats (also when superseded by another load); rejects on error.
function load(order, fraction, play) {
  if (stream) stream.dispose();
  orderName = order;
  budgetFraction = fraction;
  showBudget();
  // The first load takes over the request index.html started for the package's first bytes.
  const early = window.meshmuxFirstBytes && window.meshmuxFirstBytes.src === src ? window.meshmuxFirstBytes.response : null;
  window.meshmuxFirstBytes = null;
  const s = stream = new MeshmuxStream(src, { order, budgetBytes: Infinity, renderer, camera, adaptive, display, firstBytes: early,
    triangleBudget: triangles > 0 ? triangles : Infinity });
  ui.message.textContent = '';
  delete document.body.dataset.error;
  setState('loading');
  // Render at once: the stream applies one chunk per animation frame, so the renderer's work
  // on this step is done before the next chunk is decoded (no competition for the CPU).
  s.addEventListener('chunk', () => {
    if (s !== stream) return;
    if (document.body.dataset.state === 'settled') setState('streaming');
    renderNow();
  });
  // Played by view: the view is refined (or the budget full) until the camera moves.
  s.addEventListener('settled', () => { if (s === stream) { setState('settled'); renderNow(); } });
  // Bytes before the first picture (the table, the base): the panel shows them as they come.
  s.addEventListener('progress', () => { if (s === stream && s.state === 'opening') updatePanel(); });
  loading = (async () => {
    try {
      await s.open();
      if (s !== stream) return s.stats;
      scene.add(s.object);
      // Shade as the package's distortion was measured: three.js's colour management and the
      // light rig for physically based packages, stored bytes for Lambert ones.
      if (removeLighting) { removeLighting(); removeLighting = null; }
      if (s.table.view.physical) {
        renderer.outputColorSpace = THREE.SRGBColorSpace;
        removeLighting = addStreamLighting(s.table.view, scene, camera, renderer);
      } else {
        renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
      }
      if (!framed) frameDefault(s.worldBounds(), s.table.view);
      fillOrders(s.table.orders);
      s.budgetBytes = Math.max(Math.round(fraction * s.stats.bytesTotal), 0);
      if (s.notes.length) ui.message.textContent = `Note: ${s.notes.join('; ')}`;
      renderNow();
      setState('base');
      await nextFrame();
      if (s !== stream || !play) return s.stats;
      return await playStream(s);
    } catch (e) {
      // ?order= naming an order the package lacks: say so and play its own order.
      const unknown = /^meshmux: .*: no order "(.*)" \(the package has (.*)\)$/.exec(e && e.message);
      if (s === stream && unknown && order !== 'rate-distortion') {
        const note = `The order "${unknown[1]}" is not in this package (it has ${unknown[2]}); playing rate-distortion.`;
        const next = load('rate-distortion', fraction, play);
        ui.message.textContent = note;
        return next;
      }
      if (s === stream) showError(e);
      throw e;
    }
  })();
  return loading;
}

async function playStream(s) {
  setState('streaming');
  const stats = await s.play();
  if (s === stream) {
    renderNow();  // the last applied chunk is on screen before the state says so
    setState(stats.state === 'complete' ? 'complete' : 'stopped');
  }
  return stats;
}

// Budget slider: below what is received it changes nothing; above, it lets the stream go on.
function applyBudget() {
  showBudget();
  const s = stream;
  if (!s || !s.table || s.state === 'error' || s.state === 'disposed') return;
  const { bytesReceived, bytesTotal } = s.stats;
  const bytes = Math.round(budgetFraction * bytesTotal);
  s.budgetBytes = Math.max(bytes, bytesReceived);
  const more = s.stats.chunksApplied < s.stats.chunkCount;
  if (bytes > bytesReceived && more && !s.playing && ['base', 'stopped'].includes(document.body.dataset.state)) {
    playStream(s).catch((e) => { if (s === stream) showError(e); });
  }
}

ui.budget.addEventListener('input', () => {
  budgetFraction = clamp01(Number(ui.budget.value) / 100, 1);
  applyBudget();
});
ui.order.addEventListener('change', () => { replay(ui.order.value, budgetFraction).catch(() => {}); });
ui.replay.addEventListener('click', () => { replay(ui.order.value || orderName, budgetFraction).catch(() => {}); });
ui.reset.addEventListener('click', resetView);

function replay(order = orderName, fraction = budgetFraction) {
  return load(String(order), clamp01(Number(fraction), 1), true);
}

// ---- Test and scripting API ----------------------------------------------------------------

function view() {
  return {
    eye: camera.position.toArray(), target: controls.target.toArray(), up: camera.up.toArray(),
    fov: camera.fov, near: camera.near, far: camera.far,
  };
}

function setView(v = {}) {
  if (v.up) {
    const up = new THREE.Vector3().fromArray(v.up).normalize();
    if (!up.equals(camera.up)) {
      camera.up.copy(up);
      const target = controls.target.clone();
      controls.dispose();
      controls = makeControls();  // OrbitControls takes its orbit axis from camera.up
      controls.target.copy(target);
    }
  }
  if (v.eye) camera.position.fromArray(v.eye);
  if (v.target) controls.target.fromArray(v.target);
  if (v.fov !== undefined) camera.fov = v.fov;
  if (v.near !== undefined) camera.near = v.near;
  if (v.far !== undefined) camera.far = v.far;
  camera.lookAt(controls.target);
  camera.updateProjectionMatrix();
  framed = true;
  requestRender();
  return view();
}

// Renders the current scene and view into an offscreen RGBA8 target cleared to transparent
// black; returns the pixels top row first, base64-coded.
async function capture(width, height) {
  width = Math.floor(width);
  height = Math.floor(height);
  const max = renderer.capabilities.maxTextureSize;
  if (!(width >= 1 && height >= 1 && width <= max && height <= max)) throw new Error(`capture: size ${width}×${height} outside 1..${max}`);
  const target = new THREE.WebGLRenderTarget(width, height, {
    type: THREE.UnsignedByteType, format: THREE.RGBAFormat, depthBuffer: true, samples: 0,
    minFilter: THREE.LinearFilter, magFilter: THREE.LinearFilter, generateMipmaps: false,
  });
  target.texture.colorSpace = renderer.outputColorSpace;  // the bytes the canvas shows
  const saved = {
    aspect: camera.aspect, target: renderer.getRenderTarget(),
    color: renderer.getClearColor(new THREE.Color()), alpha: renderer.getClearAlpha(),
  };
  const pixels = new Uint8Array(width * height * 4);
  let reading;
  try {
    camera.aspect = width / height;
    camera.updateProjectionMatrix();
    renderer.setRenderTarget(target);
    renderer.setClearColor(0x000000, 0);
    renderer.clear(true, true, true);
    renderer.render(scene, camera);
    // Through a pixel buffer when possible: no stall of the GPU pipeline on the main thread.
    reading = renderer.readRenderTargetPixelsAsync
      ? renderer.readRenderTargetPixelsAsync(target, 0, 0, width, height, pixels)
      : renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
  } finally {
    // The page's state comes back at once (the read is already queued): a frame rendered
    // meanwhile goes to the canvas.
    renderer.setRenderTarget(saved.target);
    renderer.setClearColor(saved.color, saved.alpha);
    camera.aspect = saved.aspect;
    camera.updateProjectionMatrix();
  }
  try {
    await reading;
  } finally {
    target.dispose();
    requestRender();
  }
  // GL rows are bottom first: flip so row 0 is the top.
  const rows = new Uint8Array(pixels.length), stride = width * 4;
  for (let y = 0; y < height; y++) rows.set(pixels.subarray((height - 1 - y) * stride, (height - y) * stride), y * stride);
  return { width, height, rgba: toBase64(rows) };
}

function toBase64(bytes) {
  if (typeof bytes.toBase64 === 'function') return bytes.toBase64();
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

window.meshmuxViewer = {
  get stats() { return stream ? stream.stats : null; },
  get notes() { return stream ? stream.notes.slice() : []; },
  get stream() { return stream; },
  get done() { return loading; },
  orders: () => (stream && stream.table ? stream.table.orders.map((o) => o.name) : []),
  view, setView, capture, replay,
  render: renderNow,
  // The display the order is re-planned for from the next chunk on ([w, h] device pixels, or
  // null: the canvas); a replay keeps it.
  setDisplay(size) { display = size ? [Number(size[0]), Number(size[1])] : null; if (stream) stream.display = display; },
};

// Errors that escape anyway are shown rather than left in the console.
window.addEventListener('error', (e) => showError(e.error || new Error(e.message)));
window.addEventListener('unhandledrejection', (e) => { e.preventDefault(); showError(e.reason); });

// ---- Start ---------------------------------------------------------------------------------

showBudget();
resize();
load(orderName, budgetFraction, autoplay).catch(() => {});
