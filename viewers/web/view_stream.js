// view_stream.js — a block package played for the camera (MeshmuxStream's `triangleBudget`):
// the next blocks chosen from what the camera sees (block_view.js planBlocks: projected error
// removed × area on screen per byte, parents first), fetched by range, applied out of stored
// order, and detail that left the view dropped again to stay within the budget (the mesh
// decoded again from the blocks kept: block_view.js BlockMeshState.rebuild). Everything else in
// the package (texture levels, the parts of meshes that are not block meshes) follows at the
// pace of the stored order: an item is taken once the bytes received reach the bytes stored
// before it. A block mesh's completion (its full detail, where the parts stopped) is taken when
// the view wants more than the blocks sent give and the full mesh fits the budget. Used by meshmux.js; the state is held where the stream decodes (its worker, or the
// page).

import * as THREE from 'three';

import { blockChildren, heldFromStart, planBlocks } from './block_view.js';
import { nextTask, pause } from './upload.js';

// How often a settled stream looks at the camera again (ms).
const SETTLED_POLL_MS = 100;
// Blocks fetched at once: their requests overlap the applying of the ones before.
const IN_FLIGHT = 4;
// Blocks applied without waiting for an animation frame, for this long (ms).
const FRAME_EVERY_MS = 100;

// The page's buffers for each block mesh under a budget of `budget` triangles: null for a mesh
// that is not one; else {capacityVertices, capacityFaces}: the budget's faces (at least the
// base's), and as many vertices more than the base's (a split adds one vertex and at least one
// face), never more than the mesh has.
export function viewCapacities(table, budget) {
  return table.meshes.map((d) => {
    if (!d.blockCount) return null;
    const faces = Math.min(d.faces, Math.max(Math.floor(budget), d.base_faces));
    return { capacityFaces: faces, capacityVertices: Math.min(d.vertices, d.base_vertices + faces) };
  });
}

// One stream's play by view. `stream` is the MeshmuxStream (opened, its meshes built with
// viewCapacities); run() plays until stop().
export class ViewPlayer {
  constructor(stream) {
    this.s = stream;
    const table = stream.table;
    // Per block mesh: its blocks, which are held, which are sent (and where: file range).
    this.meshes = table.meshes.map((d, i) => {
      if (!d.blocks.length) return null;
      const mesh = stream.meshes[i];
      return { blocks: d.blocks, ...blockChildren(d.blocks), held: new Set(), pending: new Set(),
        sent: new Uint8Array(d.blocks.length), bytes: new Float64Array(d.blocks.length), range: d.blocks.map(() => null),
        faces: mesh.faces, vertices: mesh.vertices, capacityFaces: mesh.capacityFaces, capacityVertices: mesh.capacityVertices };
    });
    // Items paced by the stored order: [{bytesBefore, index (chunk), chunk, parts (a mesh chunk's
    // parts of meshes that are not block meshes: [{part, offset}])}].
    this.paced = [];
    let before = 0;
    const stored = stream.order.chunks;
    for (const index of stored) {
      const chunk = table.chunks[index];
      if (chunk.kind === 'mesh') {
        let at = chunk.offset;
        const chain = [];
        for (const part of chunk.parts) {
          const m = this.meshes[part.mesh];
          if (m && part.block >= 0) {
            m.sent[part.block] = 1;
            m.bytes[part.block] = part.bytes;
            m.range[part.block] = { offset: at, size: part.bytes };
          } else {
            chain.push({ part, offset: at });
          }
          at += part.bytes;
        }
        if (chain.length) this.paced.push({ bytesBefore: before, index, chunk, parts: chain });
      } else if (chunk.kind === 'texture') {
        this.paced.push({ bytesBefore: before, index, chunk });
      } else if (chunk.kind === 'complete') {
        if (chunk.meshes.some((e) => this.meshes[e.mesh])) this.completion = this._completionChunk = { index, chunk };
        else this.paced.push({ bytesBefore: before, index, chunk });
      }
      before += chunk.size;
    }
    for (const m of this.meshes) if (m) m.held = heldFromStart(m.blocks, m.sent);
    // The completion of a block mesh (its full detail single-rate, where the parts stopped): taken
    // once the view wants more than the blocks sent can give and the full mesh fits the budget.
    this.completion = this.completion || null;
    this.completed = new Map();  // block mesh → its view state, while it shows the completion
    this.pacedAt = 0;
    this.rebuilds = 0;         // times detail was dropped (a mesh decoded again)
    this.blocksApplied = 0;    // blocks applied in all (again after a drop included)
    this.screenError = NaN;    // the largest projected error of a block in view not held (pixels)
    this.peakResident = this.resident();
    this.settled = false;
    this._lastFrame = 0;
    this._frustum = new THREE.Frustum();
    this._matrix = new THREE.Matrix4();
    this._box = new THREE.Box3();
    this._v = new THREE.Vector3();
  }

