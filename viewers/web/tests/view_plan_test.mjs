// view_plan.js on tables built here (no browser): the interpolation weights, the steepest
// descent for a view, and the promise that an adapted order never does worse than the stored
// one for the view it was planned for.
import assert from 'node:assert/strict';
import { displayScale, layerChunks, pathArea, planRemaining, surface, textureAxis, viewWeights } from '../view_plan.js';

// An octahedron of views (6 directions, 8 triangles) over a 3 × 3 grid: chunks 0, 1 mesh
// layers, 2, 3 texture levels, stored order mesh, mesh, texture, texture (chunk index order).
const directions = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]];
const triangles = [];
for (const x of [0, 1]) for (const y of [2, 3]) for (const z of [4, 5]) triangles.push([x, y, z]);
// View 0 (+x) sees mostly texture (texture levels lower its distortion most), the others see
// mostly geometry (mesh layers do). Distortion of cell (i, j) from view v.
function cell(i, j, v) {
  const texture = v === 0 ? 6 : 1, mesh = v === 0 ? 1 : 6;
  return mesh * (2 - i) + texture * (2 - j);
}
const distortion = [];
for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) distortion.push(directions.map((_, v) => cell(i, j, v)));
const table = {
  chunks: [{ kind: 'mesh', size: 100 }, { kind: 'mesh', size: 100 }, { kind: 'texture', size: 100 }, { kind: 'texture', size: 100 }],
  orders: [{ name: 'rate-distortion', chunks: [0, 1, 2, 3] }],
  view_table: { directions, triangles, mesh_layers: 3, texture_layers: 3, distortion },
};
const stored = table.orders[0].chunks, layers = layerChunks(table);

// A sampled direction gets all the weight; a direction between views shares it linearly.
assert.deepEqual([...viewWeights(table.view_table, [2, 0, 0])], [1, 0, 0, 0, 0, 0]);
const mid = viewWeights(table.view_table, [1, 1, 0]);
assert.ok(Math.abs(mid[0] - 0.5) < 1e-9 && Math.abs(mid[2] - 0.5) < 1e-9, `weights ${[...mid]}`);
assert.ok(Math.abs(mid.reduce((a, b) => a + b, 0) - 1) < 1e-12);

// From +x the texture comes first; from +y the stored order (mesh first) already is the plan.
const fromX = planRemaining(table, viewWeights(table.view_table, [1, 0, 0]), new Set(), stored);
assert.deepEqual(fromX, { sequence: [2, 3, 0, 1], adapted: true });
const fromY = planRemaining(table, viewWeights(table.view_table, [0, 1, 0]), new Set(), stored);
assert.deepEqual(fromY, { sequence: stored, adapted: false });

// Never worse than the stored order for the view planned for, from any state.
for (const v of directions) {
  const w = viewWeights(table.view_table, v), D = surface(table.view_table, w);
  for (const applied of [[], [0], [0, 2], [0, 1], [2, 3]]) {
    const remaining = stored.filter((c) => !applied.includes(c));
    const plan = planRemaining(table, w, new Set(applied), remaining);
    const i = applied.filter((c) => c < 2).length, j = applied.length - i;
    assert.ok(pathArea(table, D, layers, i, j, plan.sequence) <= pathArea(table, D, layers, i, j, remaining), `view ${v}, applied ${applied}`);
    assert.deepEqual([...plan.sequence].sort(), [...remaining].sort(), 'the plan holds exactly the chunks left');
  }
}

// Cells without a measure: a plan goes around them ((1, 1) missing: texture, texture, then
// mesh), and where every next cell is unmeasured the stored order is kept.
const around = { ...table, view_table: { ...table.view_table, distortion: distortion.map((c, k) => (k === 4 ? null : c)) } };
assert.deepEqual(planRemaining(around, viewWeights(around.view_table, [1, 0, 0]), new Set(), stored),
  { sequence: [2, 3, 0, 1], adapted: true });
const blocked = { ...table, view_table: { ...table.view_table, distortion: distortion.map((c, k) => (k === 1 || k === 3 ? null : c)) } };
assert.deepEqual(planRemaining(blocked, viewWeights(blocked.view_table, [1, 0, 0]), new Set(), stored),
  { sequence: stored, adapted: false });
