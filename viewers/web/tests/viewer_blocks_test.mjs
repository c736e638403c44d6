// The viewer page (index.html) on a block package: played by view by default (?triangles,
// default 2M), it reaches the state "settled" with the triangles it holds within the budget and
// the view refined to a pixel; with ?triangles=0 it plays the stored order to "complete".
// usage: node viewer_blocks_test.mjs --meshmux BIN --package DIR (a `meshmux convert` output
//        of a big mesh) --work DIR [--chromium PATH]
import fs from 'node:fs';

import { checks, launch, opt, serve, skip } from './harness.mjs';

const meshmux = opt('--meshmux'), dir = opt('--package'), work = opt('--work'), chromiumPath = opt('--chromium', '/usr/bin/chromium');
if (!meshmux || !dir || !work) {
  console.error('usage: node viewer_blocks_test.mjs --meshmux BIN --package DIR --work DIR');
  process.exit(2);
}
if (!fs.existsSync(chromiumPath)) skip(`${chromiumPath} not installed`);
fs.mkdirSync(work, { recursive: true });
const { check, failures } = checks();
const { server, url } = await serve(meshmux, dir);
const { context, close } = await launch(work, chromiumPath);
try {
  const page = context.pages()[0] || (await context.newPage());
  const state = async (query, want) => {
    await page.goto(url + query);
    await page.waitForFunction((w) => [...w, 'error'].includes(document.body.dataset.state), want, { timeout: 120000, polling: 100 });
    return page.evaluate(() => ({ state: document.body.dataset.state, error: document.body.dataset.error, stats: window.meshmuxViewer.stats }));
  };
  const byView = await state('', ['settled']);
  const s = byView.stats;
  check(byView.state === 'settled', `by view: state ${byView.state}${byView.error ? ` (${byView.error})` : ''}`);
  check(s.residentTriangles > 0 && s.residentTriangles <= 2000000 && s.triangleBudget === 2000000,
    `by view: ${s.residentTriangles} triangles held of the default budget ${s.triangleBudget}, ${s.blocksHeld} of ${s.blockCount} blocks`);
  check(s.screenError <= 1, `by view: screen error ${s.screenError.toFixed(2)} px at the default view`);
  const stored = await state('?triangles=0', ['complete', 'stopped']);
  check(stored.state === 'complete' && stored.stats.residentTriangles === undefined,
    `?triangles=0: the stored order, ${stored.state}, ${stored.stats.triangles} triangles`);
} finally {
  await close();
  server.kill();
}
console.log(failures.length ? `FAIL: ${failures.length} check(s)` : 'PASS');
process.exit(failures.length ? 1 : 0);
