// view_plan.js — the order re-planned for the viewer's own camera (Yang, Shen and Kuo,
// "Progressive coding of 3D textured graphic model via joint mesh-texture optimization" §3).
//
// The package's "view_table" holds the distortion of every cell (i mesh layers received, j
// texture levels received) seen from each view of the viewing sphere, and the viewing mesh over
// those views. For a camera direction, the surface is interpolated linearly over the viewing-mesh
// triangle around it (barycentric weights of its three views: Yang, Shen and Kuo §3 interpolate
// from the triangle's vertices; their printed weights grow with the distance, which would favour
// the far view, so we use the linear interpolation the text describes). On that surface the
// steepest descent of their §2 plans the remaining moves; the plan is followed only where its area
// under distortion-vs-bytes is below the stored order's remainder on the same surface, so an
// adapted order is never worse than the stored one for the view it was planned for.
//
// Moves: the k-th mesh chunk of the stored order is mesh layer k + 1, the k-th texture chunk
// texture level k + 1 (the stored order moves one layer at a time, each axis in order).
//
// The canvas: the table was measured for a display (the table's view.display, device pixels;
// the renders sample textures with that display's pixel footprint). On a canvas whose smaller
// side is a fraction s < 1 of the display's, mip selection needs 1/s fewer texels per side: the
// picture with texture level j there is the display's picture with the level 1/s times wider,
// drawn smaller. So the client reads the table's texture axis at that wider level
// (displayScale / textureAxis below; log-linear between levels, the top level where the wider
// one does not exist): levels no pixel of the canvas resolves gain nothing there and go after
// everything that can be seen (kept for zooming in; planRemaining puts them after every mesh
// layer whatever the slopes). A canvas as large as the display or larger reads the table as it is.

// Per-view weights (summing to 1) for a direction from the model's centre (any length).
export function viewWeights(viewTable, direction) {
  const dirs = viewTable.directions, n = dirs.length;
  const len = Math.hypot(direction[0], direction[1], direction[2]);
  const w = new Float64Array(n);
  if (!(len > 0)) { w.fill(1 / n); return w; }
  const d = [direction[0] / len, direction[1] / len, direction[2] / len];
  // The triangle whose cone holds d: d = a·A + b·B + c·C with a, b, c ≥ 0.
  let best = null, bestMin = -Infinity;
  for (const [ia, ib, ic] of viewTable.triangles) {
    const A = dirs[ia], B = dirs[ib], C = dirs[ic];
    const det = dot(A, cross(B, C));
    if (Math.abs(det) < 1e-12) continue;
    const a = dot(d, cross(B, C)) / det, b = dot(A, cross(d, C)) / det, c = dot(A, cross(B, d)) / det;
    const m = Math.min(a, b, c);
    if (m > bestMin) { bestMin = m; best = [ia, ib, ic, a, b, c]; }
  }
  if (!best || bestMin < -1e-9) {  // no triangle around it: the nearest view
    let k = 0;
    for (let v = 1; v < n; v++) if (dot(dirs[v], d) > dot(dirs[k], d)) k = v;
    w[k] = 1;
    return w;
  }
  const [ia, ib, ic] = best;
  let [a, b, c] = best.slice(3).map((x) => Math.max(0, x));
  const s = a + b + c;
  w[ia] += a / s; w[ib] += b / s; w[ic] += c / s;
  return w;
}

function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }

// The interpolated surface: per cell (i × texture_layers + j) the weighted distortion, or NaN
// where the table has no measure. With `axis` (textureAxis: per texture level, the fractional
// level of the table it reads), the texture axis is read there: the surface for a canvas.
export function surface(viewTable, weights, axis = null) {
  const D = viewTable.distortion.map((cell) => {
    if (!cell) return NaN;
    let s = 0;
    for (let v = 0; v < cell.length; v++) s += weights[v] * cell[v];
    return s;
  });
  if (!axis) return D;
  const n = viewTable.texture_layers, out = new Array(D.length);
  for (let i = 0; i < viewTable.mesh_layers; i++)
    for (let j = 0; j < n; j++) {
      const x = Math.min(n - 1, Math.max(j, axis[j])), lo = Math.floor(x), hi = Math.min(n - 1, lo + 1), f = x - lo;
      out[i * n + j] = f > 0 ? (1 - f) * D[i * n + lo] + f * D[i * n + hi] : D[i * n + lo];
    }
  return out;
}