  // Faces held over every mesh (the budget's count).
  resident() {
    let n = 0;
    for (const m of this.s.meshes) n += m.faces;
    return n;
  }

  stats() {
    let held = 0, total = 0;
    for (const m of this.meshes) if (m) { held += m.held.size; total += m.blocks.length; }
    return { residentTriangles: this.resident(), peakResidentTriangles: this.peakResident, triangleBudget: this.s.options.triangleBudget,
      blocksHeld: held, blockCount: total, blocksApplied: this.blocksApplied, rebuilds: this.rebuilds, screenError: this.screenError,
      settled: this.settled };
  }

  // The camera's state the plan depends on, to see when it changed.
  _viewKey() {
    const c = this.s.options.camera, size = this._canvas();
    c.updateMatrixWorld();
    this.s.object.updateMatrixWorld(true);
    return [...c.matrixWorld.elements, ...c.projectionMatrix.elements, ...size, this.s.options.triangleBudget, ...this.s.object.matrixWorld.elements].join(',');
  }

  _canvas() {
    return this.s.canvasSize() || this.s.table.view.display || [1920, 1080];
  }

  // Per block mesh, the matrices its objects draw it with (instances included), and the camera's
  // frustum, position and pixels per world unit at unit distance.
  _prepare() {
    const camera = this.s.options.camera;
    camera.updateMatrixWorld();
    this.s.object.updateMatrixWorld(true);
    this._frustum.setFromProjectionMatrix(this._matrix.multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse));
    this._eye = camera.getWorldPosition(new THREE.Vector3());
    const [width, height] = this._canvas();
    this._size = [width, height];
    this._viewProjection = this._matrix.clone();
    if (camera.isOrthographicCamera) this._ortho = height * camera.zoom / Math.max(camera.top - camera.bottom, 1e-12);
    else this._ortho = 0, this._focal = height / (2 * Math.tan((camera.fov * Math.PI) / 360));
    this._diagonal = this.s.worldBounds().getSize(this._v).length();
    const matrices = this.s.meshes.map(() => []);
    for (const root of this.s.viewRoots || [this.s.object]) root.traverse((o) => {
      const i = this.s.meshes.findIndex((m) => m.geometry === o.geometry);
      if (i < 0 || !this.meshes[i]) return;
      if (o.isInstancedMesh) {
        for (let k = 0; k < o.count; k++) matrices[i].push(o.getMatrixAt(k, new THREE.Matrix4()).premultiply(o.matrixWorld));
      } else {
        matrices[i].push(o.matrixWorld.clone());
      }
    });
    this._matrices = matrices;
    this._scales = this.meshes.map((m) => (m ? new Array(m.blocks.length) : null));
  }

  // Block k of mesh i from the camera: {pixels: screen pixels per unit of error (the scene's
  // diagonal) at its box's nearest point, 0 outside the view; area: its box's area on screen,
  // pixels²}; the nearest of its instances.
  scale(i, k) {
    const cached = this._scales[i][k];
    if (cached) return cached;
    const mesh = this.s.meshes[i], b = this.meshes[i].blocks[k].box;
    const local = new THREE.Box3(new THREE.Vector3(b[0], b[1], b[2]), new THREE.Vector3(b[3], b[4], b[5]));
    if (!mesh.quantized) {
      const o = mesh.origin, s = mesh.step;
      local.min.set(o[0] + b[0] * s, o[1] + b[1] * s, o[2] + b[2] * s);
      local.max.set(o[0] + b[3] * s, o[1] + b[4] * s, o[2] + b[5] * s);
    }
    let best = { pixels: 0, area: 0 };
    for (const matrix of this._matrices[i]) {
      const box = this._box.copy(local).applyMatrix4(matrix);
      if (!this._frustum.intersectsBox(box)) continue;
      const distance = Math.max(box.distanceToPoint(this._eye), this.s.options.camera.near || 1e-6);
      const perUnit = this._ortho || this._focal / distance;
      const pixels = this._diagonal * perUnit;
      if (pixels > best.pixels) best = { pixels, area: this._area(box) };
    }
    this._scales[i][k] = best;
    return best;
  }

  // A world box's area on screen (pixels², clipped to it; the whole screen when a corner is
  // behind the camera).
  _area(box) {
    const [w, h] = this._size, e = this._viewProjection.elements;
    let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
    for (let c = 0; c < 8; c++) {
      const x = c & 1 ? box.max.x : box.min.x, y = c & 2 ? box.max.y : box.min.y, z = c & 4 ? box.max.z : box.min.z;
      const cw = e[3] * x + e[7] * y + e[11] * z + e[15];
      if (!(cw > 1e-9)) return w * h;
      const px = (e[0] * x + e[4] * y + e[8] * z + e[12]) / cw, py = (e[1] * x + e[5] * y + e[9] * z + e[13]) / cw;
      x0 = Math.min(x0, px); x1 = Math.max(x1, px); y0 = Math.min(y0, py); y1 = Math.max(y1, py);
    }
    const cw = Math.max(0, Math.min(1, x1) - Math.max(-1, x0)), ch = Math.max(0, Math.min(1, y1) - Math.max(-1, y0));
    return (cw * ch * w * h) / 4;
  }

  // Plays until the signal aborts: paced items as their bytes come due, blocks by view (up to
  // IN_FLIGHT fetched at once, the next chosen as each one is applied, those on their way
  // counted as held); when nothing in view needs more, waits for the camera, canvas or budget
  // to change.
  async run(signal) {
    const s = this.s;
    let lastKey = null;
    const inflight = [];  // [{mesh, block, faces, vertices, read}] in the order asked
    try {
      while (!signal.aborted) {
        await this._takePaced(signal, false);
        const key = this._viewKey();
        if (!inflight.length && await this._uncomplete(signal)) continue;
        let evicted = false;
        if (inflight.length < IN_FLIGHT) {
          const plan = this._plan(inflight, IN_FLIGHT - inflight.length);
          if (plan.evict.length && !inflight.length) {
            await this._drop(plan.evict, signal);  // then plans again with the room made
            evicted = true;
          } else if (!plan.evict.length) {
            const within = (n) => s.options.budgetBytes - s._bytes - inflight.reduce((a, x) => a + x.size, 0) >= n;
            for (const f of plan.fetch) {
              const r = this.meshes[f.mesh].range[f.block], b = this.meshes[f.mesh].blocks[f.block];
              if (!within(r.size)) break;
              const read = s._reader.read(r.offset, r.offset + r.size, signal, true);
              read.catch(() => {});
              inflight.push({ ...f, size: r.size, faces: b.face_end - b.face_begin, vertices: b.vertex_end - b.vertex_begin, read });
            }
          }
        }
        if (evicted) continue;
        if (!inflight.length) {
          // Nothing more for this view: the paced items left, the completion where it is wanted
          // and fits, then wait for a change.
          if (await this._takePaced(signal, true)) continue;
          if (await this._takeCompletion(signal)) continue;
          if (!this.settled || key !== lastKey) {
            this.settled = true;
            lastKey = key;
            s._emit('settled');
          }
          while (!signal.aborted && this._viewKey() === key) await sleep(SETTLED_POLL_MS, signal);
          continue;
        }
        this.settled = false;
        const f = inflight[0];
        const data = await f.read;
        inflight.shift();
        if (signal.aborted) { if (data.release) data.release(); return; }
        try {
          await s._viewApply(f.mesh, f.block, data);
          this.meshes[f.mesh].held.add(f.block);
        } finally {
          if (data.release) data.release();
        }
        s._bytes += data.length;
        this.blocksApplied++;
        this.peakResident = Math.max(this.peakResident, this.resident());
        s._emit('chunk', { kind: 'block', mesh: f.mesh, block: f.block });
        s._emit('progress');
        await this._yield();
      }
    } finally {
      for (const x of inflight) x.read.then((d) => { if (d && d.release) d.release(); }, () => {});
    }
  }

  // Between two blocks: a task boundary, and an animation frame every FRAME_EVERY_MS (a block
  // need not wait for a frame of its own: where frames are slow, a software GL drawing a million
  // triangles, that would hold the refinement to one block per frame).
  async _yield() {
    const now = performance.now();
    if (now - this._lastFrame < FRAME_EVERY_MS) { await nextTask(); return; }
    await pause();
    this._lastFrame = performance.now();
  }

  // When the budget was lowered under what a completion holds: its meshes back to their blocks
  // (decoded again from those held; the completion can be taken again later). Resolves with
  // whether it gave one back.
  async _uncomplete(signal) {
    const s = this.s;
    if (!this.completed.size || this.resident() <= s.options.triangleBudget) return false;
    for (const [i, m] of this.completed) {
      await s._viewRebuild(i, [...m.held]);
      this.meshes[i] = m;
      this.rebuilds++;
      if (signal.aborted) break;
    }
    this.completion = this._completionChunk;
    this.completed.clear();
    return true;
  }

  // planBlocks for the camera now, the blocks on their way (`inflight`) counted as held; at most
  // `max` blocks.
  _plan(inflight, max) {
    const s = this.s;
    this._prepare();
    let resident = this.resident();
    const views = this.meshes.map((m, i) => {
      if (!m) return null;
      const pending = new Set(), mine = inflight.filter((x) => x.mesh === i);
      for (const x of mine) pending.add(x.block);
      const faces = mine.reduce((a, x) => a + x.faces, 0), vertices = mine.reduce((a, x) => a + x.vertices, 0);
      resident += faces;
      return { ...m, pending, faces: s.meshes[i].faces + faces, vertices: s.meshes[i].vertices + vertices };
    });
    const plan = planBlocks(views, resident, s.options.triangleBudget, (i, k) => this.scale(i, k), { max });
    this.screenError = plan.error;
    return plan;
  }

  // Drops the blocks of `evict` ([{mesh, blocks}]): each mesh decoded again from the rest.
  async _drop(evict, signal) {
    for (const e of evict) {
      const m = this.meshes[e.mesh], drop = new Set(e.blocks);
      const keep = [...m.held].filter((k) => !drop.has(k));
      await this.s._viewRebuild(e.mesh, keep);
      m.held = new Set(keep);
      this.rebuilds++;
      if (signal.aborted) return;
    }
  }

  // Takes the completion when the screen error left is over the tolerance (blocks it cut off
  // are in view) and its meshes' full detail fits the budget; its block meshes are then whole
  // (no longer chosen by view). Resolves with whether it took it.
  async _takeCompletion(signal) {
    const s = this.s, c = this.completion;
    if (!c || !(this.screenError > 1)) return false;
    let resident = this.resident();
    for (const e of c.chunk.meshes) resident += e.faces - s.meshes[e.mesh].faces;
    if (resident > s.options.triangleBudget || s._bytes + c.chunk.size > s.options.budgetBytes) return false;
    const data = await s._reader.read(c.chunk.offset, c.chunk.offset + c.chunk.size, signal, true);
    try {
      await s._applyChunk(c.index, c.chunk, data);
    } finally {
      if (data.release) data.release();
    }
    s._bytes += c.chunk.size;
    for (const e of c.chunk.meshes) {
      this.completed.set(e.mesh, this.meshes[e.mesh]);
      this.meshes[e.mesh] = null;
    }
    this.completion = null;
    this.screenError = 0;
    this.peakResident = Math.max(this.peakResident, this.resident());
    s._emit('chunk', { chunk: c.index, kind: 'complete' });
    s._emit('progress');
    return true;
  }

  // Takes the paced items whose stored bytes are due (all that are left with `all`). Resolves
  // with whether it took one.
  async _takePaced(signal, all) {
    const s = this.s;
    let took = false;
    while (this.pacedAt < this.paced.length && !signal.aborted) {
      const item = this.paced[this.pacedAt];
      if (!all && item.bytesBefore > s._bytes) break;
      const c = item.chunk;
      const start = item.parts ? item.parts[0].offset : c.offset;
      const end = item.parts ? item.parts[item.parts.length - 1].offset + item.parts[item.parts.length - 1].part.bytes : c.offset + c.size;
      if (s._bytes + (end - start) > s.options.budgetBytes) break;
      const data = await s._reader.read(start, end, signal, true);
      try {
        if (item.parts) await s._viewChainParts(item.index, item.parts, start, data);
        else await s._applyChunk(item.index, c, data);
      } finally {
        if (data.release) data.release();
      }
      s._bytes += end - start;
      this.pacedAt++;
      took = true;
      this.peakResident = Math.max(this.peakResident, this.resident());
      s._emit('chunk', { chunk: item.index, kind: c.kind });
      s._emit('progress');
      await pause();
      if (c.kind === 'texture' && !s.options.uploadsBeside) await s._gpuIdle();
    }
    return took;
  }
}

function sleep(ms, signal) {
  return new Promise((resolve) => {
    const timer = setTimeout(done, ms);
    function done() { clearTimeout(timer); signal.removeEventListener('abort', done); resolve(); }
    signal.addEventListener('abort', done, { once: true });
  });
}
