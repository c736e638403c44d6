// throttle.mjs — an HTTP proxy that plays one shared link of a given bandwidth and latency in
// front of a server, for the benches. Chromium's own emulation (CDP
// Network.emulateNetworkConditions) throttles only the page's requests: a Web Worker's fetches
// (meshmux decodes and fetches its refinements in one) would pass at full speed. Here every
// response, whoever asked, shares one link: bodies leave in pieces of `piece` bytes, taken in
// turn from every response that has bytes waiting (as TCP flows share a bottleneck), each piece
// when the link has carried the previous ones at `bytesPerSecond`; every request waits
// `latencyMs` before it reaches the server (the round trip).
//
//   const link = await throttle('http://127.0.0.1:8000/', { bytesPerSecond: 1.25e6, latencyMs: 20 });
//   ... fetch(link.url + 'model.mmxp') ...
//   link.setRate(Infinity);   // full speed from now on
//   await link.close();
import http from 'node:http';

export async function throttle(upstream, { bytesPerSecond = Infinity, latencyMs = 20, piece = 16 * 1024 } = {}) {
  const target = new URL(upstream);
  let rate = bytesPerSecond;
  const flows = [];  // responses with bytes waiting: { res, pieces: [Buffer], ended, upstream }
  let turn = 0, busyUntil = 0, timer = null;

  // Sends the next piece of the next flow in turn, then waits for the link to carry it.
  const pump = () => {
    timer = null;
    for (;;) {
      const live = flows.filter((f) => f.pieces.length || f.ended);
      if (!live.length) return;
      const now = performance.now();
      if (now < busyUntil) { timer = setTimeout(pump, Math.max(1, busyUntil - now)); return; }
      const f = live[turn++ % live.length];
      if (!f.pieces.length) {  // ended with nothing left
        flows.splice(flows.indexOf(f), 1);
        f.res.end();
        continue;
      }
      const p = f.pieces.shift();
      f.res.write(p);
      if (f.pieces.length < 4) f.upstream.resume();
      if (Number.isFinite(rate)) busyUntil = Math.max(busyUntil, now) + (p.length / rate) * 1000;
    }
  };
  const kick = () => { if (!timer) timer = setTimeout(pump, 0); };

  const server = http.createServer((req, res) => {
    setTimeout(() => {
      const up = http.request({ host: target.hostname, port: target.port, path: req.url, method: req.method,
        headers: { ...req.headers, host: target.host } }, (r) => {
        res.writeHead(r.statusCode, r.headers);
        const flow = { res, pieces: [], ended: false, upstream: r };
        flows.push(flow);
        r.on('data', (d) => {
          for (let at = 0; at < d.length; at += piece) flow.pieces.push(d.subarray(at, at + piece));
          if (flow.pieces.length >= 8) r.pause();
          kick();
        });
        r.on('end', () => { flow.ended = true; kick(); });
        res.on('close', () => {  // the client went away (an aborted fetch)
          const i = flows.indexOf(flow);
          if (i >= 0) flows.splice(i, 1);
          r.destroy();
        });
      });
      up.on('error', () => { if (!res.headersSent) res.writeHead(502); res.end(); });
      req.pipe(up);
    }, Number.isFinite(rate) ? latencyMs : 0);
  });
  await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
  return {
    url: `http://127.0.0.1:${server.address().port}/`,
    setRate(bytes) { rate = bytes; busyUntil = 0; kick(); },
    close: () => new Promise((resolve) => { server.closeAllConnections(); server.close(resolve); }),
  };
}
