// view_plan.js on tables built here (no browser): the interpolation weights, the steepest
// descent for a view, and the promise that an adapted order never does worse than the stored
// one for the view it was planned for.
import assert from 'node:assert/strict';
import { layerChunks, pathArea, planRemaining, surface, viewWeights } from '../view_plan.js';

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
console.log('view_plan: ok');