// The canvas. A package ordered for 1920×1080 with texture levels 512², 1024², 2048² (the
// base's 256²): the mesh layers gain 5, 3, 1 and the levels 4, 2, 1.5 per 100 bytes, so the
// stored order sends the top level before the last mesh layer. On a 640×360 canvas (a third of
// the display's rows) the 2048² level is what 6144² would be on the display: nothing any pixel
// resolves, so it must come after every mesh layer; the 1024² level reads the table 58.5 % of
// the way from 2048² to the top (3072² on the display); the base's level reads itself.
const meshGain = [5, 3, 1], textureGain = [4, 2, 1.5];
const sum = (a, from) => a.slice(from).reduce((x, y) => x + y, 0);
const sized = {
  view: { display: [1920, 1080] },
  chunks: [...meshGain.map(() => ({ kind: 'mesh', size: 100 })),
    ...[512, 1024, 2048].map((w) => ({ kind: 'texture', size: 100, width: w, height: w }))],
  orders: [{ name: 'rate-distortion', chunks: [0, 3, 1, 4, 5, 2] }],
  view_table: { directions: [[0, 0, 1]], triangles: [], mesh_layers: 4, texture_layers: 4, distortion: [] },
};
for (let i = 0; i < 4; i++) for (let j = 0; j < 4; j++) sized.view_table.distortion.push([sum(meshGain, i) + sum(textureGain, j)]);
assert.equal(displayScale(sized, [1920, 1080]), 1);
assert.equal(displayScale(sized, [3840, 2160]), 1, 'a larger canvas reads the table as it is');
assert.equal(displayScale(sized, null), 1);
assert.ok(Math.abs(displayScale(sized, [640, 360]) - 1 / 3) < 1e-12);
assert.equal(textureAxis(sized, 1), null);
const axis = textureAxis(sized, 1 / 3), third = Math.log2(3);
[0, 1 + third, 3, 3].forEach((x, j) => assert.ok(Math.abs(axis[j] - x) < 1e-9, `level ${j} reads ${axis[j]}, not ${x}`));
const one = [1], sizedStored = sized.orders[0].chunks;
assert.deepEqual(planRemaining(sized, one, new Set(), sizedStored), { sequence: sizedStored, adapted: false },
  'on the display it was ordered for, the stored order stands');
const small = planRemaining(sized, one, new Set(), sizedStored, axis);
assert.equal(small.adapted, true);
assert.equal(small.sequence.at(-1), 5, `on 640×360 the 2048² level comes last (${small.sequence})`);
assert.ok(small.sequence.indexOf(5) > small.sequence.indexOf(2), 'after every mesh layer');
// With the base's width in the table (texture_widths, the base's 256² first), the base reads
// the table where 768² would stand: 58.5 % of the way from 512² to 1024², no longer itself.
const widthed = { ...sized, view_table: { ...sized.view_table, texture_widths: [256, 512, 1024, 2048] } };
[1 + third - 1, 1 + third, 3, 3].forEach((x, j) => assert.ok(Math.abs(textureAxis(widthed, 1 / 3)[j] - x) < 1e-9,
  `with widths, level ${j} reads ${textureAxis(widthed, 1 / 3)[j]}, not ${x}`));
// A package of one texture level (SpecularTest: base 128², level 512²): on a third of the display
// the base reads 384², 79 % of the way to the level, so the level keeps a fifth of its display
// gain there; without the base's width (an older table) the base reads itself and the level all of it.
const oneLevel = { view: { display: [1920, 1080] }, chunks: [{ kind: 'mesh', size: 100 }, { kind: 'texture', size: 100, width: 512, height: 512 }],
  orders: [{ name: 'rate-distortion', chunks: [0, 1] }],
  view_table: { directions: [[0, 0, 1]], triangles: [], mesh_layers: 2, texture_layers: 2, distortion: [[2], [1], [1], [0]] } };
assert.deepEqual(textureAxis(oneLevel, 1 / 3), [0, 1]);
const oneAxis = textureAxis({ ...oneLevel, view_table: { ...oneLevel.view_table, texture_widths: [128, 512] } }, 1 / 3);
assert.ok(Math.abs(oneAxis[0] - third / 2) < 1e-9 && oneAxis[1] === 1, `one level with widths reads ${oneAxis}`);
// Read for the canvas, a level past what the canvas resolves gains nothing.
const Ds = surface(sized.view_table, one, axis);
for (let i = 0; i < 4; i++) assert.equal(Ds[i * 4 + 2], Ds[i * 4 + 3]);
console.log('view_plan: ok');
