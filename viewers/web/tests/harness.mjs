// What the browser tests share: command-line options, `meshmux serve` on a free port, and
// Debian's headless chromium through playwright-core in a private profile.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { chromium } from 'playwright-core';

// The value after `name` in the process's arguments, or `fallback`.
export function opt(name, fallback) {
  const args = process.argv.slice(2);
  const i = args.indexOf(name);
  return i >= 0 && i + 1 < args.length ? args[i + 1] : fallback;
}

// Exits 77 (a skip for ctest) with the reason on stderr.
export function skip(message) {
  console.error(`SKIPPED: ${message}`);
  process.exit(77);
}

// A browser test's arguments: --meshmux BIN --work DIR [--chromium PATH]; a usage line (exit 2)
// when one is missing, a skip (77) when chromium is not installed. { meshmux, work, chromiumPath }.
export function browserTestArgs(script) {
  const meshmux = opt('--meshmux'), work = opt('--work'), chromiumPath = opt('--chromium', '/usr/bin/chromium');
  if (!meshmux || !work) {
    console.error(`usage: node ${script} --meshmux BIN --work DIR [--chromium PATH]`);
    process.exit(2);
  }
  if (!fs.existsSync(chromiumPath)) skip(`${chromiumPath} not installed (apt-get install chromium)`);
  return { meshmux, work, chromiumPath };
}

// Checks that print "ok" or "FAIL" and remember the failures: { check(ok, what), failures }.
export function checks() {
  const failures = [];
  const check = (ok, what) => {
    console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
    if (!ok) failures.push(what);
  };
  return { check, failures };
}

// `meshmux serve DIR` on port 0; resolves { server, url } once it printed its URL.
export async function serve(meshmux, dir) {
  const server = spawn(meshmux, ['serve', dir, '--port', '0', '-q'], { stdio: ['ignore', 'pipe', 'pipe'] });
  const url = await new Promise((resolve, reject) => {
    let text = '';
    const timer = setTimeout(() => reject(new Error('meshmux serve printed no URL')), 10000);
    server.stdout.on('data', (d) => {
      text += d;
      const m = text.match(/http:\/\/[^\s]+\//);
      if (m) { clearTimeout(timer); resolve(m[0]); }
    });
    server.on('exit', (code) => reject(new Error(`meshmux serve exited ${code}`)));
  });
  return { server, url };
}

// Headless chromium in a fresh profile under `work`; resolves { context, close } (close also
// removes the profile).
export async function launch(work, chromiumPath, viewport = { width: 960, height: 720 }) {
  const userData = fs.mkdtempSync(path.join(work, 'chromium-'));
  const context = await chromium.launchPersistentContext(userData, {
    executablePath: chromiumPath,
    headless: true,
    viewport,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  const close = async () => {
    await context.close();
    fs.rmSync(userData, { recursive: true, force: true });
  };
  return { context, close };
}
