// Who holds a page's main thread: a chromium trace of the page's tasks (CDP Tracing) with a
// JavaScript sampling profile (CDP Profiler) taken beside it, and every task over 16 ms between
// two user-timing marks given to the owner its samples and trace events show:
//   frame    the page's own frames (a function named in `frameFunctions` on a sample's stack)
//   commit   the browser handing the page's picture to the compositor (a Commit event over half
//            the task: with software compositing it waits for the GPU to finish the frame)
//   library  the loading library's code (a sample's stack through a script `library` matches)
//   other    the rest (garbage collection between tasks, the browser's own work)
// The longtask API starts at 50 ms and names no script; this sees every task of 16 ms and whose
// it is. Used by world.mjs --trace.
//
//   const trace = await startTrace(cdp);          // before the page's work starts
//   ... const { events, profile } = await trace.stop();
//   const owners = taskOwners(events, profile, { start: 'bench-start', end: 'bench-loaded', library, frameFunctions });

const CATEGORIES = 'toplevel,blink.user_timing,devtools.timeline';

// Starts tracing and sampling on a CDP session of the page; resolves { stop } whose stop()
// resolves { events, profile }.
export async function startTrace(cdp, { samplingMicros = 500 } = {}) {
  const events = [];
  cdp.on('Tracing.dataCollected', (e) => events.push(...e.value));
  const complete = new Promise((resolve) => cdp.on('Tracing.tracingComplete', resolve));
  await cdp.send('Profiler.enable');
  await cdp.send('Profiler.setSamplingInterval', { interval: samplingMicros });
  await cdp.send('Tracing.start', { categories: CATEGORIES, transferMode: 'ReportEvents' });
  await cdp.send('Profiler.start');
  return {
    async stop() {
      const { profile } = await cdp.send('Profiler.stop');
      await cdp.send('Tracing.end');
      await complete;
      return { events, profile };
    },
  };
}

// The main thread of the renderer that ran the page: the CrRendererMain with the most tasks.
function pageMainThread(events) {
  const tasks = new Map();
  for (const e of events) if (e.name === 'ThreadControllerImpl::RunTask') tasks.set(`${e.pid}:${e.tid}`, (tasks.get(`${e.pid}:${e.tid}`) || 0) + 1);
  const mains = events.filter((e) => e.ph === 'M' && e.name === 'thread_name' && e.args.name === 'CrRendererMain');
  mains.sort((a, b) => (tasks.get(`${b.pid}:${b.tid}`) || 0) - (tasks.get(`${a.pid}:${a.tid}`) || 0));
  return mains[0];
}

// Every task over `overMs` between the marks `start` and `end` (user timing marks; the trace's
// ends where one is missing), each { ms, owner, at (s after start), top (the library's busiest
// functions, for a library task; cpuMs: the thread's own time in it, null where the trace has
// none; samples and leaves: the profile's samples in it and their innermost frames) }, and per owner { tasks, over50, ms, longest }.
// Trace events that only a rendering update (the browser's frame) runs.
const FRAME_UPDATE = new Set(['PrePaint', 'Paint', 'Layerize', 'UpdateLayoutTree', 'Layout']);