// The canvas against the table's display: the ratio of their smaller sides (device pixels),
// at most 1; 1 where either is unknown.
export function displayScale(table, canvas) {
  const d = table && table.view && table.view.display;
  if (!d || !canvas) return 1;
  const have = Math.min(canvas[0], canvas[1]), made = Math.min(d[0], d[1]);
  return have > 0 && made > 0 ? Math.min(1, have / made) : 1;
}

// Per texture level j (0: the base's, then each texture chunk's), the fractional level of the
// table whose picture on the display is level j's on a canvas `scale` (displayScale) of it:
// the level 1/scale times wider, log-linear between the levels' widths, the top level past
// them; null where the table needs no re-reading (scale 1, no texture levels). The widths are
// the table's texture_widths (the base's first). An older table has none and its chunks give
// every width but the base's: there the base reads itself (guessing it one step below the first
// level made a one-level package's only level look unresolvable on a small canvas, where the
// base was four times smaller still).
export function textureAxis(table, scale) {
  const vt = table.view_table;
  if (!vt || !(scale < 1) || vt.texture_layers < 2) return null;
  const known = Array.isArray(vt.texture_widths) && vt.texture_widths.length === vt.texture_layers;
  const widths = known ? vt.texture_widths.map((w) => Math.max(1, w))
    : [0, ...layerChunks(table).texture.map((c) => Math.max(1, table.chunks[c].width || 1))];
  if (widths.length !== vt.texture_layers) return null;
  const logs = widths.map((w) => Math.log2(Math.max(1, w))), top = logs.length - 1;
  return logs.map((l, j) => {
    if (j === 0 && !known) return 0;
    const want = l - Math.log2(scale);
    let x = j;
    for (let k = j; k < top; k++) {
      if (want >= logs[k + 1]) { x = k + 1; continue; }
      if (logs[k + 1] > logs[k] && want > logs[k]) x = k + (want - logs[k]) / (logs[k + 1] - logs[k]);
      break;
    }
    return x;
  });
}

// The chunk of each move: mesh[k] the chunk of mesh layer k + 1, texture[k] of level k + 1.
export function layerChunks(table) {
  const mesh = [], texture = [];
  for (const index of table.orders[0].chunks) (table.chunks[index].kind !== 'texture' ? mesh : texture).push(index);
  return { mesh, texture };
}

// The state after the chunks `applied` (a set or array of chunk indices): (i, j).
function stateOf(layers, applied) {
  const has = applied instanceof Set ? applied : new Set(applied);
  let i = 0, j = 0;
  while (i < layers.mesh.length && has.has(layers.mesh[i])) i++;
  while (j < layers.texture.length && has.has(layers.texture[j])) j++;
  return [i, j];
}

// Area under the step curve of `sequence` (chunk indices) from state (i, j) on surface D: each
// distortion holds while the next chunk's bytes arrive. Infinity where a cell is not measured.
export function pathArea(table, D, layers, i, j, sequence) {
  const n = table.view_table.texture_layers;
  let area = 0;
  for (const index of sequence) {
    const d = D[i * n + j];
    if (!Number.isFinite(d)) return Infinity;
    area += d * table.chunks[index].size;
    if (table.chunks[index].kind !== 'texture') i++; else j++;
  }
  return area;
}

