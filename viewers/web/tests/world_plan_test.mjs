// world_plan.js without a browser: the world file refused where it would leave its folder or
// draw nothing, the screen share of placed boxes, and the gains the world schedules by.
import assert from 'node:assert/strict';
import { chunkCost, chunkGain, packageDirection, screenShare, urlInsideWorld, validateWorld, viewWeights } from '../world_plan.js';

// ---- validateWorld ----------------------------------------------------------------------------
const id = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
const good = { meshmux_world: 1, packages: [{ name: 'Duck', url: 'Duck/model.mmxp', bounds: [0, 0, 0, 1, 1, 1], bytes: 10 }],
  placements: [{ package: 0, matrix: id }, { package: 0, matrix: [...id.slice(0, 12), 3, 0, 0, 1] }] };
const w = validateWorld(good);
assert.equal(w.packages.length, 1);
assert.equal(w.placements.length, 2, 'a package placed twice');
const refused = (json, says) => assert.throws(() => validateWorld(json, 'w.json'), (e) => {
  assert.ok(e.message.startsWith('meshmux: w.json: ') && e.message.includes(says), e.message);
  return true;
});
const withUrl = (url) => ({ ...good, packages: [{ ...good.packages[0], url }] });
// URLs that would read outside the world's folder: the same list batch/world.h refuses.
for (const url of ['../x.mmxp', 'a/../../b.mmxp', '/abs.mmxp', 'https://e.com/x.mmxp', 'javascript:alert(1)', 'a\\b', 'x?y', 'a/%2E%2e/b', ' //evil.example/x.mmxp', 'a/.. '])
  refused(withUrl(url), 'packages[0].url');
for (const url of ['Duck/model.mmxp', 'x..y/m.mmxp', './a.mmxp']) assert.ok(urlInsideWorld(url), url);
assert.doesNotThrow(() => validateWorld(withUrl('https://cdn.example.com/a.mmxp'), 'w.json', { allowExternalUrls: true }));
const withPlacement = (p) => ({ ...good, placements: [p] });
refused(withPlacement({ package: 1, matrix: id }), 'placements[0].package');
refused(withPlacement({ package: 0, matrix: id.slice(1) }), 'is not 16 numbers');
refused(withPlacement({ package: 0, matrix: [...id.slice(0, 15), 2] }), 'not affine');
refused(withPlacement({ package: 0, matrix: [1, 0, 0, 0, 2, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1] }), 'singular');
refused(withPlacement({ package: 0, matrix: [...id.slice(0, 12), 1e300, 0, 0, 1] }), 'not a finite coordinate');
refused({ ...good, meshmux_world: 2 }, 'version 2');
refused({ packages: [] }, 'not a meshmux world');
refused([], 'not a JSON object');
refused({ ...good, packages: [{ ...good.packages[0], bounds: [0, 0, 0, 1, -1, 1] }] }, 'minimum above its maximum');
// head_bytes: where the base ends (the first request's size); never past the package's end.
assert.equal(validateWorld({ ...good, packages: [{ ...good.packages[0], head_bytes: 7 }] }).packages[0].headBytes, 7);
assert.equal(w.packages[0].headBytes, 0, 'unknown: the client probes');
refused({ ...good, packages: [{ ...good.packages[0], head_bytes: 11 }] }, 'packages[0].head_bytes is more than');
refused({ ...good, packages: [{ ...good.packages[0], head_bytes: 1.5 }] }, 'packages[0].head_bytes is not a byte count');

// ---- screenShare --------------------------------------------------------------------------------
// A camera at the origin looking down −z, 90° vertical field, square: (x, y, z) → (x/−z, y/−z).
const n = 0.1, f = 100;
const proj = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, -(f + n) / (f - n), -1, 0, 0, -2 * f * n / (f - n), 0];
const box = [-0.5, -0.5, -0.5, 0.5, 0.5, 0.5];
const place = (x, y, z, s = 1) => [s, 0, 0, 0, 0, s, 0, 0, 0, 0, s, 0, x, y, z, 1];
const ahead = screenShare(box, place(0, 0, -10), proj);
assert.ok(ahead > 0.002 && ahead < 0.004, `a unit box 10 ahead covers ~1/300 of the screen: ${ahead}`);
assert.ok(screenShare(box, place(0, 0, -5), proj) > 3 * ahead, 'nearer is larger');
assert.equal(screenShare(box, place(0, 0, 10), proj), 0, 'behind the camera: nothing');
assert.equal(screenShare(box, place(30, 0, -10), proj), 0, 'off to the side: nothing');
assert.equal(screenShare(box, place(0, 0, 0, 4), proj), 1, 'around the camera: everything');
assert.ok(screenShare(box, place(0, 0, -10, 0.1), proj) < ahead / 50, 'tiny is tiny');

