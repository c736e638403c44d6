// The view-adaptive check: for each converted folder's package with a per-view table, and each
// sampled view v of its viewing sphere, the area under distortion-vs-bytes seen from v (the table's
// measures from v) with the order the client plans for a camera at v (viewers/web/view_plan.js)
// against the stored (global) order's. Prints a table and whether every view's adapted area is at
// most the global one.
//
// usage: node bench/view_adaptive.mjs OUT [OUT ...]   (folders written by meshmux convert)
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { rawTableOf, validateTable } from '../viewers/web/package_reader.js';
import { layerChunks, pathArea, planRemaining, surface, viewWeights } from '../viewers/web/view_plan.js';

const rows = [];
let allMet = true;
for (const out of process.argv.slice(2)) {
  const name = path.basename(path.resolve(out));
  const file = path.join(out, 'model.mmxp');
  if (!fs.existsSync(file)) { rows.push(`| ${name} | no package | | | | | |`); continue; }
  const bytes = fs.readFileSync(file);
  const tableSize = bytes.readUInt32LE(8);
  const { raw } = rawTableOf(bytes, zlib.inflateSync, (m) => new Error(`${name}: ${m}`));  // a block index merged in
  const table = validateTable(raw, { fileSize: bytes.length, dataStart: 12 + tableSize, fail: (m) => new Error(`${name}: ${m}`) });
  const vt = table.view_table;
  if (!vt) { rows.push(`| ${name} | no choice (${table.chunks.length} chunks of one kind or none) | | | | | |`); continue; }
  const layers = layerChunks(table), stored = table.orders[0].chunks;
  let adaptedViews = 0, sumGain = 0, minGain = Infinity, maxGain = -Infinity, met = true;
  for (let v = 0; v < vt.directions.length; v++) {
    const w = viewWeights(vt, vt.directions[v]);
    const plan = planRemaining(table, w, new Set(), stored);
    const D = surface(vt, w);
    const a = pathArea(table, D, layers, 0, 0, plan.sequence), g = pathArea(table, D, layers, 0, 0, stored);
    const gain = g > 0 ? 1 - a / g : 0;
    adaptedViews += plan.adapted;
    sumGain += gain;
    minGain = Math.min(minGain, gain);
    maxGain = Math.max(maxGain, gain);
    if (a > g * (1 + 1e-12)) met = false;
  }
  allMet &&= met;
  const pct = (x) => `${(100 * x).toFixed(2)}%`;
  rows.push(`| ${name} | ${vt.mesh_layers} × ${vt.texture_layers} | ${vt.directions.length} | ${adaptedViews} | ${pct(sumGain / vt.directions.length)} | ${pct(minGain)} .. ${pct(maxGain)} | ${met ? 'yes' : 'NO'} |`);
}
console.log('| model | grid (mesh × texture) | views | views re-planned | mean area gain | gain range | adapted ≤ global on every view |');
console.log('|---|---|---:|---:|---:|---|---|');
for (const r of rows) console.log(r);
process.exitCode = allMet ? 0 : 1;