// The remaining chunks for the view whose weights are given, after `applied` chunks (the
// sequence's prefix): { sequence, adapted } — the steepest descent on the interpolated surface
// (read for the canvas when `axis` is given: textureAxis) when its area is below the stored
// order's remainder (`stored`, the chunks not yet applied in the order being followed), else
// `stored` itself.
export function planRemaining(table, weights, applied, stored, axis = null) {
  const vt = table.view_table;
  if (!vt) return { sequence: stored, adapted: false };
  const layers = layerChunks(table), D = surface(vt, weights, axis), n = vt.texture_layers;
  // The stored remainder with the levels the canvas cannot resolve after every mesh layer: what
  // a plan must beat, and what is played when none does.
  const kept = deferUnresolved(layers, stored, axis, n);
  if (kept !== stored) {
    const plan = planRemaining(table, weights, applied, kept, axis);
    return { sequence: plan.sequence, adapted: true };
  }
  let [i, j] = stateOf(layers, applied);
  const i0 = i, j0 = j, plan = [];
  while (i < layers.mesh.length || j < layers.texture.length) {
    const here = D[i * n + j];
    let pick = null, best = -Infinity;
    if (i < layers.mesh.length) {
      const c = layers.mesh[i], next = D[(i + 1) * n + j];
      const slope = (here - next) / Math.max(1, table.chunks[c].size);
      if (Number.isFinite(slope) && slope > best) { best = slope; pick = 'mesh'; }
    }
    // A level the canvas cannot resolve (the one before it already reads the table's top level)
    // waits until every mesh layer is in, whatever the measured slopes say (zero for it; a
    // last mesh layer's may be below zero by a hair of noise).
    const unresolved = axis && j < layers.texture.length && axis[j] >= n - 1 - 1e-9;
    if (j < layers.texture.length && (!unresolved || i >= layers.mesh.length)) {
      const c = layers.texture[j], next = D[i * n + j + 1];
      const slope = (here - next) / Math.max(1, table.chunks[c].size);
      if (Number.isFinite(slope) && slope > best) { best = slope; pick = 'texture'; }
    }
    if (!pick) return { sequence: stored, adapted: false };  // a cell without a measure
    if (pick === 'mesh') plan.push(layers.mesh[i++]); else plan.push(layers.texture[j++]);
  }
  const adaptedArea = pathArea(table, D, layers, i0, j0, plan);
  const storedArea = pathArea(table, D, layers, i0, j0, stored);
  const same = plan.length === stored.length && plan.every((c, k) => c === stored[k]);
  return adaptedArea < storedArea && !same ? { sequence: plan, adapted: true } : { sequence: stored, adapted: false };
}

// `sequence` with the texture chunks of levels the canvas cannot resolve (axis: the one before
// them already reads the table's top level) moved after its last mesh chunk, in their order;
// `sequence` itself when none has to move.
function deferUnresolved(layers, sequence, axis, n) {
  if (!axis) return sequence;
  const level = new Map(layers.texture.map((c, k) => [c, k]));  // chunk → the state it leaves
  const late = (c) => level.has(c) && axis[level.get(c)] >= n - 1 - 1e-9;
  const lastMesh = sequence.reduce((at, c, k) => (level.has(c) ? at : k), -1);
  if (!sequence.some((c, k) => late(c) && k < lastMesh)) return sequence;
  return [...sequence.filter((c) => !late(c)), ...sequence.filter(late)];
}

// The view-independent distortion (the mean over views) after each chunk of `sequence`, from
// the start: what the stats report as the expected distortion.
export function sequenceDistortion(table, sequence) {
  const vt = table.view_table, layers = layerChunks(table), n = vt.texture_layers;
  const views = vt.directions.length, out = [];
  let i = 0, j = 0;
  for (const index of sequence) {
    if (table.chunks[index].kind !== 'texture') i++; else j++;
    const cell = vt.distortion[i * n + j];
    out.push(cell ? cell.reduce((a, b) => a + b, 0) / views : NaN);
  }
  return out;
}
