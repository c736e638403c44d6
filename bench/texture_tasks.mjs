// The page's main thread while a package's texture levels arrive, per converted folder: the
// library (viewer/meshmux.js) plays the package in headless chromium with a WebGLRenderer of its
// own (an offscreen canvas, never drawn: its texture levels go to the GPU inside the traced
// tasks, KTX2 maps transcoded to what that GPU reads), and every task over 16 ms between the
// first chunk and "complete" is given to its owner (bench/main_thread.mjs: the library, the
// browser's commits, other), with the library's functions that held it. Also the GPU bytes the
// finished stream's textures hold (stats.gpuBytes) against the same textures as RGBA8.
// Used by bench/textures.sh for JPEG/PNG against KTX2 folders of the same model.
//
// usage: node bench/texture_tasks.mjs --meshmux BIN --dirs DIR[,DIR...] [--json FILE]
//        [--chromium /usr/bin/chromium] [--repeat 3]
// Prints one line per folder; --json writes them all. Run alone: the milliseconds are the
// machine's (llvmpipe in chromium), and another job's load lengthens every task.
import fs from 'node:fs';
import path from 'node:path';
import { launch, opt, serve } from '../viewers/web/tests/harness.mjs';
import { startTrace, taskOwners } from './main_thread.mjs';

const meshmux = opt('--meshmux'), dirs = (opt('--dirs') || '').split(',').filter(Boolean);
const chromiumPath = opt('--chromium', '/usr/bin/chromium'), json = opt('--json');
const repeat = Math.max(1, Number(opt('--repeat', '3')));
if (!meshmux || !dirs.length) {
  console.error('usage: node bench/texture_tasks.mjs --meshmux BIN --dirs DIR[,DIR...] [--json FILE]');
  process.exit(2);
}

// One play of the package in folder `dir`'s page: the longest task over the window, the tasks
// over 16 ms with their owners, and the GPU bytes at the end.
async function playOnce(context, url) {
  const page = await context.newPage();
  await page.goto(`${url}index.html?autoplay=0`);
  await page.waitForFunction(() => window.meshmuxViewer && window.meshmuxViewer.stream, null, { timeout: 60000 });
  const cdp = await context.newCDPSession(page);
  await page.evaluate(async () => {
    const { MeshmuxStream } = await import('./viewer/meshmux.js');
    const THREE = await import('three');
    const renderer = new THREE.WebGLRenderer({ canvas: document.createElement('canvas') });
    window.__bench = new MeshmuxStream('model.mmxp', { renderer, adaptive: false });
    await window.__bench.open();
  });
  const trace = await startTrace(cdp);
  const stats = await page.evaluate(async () => {
    const s = window.__bench;
    performance.mark('bench-start');
    await s.play();
    performance.mark('bench-loaded');
    const { shownTextures } = await import('./viewer/ktx2.js');
    const rgba = shownTextures(s.materials).reduce((n, v) => n + Math.round(4 * v.image.width * v.image.height * 4 / 3), 0);
    const out = { ...s.stats, rgbaBytes: rgba };
    s.dispose();
    return out;
  });
  const { events, profile } = await trace.stop();
  await cdp.detach();
  await page.close();
  // Every task in the window, once; those over 16 ms are listed with their owners.
  const all = taskOwners(events, profile, { start: 'bench-start', end: 'bench-loaded', library: /\/viewer\//, overMs: 0 }).tasks;
  const tasks = all.filter((t) => t.ms > 16);
  const library = all.filter((t) => t.owner === 'library');  // every task of the library's, any length
  return {
    state: stats.state, gpuBytes: stats.gpuBytes, rgbaBytes: stats.rgbaBytes,
    longest: all.reduce((m, t) => Math.max(m, t.ms), 0),
    libraryLongest: library.reduce((m, t) => Math.max(m, t.ms), 0),
    over16: tasks.map((t) => ({ ms: +t.ms.toFixed(1), owner: t.owner, top: t.top, leaves: t.leaves })),
  };
}

const results = [];
for (const dir of dirs) {
  const { server, url } = await serve(meshmux, dir);
  const { context, close } = await launch(path.dirname(path.resolve(dir)), chromiumPath, { width: 960, height: 720 });
  try {
    const runs = [];
    for (let k = 0; k < repeat; k++) runs.push(await playOnce(context, url));
    // The median run by the library's longest task.
    runs.sort((a, b) => a.libraryLongest - b.libraryLongest);
    const r = { dir, ...runs[Math.floor(runs.length / 2)], libraryLongestRuns: runs.map((x) => +x.libraryLongest.toFixed(1)) };
    results.push(r);
    console.log(`${dir}: ${r.state}; library's longest task ${r.libraryLongest.toFixed(1)} ms (runs ${r.libraryLongestRuns.join(', ')}), ` +
      `longest of any ${r.longest.toFixed(1)} ms; over 16 ms: ${r.over16.map((t) => `${t.ms} ${t.owner} ${t.top.join(' ')}`).join('; ') || 'none'}; ` +
      `GPU ${(r.gpuBytes / 1e6).toFixed(2)} MB (RGBA8 ${(r.rgbaBytes / 1e6).toFixed(2)} MB)`);
  } finally {
    await close();
    server.kill();
  }
}
if (json) fs.writeFileSync(json, JSON.stringify(results, null, 1));
