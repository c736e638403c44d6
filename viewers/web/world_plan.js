// world_plan.js — what MeshmuxWorld decides with, without the DOM: the world file validated like
// a package table, each placement's share of the screen, and the gain of a package's next chunk
// (its distortion drop on the package's per-view surface for the camera's direction, view_plan.js)
// weighted by that share. The world streams the chunk of best gain per byte next, across every
// package; what is off screen gains nothing and waits, what is tiny gains little.
//
// world.json: its spec is stream/world_format.h (written by `meshmux batch`, read by
// `meshmux info` with the same rules); its version and limits come from there, generated into
// stream_format.js at build time (scripts/format_constants.mjs).

import { WORLD_MAX_BYTES, WORLD_MAX_COORDINATE, WORLD_MAX_PACKAGES, WORLD_MAX_PLACEMENTS, WORLD_VERSION } from './stream_format.js';
import { layerChunks, surface, viewWeights } from './view_plan.js';

export { WORLD_VERSION };
export const WORLD_LIMITS = Object.freeze({ maxBytes: WORLD_MAX_BYTES, maxPackages: WORLD_MAX_PACKAGES, maxPlacements: WORLD_MAX_PLACEMENTS });
const MAX_COORDINATE = WORLD_MAX_COORDINATE;

// Whether a URL stays inside the world's folder: no scheme, no leading '/', no '\', no '..'
// segment (also percent-encoded, any case), no query or fragment, no space or control character.
export function urlInsideWorld(url) {
  if (typeof url !== 'string' || url.length === 0 || url.length > 2048 || url[0] === '/') return false;
  // Spaces too: URL parsers strip them at the ends (" //host/x" would leave the site).
  if (/[\u0000-\u0020\u007f\\?#]/.test(url)) return false;
  const colon = url.indexOf(':'), slash = url.indexOf('/');
  if (colon >= 0 && (slash < 0 || colon < slash)) return false;
  return !url.split('/').some((s) => /^(\.|%2e){2}$/i.test(s));
}

// The world file's JSON (parsed) validated: { packages, placements }, or an Error naming `file`
// and the element. options.allowExternalUrls lifts the folder rule (trusted worlds only).
export function validateWorld(json, file = 'world.json', options = {}) {
  const fail = (what) => { throw new Error(`meshmux: ${file}: ${what}`); };
  const isObj = (x) => x !== null && typeof x === 'object' && !Array.isArray(x);
  const numbers = (x, n, where) => {
    if (!Array.isArray(x) || x.length !== n) fail(`${where} is not ${n} numbers`);
    x.forEach((v, i) => {
      if (typeof v !== 'number' || !Number.isFinite(v) || Math.abs(v) > MAX_COORDINATE) fail(`${where}[${i}] is not a finite coordinate`);
    });
    return x.slice();
  };
  if (!isObj(json)) fail('not a JSON object');
  if (json.meshmux_world === undefined) fail('not a meshmux world (no "meshmux_world" version)');
  if (json.meshmux_world !== WORLD_VERSION) fail(`world version ${JSON.stringify(json.meshmux_world)} (this library reads version ${WORLD_VERSION})`);
  if (!Array.isArray(json.packages)) fail('"packages" is missing or not an array');
  if (json.packages.length > WORLD_LIMITS.maxPackages) fail(`${json.packages.length} packages (at most ${WORLD_LIMITS.maxPackages})`);
  const packages = json.packages.map((p, i) => {
    const w = `packages[${i}]`;
    if (!isObj(p)) fail(`${w} is not an object`);
    if (typeof p.url !== 'string' || !p.url) fail(`${w}.url is missing or not a string`);
    if (!options.allowExternalUrls && !urlInsideWorld(p.url)) fail(`${w}.url ${JSON.stringify(p.url)} leaves the world's folder`);
    if (p.name !== undefined && (typeof p.name !== 'string' || p.name.length > 256)) fail(`${w}.name is not a string of at most 256 bytes`);
    const bounds = numbers(p.bounds, 6, `${w}.bounds`);
    for (let a = 0; a < 3; a++) if (bounds[a] > bounds[a + 3]) fail(`${w}.bounds has a minimum above its maximum`);
    if (p.bytes !== undefined && !(Number.isSafeInteger(p.bytes) && p.bytes >= 0)) fail(`${w}.bytes is not a byte count`);
    if (p.head_bytes !== undefined && !(Number.isSafeInteger(p.head_bytes) && p.head_bytes >= 0)) fail(`${w}.head_bytes is not a byte count`);
    if (p.bytes > 0 && p.head_bytes > p.bytes) fail(`${w}.head_bytes is more than the package's bytes`);
    return { name: p.name === undefined ? p.url : p.name, url: p.url, bounds, bytes: p.bytes || 0, headBytes: p.head_bytes || 0 };
  });
  if (!Array.isArray(json.placements)) fail('"placements" is missing or not an array');
  if (json.placements.length > WORLD_LIMITS.maxPlacements) fail(`${json.placements.length} placements (at most ${WORLD_LIMITS.maxPlacements})`);
  const placements = json.placements.map((p, i) => {
    const w = `placements[${i}]`;
    if (!isObj(p)) fail(`${w} is not an object`);
    if (!Number.isSafeInteger(p.package) || p.package < 0 || p.package >= packages.length)
      fail(`${w}.package is not the index of a package (0 to ${packages.length} - 1)`);
    const m = numbers(p.matrix, 16, `${w}.matrix`);
    if (m[3] !== 0 || m[7] !== 0 || m[11] !== 0 || m[15] !== 1) fail(`${w}.matrix is not affine (its last row must be 0 0 0 1)`);
    const det = m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) + m[8] * (m[1] * m[6] - m[5] * m[2]);
    if (!(Math.abs(det) > 0) || !Number.isFinite(det)) fail(`${w}.matrix is singular`);
    return { package: p.package, matrix: m };
  });
  return { packages, placements };
}

// The share of the screen (0 to 1) the box `bounds` (6 numbers) placed by `matrix` (16,
// column-major) covers, seen through `viewProjection` (16, column-major: projection × view):
// the screen rectangle around its corners, clipped to the screen. 0 when it is wholly behind the
// camera or off screen; 1 when the camera is inside it or it straddles the camera's plane.
export function screenShare(bounds, matrix, viewProjection) {
  let minX = Infinity, minY = Infinity, maxX = -Infinity, maxY = -Infinity, behind = 0;
  const m = matrix, p = viewProjection;
  for (let c = 0; c < 8; c++) {
    const x0 = bounds[c & 1 ? 3 : 0], y0 = bounds[c & 2 ? 4 : 1], z0 = bounds[c & 4 ? 5 : 2];
    const x = m[0] * x0 + m[4] * y0 + m[8] * z0 + m[12];
    const y = m[1] * x0 + m[5] * y0 + m[9] * z0 + m[13];
    const z = m[2] * x0 + m[6] * y0 + m[10] * z0 + m[14];
    const cx = p[0] * x + p[4] * y + p[8] * z + p[12];
    const cy = p[1] * x + p[5] * y + p[9] * z + p[13];
    const cw = p[3] * x + p[7] * y + p[11] * z + p[15];
    if (!(cw > 1e-9)) { behind++; continue; }
    minX = Math.min(minX, cx / cw); maxX = Math.max(maxX, cx / cw);
    minY = Math.min(minY, cy / cw); maxY = Math.max(maxY, cy / cw);
  }
  if (behind === 8) return 0;
  if (behind > 0) return 1;  // straddles the camera's plane: as near as it gets
  const w = Math.min(maxX, 1) - Math.max(minX, -1), h = Math.min(maxY, 1) - Math.max(minY, -1);
  return w > 0 && h > 0 ? (w * h) / 4 : 0;
}

// The direction from a placed box's centre to the eye, in the package's own frame (the frame of
// its per-view table), for viewWeights.
export function packageDirection(bounds, matrix, eye) {
  const c = [(bounds[0] + bounds[3]) / 2, (bounds[1] + bounds[4]) / 2, (bounds[2] + bounds[5]) / 2];
  const m = matrix;
  const world = [0, 1, 2].map((r) => m[r] * c[0] + m[4 + r] * c[1] + m[8 + r] * c[2] + m[12 + r]);
  const d = [eye[0] - world[0], eye[1] - world[1], eye[2] - world[2]];
  // The 3x3 part's inverse applied to d (Cramer's rule).
  const a = [[m[0], m[4], m[8]], [m[1], m[5], m[9]], [m[2], m[6], m[10]]];
  const det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
    a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  const col = (k) => a.map((row, r) => row.map((v, j) => (j === k ? d[r] : v)));
  const det3 = (b) => b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1]) - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0]) +
    b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
  return [det3(col(0)) / det, det3(col(1)) / det, det3(col(2)) / det];
}