export function taskOwners(events, profile, { start, end, library, frameFunctions = [], overMs = 16 }) {
  const main = pageMainThread(events);
  if (!main) return { tasks: [], owners: {} };
  const onMain = events.filter((e) => e.pid === main.pid && e.tid === main.tid && e.ph === 'X');
  const mark = (name) => events.find((e) => e.name === name && e.cat && e.cat.includes('blink.user_timing'));
  const from = mark(start) ? mark(start).ts : -Infinity, to = mark(end) ? mark(end).ts : Infinity;
  const byId = new Map(profile.nodes.map((n) => [n.id, n]));
  const parent = new Map();
  for (const n of profile.nodes) for (const c of n.children || []) parent.set(c, n.id);
  const stack = (id) => {
    const s = [];
    for (let x = id; x !== undefined; x = parent.get(x)) s.push(byId.get(x).callFrame);
    return s;
  };
  let t = profile.startTime;
  const samples = profile.samples.map((id, i) => ({ t: (t += profile.timeDeltas[i]), id }));
  const name = (f) => `${f.functionName || '(anonymous)'} (${f.url.split('/').pop()}:${f.lineNumber + 1}:${f.columnNumber + 1})`;
  const tasks = [], owners = {};
  const commits = onMain.filter((e) => e.name === 'Commit');
  let s0 = 0;
  for (const task of onMain.filter((e) => e.name === 'ThreadControllerImpl::RunTask' && e.dur > overMs * 1000 && e.ts >= from && e.ts <= to)) {
    const stop = task.ts + task.dur;
    while (s0 < samples.length && samples[s0].t < task.ts) s0++;
    const stacks = [];
    for (let k = s0; k < samples.length && samples[k].t <= stop; k++) stacks.push(stack(samples[k].id));
    const committing = commits.filter((e) => e.ts >= task.ts && e.ts <= stop).reduce((a, e) => a + e.dur, 0);
    let owner = 'other', top = [];
    if (stacks.some((st) => st.some((f) => frameFunctions.includes(f.functionName)))) owner = 'frame';
    else if (committing > task.dur / 2) owner = 'commit';
    else if (stacks.some((st) => st.some((f) => library.test(f.url)))) {
      owner = 'library';
      const count = new Map();
      for (const st of stacks) {
        const f = st.find((x) => library.test(x.url));  // the innermost library function
        if (f) count.set(name(f), (count.get(name(f)) || 0) + 1);
      }
      top = [...count].sort((a, b) => b[1] - a[1]).slice(0, 2).map(([k]) => k);
    }
    // Where the task's samples were, whoever's code: the innermost frame of each (three's
    // functions, the browser's built-ins, "(garbage collector)", "(idle)": the thread waiting).
    const leaf = new Map();
    for (const st of stacks) leaf.set(name(st[0]), (leaf.get(name(st[0])) || 0) + 1);
    const leaves = [...leaf].sort((a, b) => b[1] - a[1]).slice(0, 4).map(([k, n]) => `${k} ${n}`);
    const ms = task.dur / 1000;
    // The thread's own time in the task (tdur): far under ms when the thread waited for a core.
    let cpuMs = Number.isFinite(task.tdur) ? task.tdur / 1000 : null;
    // A rendering update (the browser's frame: style, paint, the canvas handed to the
    // compositor) runs the page's animation-frame callbacks first: a library task of that kind
    // counts only its script (the callbacks, and any other script call not inside one), the rest
    // being the browser's frame (on software GL, ~10-15 ms of thread time around a wait for it).
    const within = onMain.filter((e) => e !== task && e.ts >= task.ts && e.ts + e.dur <= stop);
    if (owner === 'library' && cpuMs !== null && within.some((e) => FRAME_UPDATE.has(e.name))) {
      const callbacks = within.filter((e) => e.name === 'FireAnimationFrame');
      const inCallback = (e) => callbacks.some((c) => e.ts >= c.ts && e.ts + e.dur <= c.ts + c.dur);
      const script = [...callbacks, ...within.filter((e) => e.name === 'FunctionCall' && !inCallback(e))];
      cpuMs = script.reduce((a, e) => a + (Number.isFinite(e.tdur) ? e.tdur : e.dur), 0) / 1000;
    }
    // The trace's events inside the task, longest first (their own thread time where the trace
    // has it): where a task's native time went (a fetch started, a GL call, a message).
    const inside = [...within].sort((a, b) => b.dur - a.dur).slice(0, 6)
      .map((e) => `${e.name} ${(e.dur / 1000).toFixed(1)} ms${Number.isFinite(e.tdur) ? ` (thread ${(e.tdur / 1000).toFixed(1)})` : ''}`);
    tasks.push({ ms, cpuMs, owner, at: (task.ts - from) / 1e6, top, samples: stacks.length, leaves, inside });
    const o = (owners[owner] ||= { tasks: 0, over50: 0, ms: 0, longest: 0, cpuOver: 0, cpuLongest: 0 });
    o.tasks++;
    if (ms > 50) o.over50++;
    o.ms += ms;
    o.longest = Math.max(o.longest, ms);
    if (cpuMs !== null && cpuMs > overMs) o.cpuOver++;
    o.cpuLongest = Math.max(o.cpuLongest, cpuMs || 0);
  }
  return { tasks, owners };
}
