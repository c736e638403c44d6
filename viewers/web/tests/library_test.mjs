// The library test: `npm pack` of viewers/web, installed with three.js into an empty folder
// (offline: the tarball and the repository's own three), a model converted beside it, and the
// README's example page (between its example:begin/end markers, verbatim) served by `meshmux serve`
// and opened in Debian's headless chromium: the stream must reach "complete" with no console error
// or failed request.
//
// usage: node library_test.mjs --meshmux BIN --work DIR [--model FILE] [--chromium PATH]
// Exit: 0 pass, 1 fail, 77 skipped (no chromium: said on stderr).
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { launch, opt, serve, skip } from './harness.mjs';

const meshmux = opt('--meshmux');
const work = opt('--work');
const model = opt('--model');
const chromiumPath = opt('--chromium', '/usr/bin/chromium');
if (!meshmux || !work) {
  console.error('usage: node library_test.mjs --meshmux BIN --work DIR [--model FILE]');
  process.exit(2);
}
if (!fs.existsSync(chromiumPath)) skip(`${chromiumPath} not installed (apt-get install chromium)`);
const web = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const repo = path.resolve(web, '..', '..');

function run(cmd, argv, cwd) {
  const r = spawnSync(cmd, argv, { cwd, encoding: 'utf8', maxBuffer: 1 << 26 });
  if (r.status !== 0) throw new Error(`${cmd} ${argv.join(' ')} exited ${r.status}: ${r.stderr}`);
  return r.stdout;
}

fs.rmSync(work, { recursive: true, force: true });
const app = path.join(work, 'app');
fs.mkdirSync(app, { recursive: true });
// The package as npm would publish it, installed as a user would (copies, not links: the
// server refuses links that leave its folder).
const tarball = path.join(work, run('npm', ['pack', web, '--pack-destination', work, '--silent']).trim().split('\n').pop());
fs.writeFileSync(path.join(app, 'package.json'), '{"name": "app", "private": true}\n');
run('npm', ['install', '--offline', '--no-audit', '--no-fund', '--install-links', tarball,
  path.join(repo, 'node_modules', 'three')], app);
// Every module the public ones import (relative imports inside the package), and only the
// public API exported.
const installed = path.join(app, 'node_modules', 'meshmux-stream');
for (const f of ['meshmux.js', 'meshmux.d.ts', 'gltf_plugins.js', 'lighting.js', 'materials.js', 'package_reader.js',
  'stream_mesh.js', 'stream_decoder.js', 'stream_decoder.wasm', 'stream_format.js', 'stream_worker.js', 'upload.js', 'view_plan.js', 'worker_client.js',
  'block_view.js', 'view_stream.js',
  'world.js', 'world.d.ts', 'world_plan.js', 'package.json']) {
  if (!fs.existsSync(path.join(installed, f))) throw new Error(`the package lacks ${f}`);
}
const exported = Object.keys(JSON.parse(fs.readFileSync(path.join(installed, 'package.json'), 'utf8')).exports).join(' ');
if (exported !== '. ./world.js ./package.json') throw new Error(`the package exports ${exported}, not only its public API`);
// A model beside it, and the README's page.
let input = model;
if (!input) {
  input = path.join(work, 'sample.glb');
  run(meshmux, ['sample', '-o', input, '-q']);
}
run(meshmux, ['convert', input, '-o', path.join(app, 'model'), '-q']);
const readme = fs.readFileSync(path.join(web, 'README.md'), 'utf8');
const example = /<!-- example:begin -->\s*```html\n([\s\S]*?)```\s*<!-- example:end -->/.exec(readme);
if (!example) throw new Error('README.md has no example between <!-- example:begin --> and <!-- example:end -->');
fs.writeFileSync(path.join(app, 'index.html'), example[1]);

const { server, url } = await serve(meshmux, app);
const { context, close: closeBrowser } = await launch(work, chromiumPath);
const problems = [];
let final = null;
try {
  const page = context.pages()[0] || (await context.newPage());
  page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
  page.on('requestfailed', (r) => problems.push(`request failed: ${r.url()} ${r.failure()?.errorText}`));
  page.on('response', (r) => { if (r.status() >= 400 && !r.url().endsWith('/favicon.ico')) problems.push(`HTTP ${r.status()}: ${r.url()}`); });
  const done = new Promise((resolve) => {
    page.on('console', (m) => {
      // HTTP errors are judged by status above (the browser's own favicon.ico request aside).
      if (m.type() === 'error' && !/^Failed to load resource/.test(m.text())) problems.push(`console error: ${m.text()}`);
      const s = /^meshmux: (\w+)/.exec(m.text());
      if (s) resolve(s[1]);
    });
  });
  await page.goto(url);
  let timer;
  const timeout = new Promise((resolve) => { timer = setTimeout(() => resolve('timeout'), 300000); });
  final = await Promise.race([done, timeout]);
  clearTimeout(timer);  // a pending timer would keep node alive for its whole delay
  if (final !== 'complete') problems.push(`the example page ended with "${final}", not "complete"`);
} finally {
  await closeBrowser();
  server.kill();
}
for (const p of problems) console.error(`FAIL: ${p}`);
console.log(`library: npm pack → ${path.basename(tarball)}, installed offline, README example: ${final}`);
process.exitCode = problems.length ? 1 : 0;
