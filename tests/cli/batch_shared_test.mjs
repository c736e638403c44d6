// meshmux batch over every shared model plus 20 broken copies, driven as a user would: the meshmux
// binary, a list file, kill -9, reruns.
//
//   node batch_shared_test.mjs --meshmux BIN --work DIR --mode local [--subset A,B,…]
//     a batch killed with SIGKILL mid-run, then rerun: every good model converts, every bad
//     one is listed with its one line, nothing is lost, no temporary is left, no conversion
//     outlives the batch; a third run converts nothing and touches nothing.
//   node batch_shared_test.mjs --work DIR --mode list
//     only writes DIR/list.txt (the shared models and the broken copies) and prints its path.
//   node batch_shared_test.mjs --meshmux BIN --work DIR --mode slurm
//     the same list through a real one-node Slurm (scripts/slurm-local.sh) as a job array:
//     the outputs equal a local-pool run's byte for byte (report.json's timings aside), and
//     the tasks' states are printed from the summary and scontrol.
// Exit 77 (ctest's skip) when ../shared/models is absent, or Slurm is not installed.
import { spawn, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const root = path.resolve(here, '../..');
const args = process.argv.slice(2);
const opt = (name, fallback) => {
  const i = args.indexOf(name);
  return i >= 0 && i + 1 < args.length ? args[i + 1] : fallback;
};
const meshmux = path.resolve(opt('--meshmux', `${root}/build/meshmux`));
const work = path.resolve(opt('--work', '/tmp/meshmux-batch-test'));
const mode = opt('--mode', 'local');
const models = path.resolve(opt('--models', `${root}/../shared/models`));

let failures = 0;
function check(ok, message) {
  if (!ok) {
    failures++;
    console.error(`FAIL: ${message}`);
  }
}
function skip(message) {
  console.error(`SKIPPED: ${message}`);
  process.exit(77);
}

if (!fs.existsSync(models)) skip(`${models} is absent: the shared models are needed`);
fs.rmSync(work, { recursive: true, force: true });
fs.mkdirSync(work, { recursive: true });

// Every model file of the shared set (.gltf, .glb, .dae; any letter case), sorted.
function modelFiles(dir) {
  const out = [];
  for (const e of fs.readdirSync(dir, { withFileTypes: true })) {
    const p = path.join(dir, e.name);
    if (e.isDirectory()) out.push(...modelFiles(p));
    else if (/\.(gltf|glb|dae)$/i.test(e.name)) out.push(p);
  }
  return out.sort();
}
// --subset A,B,…: only the shared models in those folders (the suite's run; bench/batch.sh and a
// run without it take every one).
const subset = opt('--subset', '');
const shared = modelFiles(models).filter((f) =>
  !subset || subset.split(',').includes(path.relative(models, f).split(path.sep)[0]));
if (subset && shared.length !== subset.split(',').length)
  throw new Error(`--subset names ${subset.split(',').length} folders, ${shared.length} models found`);
const model = (rel) => path.join(models, rel);

// 20 broken copies: truncated, garbage, and missing buffers or textures. `expect` is "failed"
// (the conversion must fail) or "warning" (it converts without the missing texture, and the
// summary shows the warning that names it).
const bad = path.join(work, 'broken');
fs.mkdirSync(bad);
const broken = [];
function addBroken(name, bytes, expect) {
  const dir = path.join(bad, name.replace(/\.[^.]*$/, '').replace(/[^A-Za-z0-9]/g, '_'));
  fs.mkdirSync(dir, { recursive: true });
  const file = path.join(dir, path.basename(name));
  fs.writeFileSync(file, bytes);
  broken.push({ file, expect });
  return dir;
}
function truncated(rel, fraction, name) {
  const b = fs.readFileSync(model(rel));
  addBroken(name, b.subarray(0, Math.max(1, Math.floor(b.length * fraction))), 'failed');
}
// Deterministic garbage (a linear congruential generator; the test repeats exactly).
function garbage(n, seed) {
  const b = Buffer.alloc(n);
  let x = seed >>> 0;
  for (let i = 0; i < n; i++) {
    x = (Math.imul(x, 1664525) + 1013904223) >>> 0;
    b[i] = x >>> 24;
  }
  return b;
}
// A .gltf copied with only some of the files it references.
function partial(rel, keep, name, expect) {
  const src = path.dirname(model(rel));
  const dir = addBroken(name, fs.readFileSync(model(rel)), expect);
  for (const f of keep) fs.copyFileSync(path.join(src, f), path.join(dir, f));
}
truncated('DamagedHelmet-glb/DamagedHelmet.glb', 0.1, 'helmet-10pc.glb');
truncated('DamagedHelmet-glb/DamagedHelmet.glb', 0.5, 'helmet-50pc.glb');
truncated('DamagedHelmet-glb/DamagedHelmet.glb', 0.999, 'helmet-999pm.glb');
truncated('StanfordBunny-glb/bunny.glb', 0.3, 'bunny-30pc.glb');
truncated('Fox-glb/Fox.glb', 12 / fs.statSync(model('Fox-glb/Fox.glb')).size, 'fox-header.glb');
truncated('2CylinderEngine-dae/2CylinderEngine.dae', 0.4, 'engine-40pc.dae');
truncated('CesiumMilkTruck-dae/CesiumMilkTruck.dae', 0.7, 'truck-70pc.dae');
truncated('Avocado-gltf/Avocado.gltf', 0.5, 'avocado-half-json.gltf');
addBroken('noise.glb', garbage(4096, 1), 'failed');
addBroken('noise.gltf', garbage(4096, 2), 'failed');
addBroken('noise.dae', garbage(4096, 3), 'failed');
addBroken('empty.glb', Buffer.alloc(0), 'failed');
addBroken('magic-then-noise.glb', Buffer.concat([Buffer.from('glTF'), Buffer.from([2, 0, 0, 0, 0, 16, 0, 0]), garbage(4088, 4)]), 'failed');
partial('Avocado-gltf/Avocado.gltf', [], 'avocado-no-bin.gltf', 'failed');
partial('SheenChair-gltf/SheenChair.gltf', ['chair_label.png'], 'chair-no-bin.gltf', 'failed');
partial('SimpleInstancing-gltf/SimpleInstancing.gltf', [], 'instancing-no-bin.gltf', 'failed');
partial('Avocado-gltf/Avocado.gltf', ['Avocado.bin'], 'avocado-no-textures.gltf', 'warning');
partial('WaterBottle-gltf/WaterBottle.gltf', ['WaterBottle.bin'], 'bottle-no-textures.gltf', 'warning');
partial('Duck-webp-gltf/Duck.gltf', ['Duck0.bin'], 'duck-no-webp.gltf', 'warning');
addBroken('duck-no-tga.dae', fs.readFileSync(model('Duck-dae/duck.dae')), 'warning');
if (broken.length !== 20) throw new Error(`${broken.length} broken copies, not 20`);

function writeList(file, inputs) {
  fs.writeFileSync(file, `# shared models and broken copies\n${inputs.join('\n')}\n`);
}
function readJson(file) {
  return JSON.parse(fs.readFileSync(file, 'utf8'));
}
function runBatch(list, out, extra = []) {
  const t0 = Date.now();
  const r = spawnSync(meshmux, ['batch', list, '-o', out, ...extra], { encoding: 'utf8', maxBuffer: 64 << 20, timeout: 600000 });
  return { code: r.status, signal: r.signal, err: r.stderr, seconds: (Date.now() - t0) / 1000 };
}
// Every file under `dir` (relative path → absolute), dot folders included.
function walk(dir, base = dir, out = new Map()) {
  for (const e of fs.readdirSync(dir, { withFileTypes: true })) {
    const p = path.join(dir, e.name);
    if (e.isDirectory()) walk(p, base, out);
    else out.set(path.relative(base, p), p);
  }
  return out;
}
// Processes whose command line mentions `text` (a conversion that outlived its batch).
function processesMentioning(text) {
  const found = [];
  for (const pid of fs.readdirSync('/proc')) {
    if (!/^\d+$/.test(pid) || Number(pid) === process.pid) continue;
    try {
      const cmd = fs.readFileSync(`/proc/${pid}/cmdline`, 'utf8').split('\0').join(' ');
      if (cmd.includes(text) && cmd.includes(' convert ')) found.push(`${pid}: ${cmd}`);
    } catch {
      // gone meanwhile
    }
  }
  return found;
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// The summary says what each input became; checks it against what each input is.
function checkSummary(doc, inputs) {
  check(doc.inputs.length === inputs.length, `batch.json lists ${doc.inputs.length} of ${inputs.length} inputs`);
  const byInput = new Map(doc.inputs.map((e) => [e.input, e]));
  const expectOf = new Map(broken.map((b) => [b.file, b.expect]));
  for (const input of inputs) {
    const e = byInput.get(input);
    if (!e) { check(false, `${input}: lost from batch.json`); continue; }
    const expect = expectOf.get(input) ?? 'ok';
    const base = path.basename(input);
    if (expect === 'failed') {
      check(e.status === 'failed', `${base}: ${e.status}, expected failed`);
      check(e.error && !e.error.includes('\n'), `${base}: not one error line: ${JSON.stringify(e.error)}`);
      check(e.error.includes(base), `${base}: the error does not name the file: ${e.error}`);
      check(!fs.existsSync(path.join(doc.outroot, e.name)), `${base}: an output folder for a failed input`);
    } else {
      check(e.status.startsWith('ok'), `${base}: ${e.status} ${e.error}`);
      check(fs.existsSync(path.join(doc.outroot, e.name, 'model.glb')), `${base}: no model.glb`);
      if (expect === 'warning')
        check(e.warnings > 0 && /could not be loaded|not found|no such file/i.test(e.first_warning),
          `${base}: converted without its texture, but the summary shows no warning naming it: ${e.first_warning}`);
    }
  }
}

function table(doc) {
  const rows = doc.inputs.map((e) => {
    const what = e.status === 'failed' ? e.error : e.warnings ? `${e.warnings} warnings: ${e.first_warning}` : '';
    return `${e.status.padEnd(18)} ${String(e.seconds).padStart(6)} s  ${e.name}  ${what.slice(0, 150)}`;
  });
  console.log(rows.join('\n'));
}

async function local() {
  const inputs = [...shared, ...broken.map((b) => b.file)];
  const list = path.join(work, 'list.txt');
  writeList(list, inputs);
  const out = path.join(work, 'out');

  // 1. kill -9 once a few conversions have finished.
  const batch = spawn(meshmux, ['batch', list, '-o', out, '--jobs', '2', '-q'], { stdio: 'ignore' });
  const records = path.join(out, '.meshmux-batch', 'records');
  const recorded = () => (fs.existsSync(records) ? fs.readdirSync(records).filter((f) => f.endsWith('.json')).length : 0);
  const exited = new Promise((r) => batch.on('exit', r));
  const t0 = Date.now();
  while (Date.now() - t0 < 120000 && batch.exitCode === null && recorded() < 6) await sleep(50);
  const before = recorded();
  batch.kill('SIGKILL');
  await exited;
  await sleep(500);
  const orphans = processesMentioning(out + '/');
  check(orphans.length === 0, `conversions outlived the killed batch:\n${orphans.join('\n')}`);
  check(before < inputs.length, 'the batch finished before it was killed: kill earlier');
  console.log(`killed the batch (SIGKILL) after ${before} of ${inputs.length} inputs were recorded`);

  // 2. The rerun completes it.
  const second = runBatch(list, out, ['--jobs', '2']);
  check(second.code === 2, `the rerun exited ${second.code} (expected 2: some inputs failed)\n${second.err}`);
  const m = second.err.match(/(\d+) inputs: (\d+) to convert, (\d+) done by an earlier run/);
  check(m && Number(m[3]) >= before, `the rerun did not reuse the ${before} finished inputs: ${m && m[0]}`);
  const doc = readJson(path.join(out, 'batch.json'));
  checkSummary(doc, inputs);
  const temporaries = [...walk(out).keys()].filter((f) => /\.meshmux-tmp-|\.tmp-\d+/.test(f));
  check(temporaries.length === 0, `temporaries left: ${temporaries.join(', ')}`);
  for (const d of fs.readdirSync(out, { withFileTypes: true }))
    check(!d.isDirectory() || d.name === '.meshmux-batch' || d.name === 'viewer' || doc.inputs.some((e) => e.name === d.name && e.status.startsWith('ok')),
      `an output folder no input owns: ${d.name}`);
  console.log(`rerun: ${m && m[0]}; ${second.seconds.toFixed(1)} s; counts ${JSON.stringify(doc.counts)}`);
  table(doc);

  // 3. A third run converts nothing and rewrites no output.
  const stamps = new Map([...walk(out)].filter(([rel]) => !rel.startsWith('.') && rel.includes('/'))
    .map(([rel, p]) => [rel, fs.statSync(p).mtimeMs]));
  const third = runBatch(list, out, ['--jobs', '2']);
  check(third.code === 2, `the third run exited ${third.code}`);
  check(/ 0 to convert, /.test(third.err), `the third run converted something: ${third.err.split('\n')[0]}`);
  for (const [rel, t] of stamps)
    check(fs.statSync(path.join(out, rel)).mtimeMs === t, `the third run rewrote ${rel}`);
  const doc3 = readJson(path.join(out, 'batch.json'));
  check(doc3.counts.reused === doc.counts.ok + doc.counts.failed, `third run reused ${doc3.counts.reused}`);
  console.log(`third run: ${third.seconds.toFixed(1)} s, ${third.err.split('\n')[0]}`);

  // 4. A texture arrives for an upload that lacked it: that input alone converts again.
  const avocado = broken.find((b) => b.file.endsWith('avocado-no-textures.gltf'));
  fs.copyFileSync(model('Avocado-gltf/Avocado_baseColor.png'), path.join(path.dirname(avocado.file), 'Avocado_baseColor.png'));
  const fourth = runBatch(list, out, ['--jobs', '2']);
  check(/ 1 to convert, /.test(fourth.err), `a changed texture did not convert its model again: ${fourth.err.split('\n')[0]}`);
  const e4 = readJson(path.join(out, 'batch.json')).inputs.find((e) => e.input === avocado.file);
  check(e4 && e4.status.startsWith('ok') && !e4.first_warning.includes('Avocado_baseColor'), `the new texture was not used: ${e4 && e4.first_warning}`);

  // 5. Ctrl-C (SIGINT) mid-run: exit 130, the summary lists every input (the ones not reached
  // as not converted), no conversion or temporary is left.
  const out5 = path.join(work, 'out-interrupted');
  const b5 = spawn(meshmux, ['batch', list, '-o', out5, '--jobs', '2', '-q'], { stdio: 'ignore' });
  const exited5 = new Promise((r) => b5.on('exit', (code) => r(code)));
  const records5 = path.join(out5, '.meshmux-batch', 'records');
  const t5 = Date.now();
  while (Date.now() - t5 < 120000 && b5.exitCode === null &&
         !(fs.existsSync(records5) && fs.readdirSync(records5).length >= 2)) await sleep(50);
  b5.kill('SIGINT');
  const code5 = await exited5;
  check(code5 === 130, `SIGINT: exit ${code5}, expected 130`);
  const doc5 = readJson(path.join(out5, 'batch.json'));
  check(doc5.inputs.length === inputs.length && doc5.counts.not_converted > 0,
    `SIGINT: the summary lists ${doc5.inputs.length} inputs, ${doc5.counts.not_converted} not converted`);
  check(processesMentioning(out5 + '/').length === 0, 'SIGINT: conversions outlived the batch');
  const temps5 = [...walk(out5).keys()].filter((f) => /\.meshmux-tmp-|\.tmp-\d+/.test(f));
  check(temps5.length === 0, `SIGINT: temporaries left: ${temps5.join(', ')}`);
  console.log(`SIGINT: exit ${code5}; ${JSON.stringify(doc5.counts)}`);
}

// Files of an output folder that must match: everything but report.json's "seconds" line.
function comparable(file) {
  const b = fs.readFileSync(file);
  if (path.basename(file) !== 'report.json') return b;
  return Buffer.from(b.toString('utf8').split('\n').filter((l) => !l.includes('"seconds"')).join('\n'));
}

async function slurm() {
  const start = spawnSync('bash', [`${root}/scripts/slurm-local.sh`, 'start'], { encoding: 'utf8' });
  if (start.status === 77) skip(start.stderr.trim());
  if (start.status !== 0) throw new Error(`slurm-local.sh start failed:\n${start.stderr}`);
  const env = { ...process.env };
  for (const m of start.stdout.matchAll(/export (\w+)='([^']*)'/g)) env[m[1]] = m[2];
  console.log(start.stderr.trim());
  try {
    // The shared models and a few broken copies, so failed tasks show too.
    const inputs = [...shared, ...broken.filter((_, i) => i % 5 === 0).map((b) => b.file)];
    const list = path.join(work, 'list.txt');
    writeList(list, inputs);
    const localOut = path.join(work, 'local');
    const slurmOut = path.join(work, 'slurm');
    const l = runBatch(list, localOut, ['--jobs', '2', '-q']);
    check(l.code === 2, `local batch exited ${l.code}\n${l.err}`);
    const t0 = Date.now();
    const s = spawnSync(meshmux, ['batch', list, '-o', slurmOut, '--slurm', '--wait', '--tasks', '6', '--throttle', '2'],
      { encoding: 'utf8', env, maxBuffer: 64 << 20, timeout: 600000 });
    const slurmSeconds = (Date.now() - t0) / 1000;
    check(s.status === 2, `slurm batch exited ${s.status} (expected 2: broken copies fail)\n${s.stderr}`);
    const ld = readJson(path.join(localOut, 'batch.json'));
    const sd = readJson(path.join(slurmOut, 'batch.json'));
    checkSummary(sd, inputs);
    // Byte for byte, every output folder.
    const lf = walk(localOut), sf = walk(slurmOut);
    let compared = 0;
    for (const [rel, p] of lf) {
      if (rel.startsWith('.meshmux-batch') || rel === 'batch.json' || rel === 'index.html') continue;
      if (!sf.has(rel)) { check(false, `Slurm output lacks ${rel}`); continue; }
      check(comparable(p).equals(comparable(sf.get(rel))), `${rel} differs between the local pool and Slurm`);
      compared++;
    }
    for (const rel of sf.keys())
      if (!rel.startsWith('.meshmux-batch') && rel !== 'batch.json' && rel !== 'index.html' && !lf.has(rel))
        check(false, `Slurm output has ${rel}, the local pool not`);
    for (const e of ld.inputs) {
      const o = sd.inputs.find((x) => x.input === e.input);
      check(o && o.status === e.status && o.error === e.error, `${e.name}: local "${e.status}: ${e.error}" vs Slurm "${o && o.status}: ${o && o.error}"`);
    }
    check(sd.slurm && sd.slurm.tasks.length === 6, 'the summary lacks the array\'s tasks');
    console.log(`local pool ${l.seconds.toFixed(1)} s; Slurm job array ${sd.slurm.array_job} (6 tasks, 2 at once) + summary job ${sd.slurm.summary_job}: ${slurmSeconds.toFixed(1)} s; ${compared} files identical`);
    console.log('tasks (from the summary):');
    for (const t of sd.slurm.tasks) console.log(`  ${sd.slurm.array_job}_${t.task}  ${t.state}  exit ${t.exit}`);
    const sc = spawnSync('scontrol', ['-o', 'show', 'job', sd.slurm.array_job], { encoding: 'utf8', env });
    console.log('scontrol -o show job (JobId, ArrayTaskId, JobState, ExitCode):');
    for (const line of sc.stdout.trim().split('\n')) {
      const f = (k) => (line.match(new RegExp(`(?:^| )${k}=(\\S+)`)) || [])[1];
      console.log(`  JobId=${f('JobId')} ArrayJobId=${f('ArrayJobId')} ArrayTaskId=${f('ArrayTaskId')} JobState=${f('JobState')} ExitCode=${f('ExitCode')}`);
    }
    table(sd);

    // A task that never runs (cancelled while pending) loses no input: the summary lists its
    // share as not converted, with the task's state.
    const small = shared.filter((f) => /BoxVertexColors|ConcavePolygon|SimpleInstancing|OrientationTest|VertexColorTest|TextureSettingsTest/.test(f));
    const list2 = path.join(work, 'list-small.txt');
    writeList(list2, small);
    const out2 = path.join(work, 'slurm-cancelled');
    const sub = spawnSync(meshmux, ['batch', list2, '-o', out2, '--slurm', '--tasks', '2', '--throttle', '1'],
      { encoding: 'utf8', env, timeout: 120000 });
    check(sub.status === 0, `--slurm without --wait exited ${sub.status}\n${sub.stderr}`);
    const arr = (sub.stderr.match(/submitted job array (\d+)/) || [])[1];
    spawnSync('scancel', [`${arr}_1`], { env });
    const summary2 = path.join(out2, 'batch.json');
    const t2 = Date.now();
    while (!fs.existsSync(summary2) && Date.now() - t2 < 180000) await sleep(200);
    const d2 = fs.existsSync(summary2) ? readJson(summary2) : { inputs: [], counts: {}, slurm: { tasks: [] } };
    check(d2.inputs.length === small.length, `cancelled task: the summary lists ${d2.inputs.length} of ${small.length} inputs`);
    const lost = d2.inputs.filter((e) => e.status === 'not converted');
    check(lost.length === Math.floor(small.length / 2) && lost.every((e) => e.error.includes(`task ${arr}_1 never ran (cancelled while pending)`)),
      `cancelled task: ${lost.length} not converted: ${lost.map((e) => e.error).join(' | ')}`);
    check(d2.inputs.filter((e) => e.status === 'ok').length === small.length - lost.length, 'cancelled task: the other task\'s inputs did not convert');
    console.log(`cancelled task ${arr}_1: ${JSON.stringify(d2.counts)}; tasks ${d2.slurm.tasks.map((t) => `${t.task} ${t.state} ${t.exit}`).join(', ')}`);
    if (lost[0]) console.log(`  e.g. ${lost[0].name}: ${lost[0].error}`);
  } finally {
    spawnSync('bash', [`${root}/scripts/slurm-local.sh`, 'stop', env.MESHMUX_SLURM_DIR || ''], { stdio: 'inherit' });
  }
}

if (mode === 'list') {
  // For bench/batch.sh: the benchmark's list (every shared model, then the 20 broken copies).
  const list = path.join(work, 'list.txt');
  writeList(list, [...shared, ...broken.map((b) => b.file)]);
  console.log(list);
  process.exit(0);
}
await (mode === 'slurm' ? slurm() : local());
if (failures) {
  console.error(`${failures} check(s) failed`);
  process.exit(1);
}
console.log('PASS');