// The distortion drop of applying `next` (a chunk index of the table) in state `applied` (the
// chunks applied so far, a Set), seen from the directions whose view weights are given (one
// weight array per placement, each with the placement's screen share): Σ share × (D(before) −
// D(after)) on the package's per-view surface, plus a hair per visible placement so that a chunk
// on screen whose measured drop is nil still comes (last). Without a per-view table, the stored
// order's view-independent distortions (`fallback`: before and after) times the total share.
// `axis` (view_plan.js textureAxis, optional): the surface read for the canvas.
export function chunkGain(table, applied, next, placements, fallback, axis = null) {
  const vt = table.view_table;
  let total = 0;
  if (!vt) {
    const share = placements.reduce((s, p) => s + p.share, 0);
    return share * (Math.max(0, fallback.before - fallback.after) + 1e-9);
  }
  const layers = layerChunks(table), n = vt.texture_layers;
  let i = 0, j = 0;
  while (i < layers.mesh.length && applied.has(layers.mesh[i])) i++;
  while (j < layers.texture.length && applied.has(layers.texture[j])) j++;
  const after = table.chunks[next].kind !== 'texture' ? [i + 1, j] : [i, j + 1];
  for (const p of placements) {
    if (!(p.share > 0)) continue;
    const D = surface(vt, p.weights, axis);
    const before = D[i * n + j], then = D[after[0] * n + after[1]];
    const drop = Number.isFinite(before) && Number.isFinite(then) ? before - then
      : Math.max(0, fallback.before - fallback.after);
    // A visible chunk always gains a little (its measured drop may be nil): it comes last, not never.
    total += p.share * (Math.max(0, drop) + 1e-9);
  }
  return total;
}

// Triangles a mesh chunk adds (its parts' faces, each times the times its mesh is drawn:
// `instances[mesh]`, the objects and instances drawing it in the base, default 1; an upper
// bound: a split may retire faces) and texels a texture chunk brings (its level's size), for
// the memory budget.
export function chunkCost(table, index, instances = []) {
  const c = table.chunks[index];
  if (c.kind === 'texture') return { triangles: 0, texels: c.width * c.height };
  let faces = 0;
  for (const p of c.parts) faces += (p.face_end - p.face_begin) * Math.max(1, instances[p.mesh] || 1);
  // The completion: each mesh's full faces in place of those its splits held.
  for (const e of c.meshes || []) faces += Math.max(0, e.faces - e.face_begin) * Math.max(1, instances[e.mesh] || 1);
  return { triangles: faces, texels: 0 };
}

export { viewWeights };
