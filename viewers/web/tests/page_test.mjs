// The viewer page's details, in Debian's headless chromium through playwright-core, on the built-in
// sample converted and served by `meshmux serve`:
//   - opened from disk (file://) it says how to serve it instead of "loading" forever;
//   - ?order=bogus plays the package's own order and says why;
//   - ?adaptive=0 plays the stored order as it is (the library's adaptive: false; default true);
//   - sizes are in decimal units, as the command line prints them; the stats are in words;
//   - a resize (a phone's rotation) re-frames the model until the user moves the camera;
//   - "Reset view" brings the default camera back; zoom stays within limits.
//
// usage: node page_test.mjs --meshmux BIN --work DIR [--chromium PATH]
// Exit: 0 pass, 1 fail, 77 skipped (no chromium: said on stderr).
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { browserTestArgs, checks, launch, serve } from './harness.mjs';

const { meshmux, work, chromiumPath } = browserTestArgs('page_test.mjs');
const { check, failures } = checks();

fs.rmSync(work, { recursive: true, force: true });
fs.mkdirSync(work, { recursive: true });
const out = path.join(work, 'out');
for (const argv of [['sample', '-o', path.join(work, 's.glb'), '-q'], ['convert', path.join(work, 's.glb'), '-o', out, '-q']]) {
  const r = spawnSync(meshmux, argv, { encoding: 'utf8' });
  if (r.status !== 0) throw new Error(`meshmux ${argv[0]} exited ${r.status}: ${r.stderr}`);
}
const { server, url } = await serve(meshmux, out);
const { context, close: closeBrowser } = await launch(work, chromiumPath);
const settled = (page) => page.waitForFunction(() => ['complete', 'stopped', 'error'].includes(document.body.dataset.state),
  null, { timeout: 120000, polling: 100 });
try {
  const page = context.pages()[0] || (await context.newPage());

  // From disk.
  await page.goto('file://' + path.join(out, 'index.html'));
  const diskState = await page.evaluate(() => document.body.dataset.state);
  const diskMessage = await page.evaluate(() => document.getElementById('message').textContent);
  check(diskState === 'error' && /meshmux serve/.test(diskMessage), `file:// explains itself: "${diskMessage}"`);

  // A bad order.
  await page.goto(url + '?order=bogus');
  await settled(page);
  const bogus = await page.evaluate(() => ({
    state: document.body.dataset.state, message: document.getElementById('message').textContent,
    order: window.meshmuxViewer.stats.order, options: window.meshmuxViewer.orders(),
  }));
  check(bogus.state === 'complete' && bogus.order === 'rate-distortion', `?order=bogus plays rate-distortion (${bogus.state}, ${bogus.order})`);
  check(/"bogus" is not in this package/.test(bogus.message), `and says why: "${bogus.message}"`);
  check(bogus.options.length >= 2, `the order list is filled (${bogus.options.join(', ')})`);

  // ?adaptive=0: the stored order, never re-planned for the camera (bench/rd_client.mjs --stored).
  check(await page.evaluate(() => window.meshmuxViewer.stream.options.adaptive === true), 'the stream re-plans for the camera by default');
  await page.goto(url + '?adaptive=0');
  await settled(page);
  const stored = await page.evaluate(() => ({ adaptive: window.meshmuxViewer.stream.options.adaptive, state: document.body.dataset.state,
    followed: window.meshmuxViewer.stats.orderFollowed }));
  check(stored.adaptive === false && stored.state === 'complete' && stored.followed === 'rate-distortion',
    `?adaptive=0 plays the stored order (adaptive ${stored.adaptive}, ${stored.state}, ${stored.followed})`);
  await page.goto(url + '?order=bogus');
  await settled(page);

  // Units and words.
  const panel = await page.evaluate(() => document.getElementById('stats').innerText);
  check(/\d kB|\d MB/.test(panel) && !/KB|MiB/.test(panel), `decimal units in the panel: ${panel.replace(/\s+/g, ' ')}`);
  check(/Difference from final/.test(panel) && !/Distortion|Chunks/.test(panel), 'the stats are named in words');

  // Resize: re-framed while the user has not moved. The model's projected size is measured by
  // the camera distance against the viewport's smaller side.
  const distance = () => page.evaluate(() => {
    const v = window.meshmuxViewer.view();
    return Math.hypot(v.eye[0] - v.target[0], v.eye[1] - v.target[1], v.eye[2] - v.target[2]);
  });
  const wide = await distance();
  await page.setViewportSize({ width: 400, height: 800 });  // a phone, upright
  await page.waitForTimeout(300);
  const tall = await distance();
  check(tall > wide * 1.2, `a portrait viewport re-frames (distance ${wide.toFixed(3)} → ${tall.toFixed(3)})`);

  // Zoom limits, then Reset view.
  const box = await page.locator('#view').boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  // Unlimited, 200 steps in would bring the camera to a thousandth of its distance, 300 out
  // to a million times it.
  for (let i = 0; i < 200; ++i) await page.mouse.wheel(0, -400);
  await page.waitForTimeout(200);
  const closest = await distance();
  for (let i = 0; i < 300; ++i) await page.mouse.wheel(0, 400);
  await page.waitForTimeout(200);
  const farthest = await distance();
  check(closest > 0.01 * tall && farthest < 11 * tall, `zoom is limited (${closest.toFixed(3)} .. ${farthest.toFixed(3)}, framed at ${tall.toFixed(3)})`);
  await page.setViewportSize({ width: 960, height: 720 });  // moved: a resize keeps the camera
  await page.waitForTimeout(300);
  check(Math.abs((await distance()) - farthest) < 1e-6, 'after the user moved, a resize keeps the camera');
  await page.click('#reset-view');
  await page.waitForTimeout(200);
  check(Math.abs((await distance()) - wide) < 1e-3 * wide, `Reset view brings the default camera back (${(await distance()).toFixed(3)})`);
} finally {
  await closeBrowser();
  server.kill();
}
process.exitCode = failures.length ? 1 : 0;