// packageDirection: the eye's direction in the package's own frame (a quarter turn about y).
const quarter = [0, 0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 5, 0, 0, 1];  // package x → world −z
const d = packageDirection([-1, -1, -1, 1, 1, 1], quarter, [5, 0, -3]);  // eye along world −z
assert.ok(Math.abs(d[0] - 3) < 1e-12 && Math.abs(d[1]) < 1e-12 && Math.abs(d[2]) < 1e-12, `direction ${d}`);

// ---- chunkGain, chunkCost ---------------------------------------------------------------------
// Two views (+x sees texture, −x sees geometry), a 2 × 2 grid: chunk 0 mesh, chunk 1 texture.
const directions = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]];
const triangles = [];
for (const x of [0, 1]) for (const y of [2, 3]) for (const z of [4, 5]) triangles.push([x, y, z]);
const cell = (i, j, v) => (v === 0 ? 1 * (1 - i) + 8 * (1 - j) : 8 * (1 - i) + 1 * (1 - j));
const distortion = [];
for (let i = 0; i < 2; i++) for (let j = 0; j < 2; j++) distortion.push(directions.map((_, v) => cell(i, j, v)));
const table = {
  chunks: [{ kind: 'mesh', size: 100, parts: [{ mesh: 0, face_begin: 10, face_end: 60 }] }, { kind: 'texture', size: 100, width: 64, height: 32 }],
  orders: [{ name: 'rate-distortion', chunks: [0, 1] }],
  meshes: [{}],
  view_table: { directions, triangles, mesh_layers: 2, texture_layers: 2, distortion },
};
const fromPlusX = [{ share: 0.5, weights: viewWeights(table.view_table, [1, 0, 0]) }];
const fromMinusX = [{ share: 0.5, weights: viewWeights(table.view_table, [-1, 0, 0]) }];
const none = new Set();
// Seen from +x the texture level buys 8 per unit of share, the mesh layer 1; from −x the reverse.
assert.ok(Math.abs(chunkGain(table, none, 1, fromPlusX, {}) - 0.5 * 8) < 1e-6);
assert.ok(Math.abs(chunkGain(table, none, 0, fromPlusX, {}) - 0.5 * 1) < 1e-6);
assert.ok(chunkGain(table, none, 0, fromMinusX, {}) > chunkGain(table, none, 1, fromMinusX, {}));
// Off screen: no gain, whatever the view says; twice the share, twice the gain.
assert.equal(chunkGain(table, none, 1, [{ share: 0, weights: fromPlusX[0].weights }], {}), 0);
const twice = chunkGain(table, none, 1, [...fromPlusX, ...fromPlusX], {});
assert.ok(Math.abs(twice - 2 * chunkGain(table, none, 1, fromPlusX, {})) < 1e-9);
// After the mesh layer, the texture level's gain is read at (1, 0) → (1, 1).
assert.ok(Math.abs(chunkGain(table, new Set([0]), 1, fromPlusX, {}) - 0.5 * 8) < 1e-6);
// Without a per-view table: the stored order's drop times the share.
const flat = { ...table, view_table: null };
assert.ok(Math.abs(chunkGain(flat, none, 0, fromPlusX, { before: 5, after: 2 }) - 0.5 * 3) < 1e-6);
assert.deepEqual(chunkCost(table, 0), { triangles: 50, texels: 0 });
assert.deepEqual(chunkCost(table, 1), { triangles: 0, texels: 2048 });
// A mesh the base draws three times (three nodes, or instances) adds its faces three times.
assert.deepEqual(chunkCost(table, 0, [3]), { triangles: 150, texels: 0 });
console.log('world_plan: validation, screen shares, directions and gains as expected');
