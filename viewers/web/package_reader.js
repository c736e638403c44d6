// package_reader.js — reading a meshmux stream package (model.mmxp, version PACKAGE_VERSION;
// layout in stream/format.h) over HTTP: byte ranges of one URL (RangeReader), the table's and
// base's inflation (inflate) and the validation of the package's JSON table against the file
// (validateTable). Used by meshmux.js. The format's constants come from stream_format.js,
// generated from stream/format.h at build time.

import {
  BLOCK_PACKAGE_VERSION, CHANNEL_NAMES, MAX_BASE_BYTES, MAX_KEPT_IMAGES, MAX_TABLE_BYTES, MAX_TEXTURE_SIDE, PACKAGE_VERSION,
  PART_ELEMENTS_CONSTANT, PART_ELEMENTS_PER_BYTE, RANGE_CODER_FLUSH_BYTES,
} from './stream_format.js';

export { BLOCK_PACKAGE_VERSION, MAX_BASE_BYTES, MAX_TABLE_BYTES, PACKAGE_VERSION };
// Bytes a client keeps per vertex (float position, normal, uv; quantized copies; corner list).
const VERTEX_BYTES = 48;
// The per-mesh element cap comes from the table's "limits" (written by the C++ writer, which
// enforces the same number); this only bounds what a hostile table may claim, at what typed
// arrays of a client's vertices can hold.
const TYPED_ARRAY_ELEMENTS = 2 ** 30 / VERTEX_BYTES;
// A part's coded bytes stand for at most PART_ELEMENTS_PER_BYTE splits and faces per byte, plus
// PART_ELEMENTS_CONSTANT, and hold at least the range coder's head (stream/vsplit.h
// part_size_plausible).
const PART_MIN_BYTES = RANGE_CODER_FLUSH_BYTES;

// Inflates the package's table or base (a zlib stream) with the browser's DecompressionStream, refusing output past
// `limit` bytes (a zlib bomb) and trailing or missing bytes.
export async function inflate(bytes, limit, format = 'deflate') {
  const stream = new DecompressionStream(format);
  const writer = stream.writable.getWriter();
  writer.write(bytes).catch(() => {});
  writer.close().catch(() => {});
  const reader = stream.readable.getReader();
  const pieces = [];
  let total = 0;
  try {
    for (;;) {
      const { done, value } = await reader.read();
      if (done) break;
      total += value.length;
      if (total > limit) throw new Error(`inflates past its limit of ${limit} bytes`);
      pieces.push(value);
    }
  } catch (e) {
    reader.cancel().catch(() => {});
    throw new Error(e.message.includes('limit') ? e.message : `not a complete ${format === 'deflate' ? 'zlib' : format} stream (${e.message})`);
  }
  if (pieces.length === 1) return pieces[0];
  const out = new Uint8Array(total);
  let at = 0;
  for (const p of pieces) { out.set(p, at); at += p.length; }
  return out;
}

// ---- The package table -----------------------------------------------------------------------

// The block index's lists (stream/format.h "Block index": {blocks, parts}, parsed) put where a
// table without an index holds them: each block mesh's "blocks" (the table gives its count), each
// mesh chunk's "parts". Returns a new table object; throws fail(message) where they do not fit.
export function mergeIndex(t, index, fail) {
  const need = (ok, message) => { if (!ok) throw fail(message); };
  need(index && typeof index === 'object' && Array.isArray(index.blocks) && Array.isArray(index.parts),
    'the block index must be {"blocks": [...], "parts": [...]}');
  need(Array.isArray(t.meshes) && index.blocks.length === t.meshes.length, 'the block index does not hold one entry per mesh');
  const meshes = t.meshes.map((m, i) => {
    const list = index.blocks[i], listed = list !== null;
    need(listed === (m !== null && typeof m === 'object' && m.blocks !== undefined)
      && (!listed || (Array.isArray(list) && m.blocks === list.length)), `meshes[${i}]: its "blocks" count and the index's list differ`);
    return listed ? { ...m, blocks: list } : m;
  });
  need(Array.isArray(t.chunks), 'chunks must be an array');
  let next = 0;
  const chunks = t.chunks.map((c) => {
    if (!c || c.kind !== 'mesh') return c;
    need(c.parts === undefined, 'a mesh chunk carries parts in the table and in the block index');
    need(next < index.parts.length, 'the block index holds fewer part lists than mesh chunks');
    return { ...c, parts: index.parts[next++] };
  });
  need(next === index.parts.length, 'the block index holds more part lists than mesh chunks');
  return { ...t, meshes, chunks, merged: true };
}

// A whole package's table as parsed, its block index merged in (mergeIndex), for tools that hold
// the file (`bytes`) and a synchronous inflater (`inflateSync(bytes)` → bytes, node's
// zlib.inflateSync): {raw, dataStart}, to validate with validateTable.
export function rawTableOf(bytes, inflateSync, fail = (m) => new Error(m)) {
  const J = new DataView(bytes.buffer, bytes.byteOffset).getUint32(8, true), dataStart = 12 + J;
  const parse = (b) => JSON.parse(new TextDecoder('utf-8').decode(inflateSync(b)));
  let raw = parse(bytes.subarray(12, dataStart));
  if (raw && raw.index && Number.isSafeInteger(raw.index.offset) && Number.isSafeInteger(raw.index.size)) {
    const at = dataStart + raw.index.offset;
    raw = mergeIndex(raw, parse(bytes.subarray(at, at + raw.index.size)), fail);
  }
  return { raw, dataStart };
}

// Validates the parsed JSON table against the file and returns it normalized (numbers checked,
// mesh parts contiguous, orders complete; offsets, which count from the data start, made
// absolute). `fail(message)` makes the Error to throw. A package with blocks keeps its block
// lists and parts in the block index (stream/format.h): its table alone (not mergeIndex's) is
// read as far as the first picture needs, its block meshes' blocks and its mesh chunks' parts
// left empty (each mesh's blockCount says how many blocks it has) and `indexPending` true;
// validated again once merged, it is whole.
export function validateTable(t, { fileSize, dataStart, fail }) {
  const need = (ok, message) => { if (!ok) throw fail(message); };
  const obj = (v, what) => { need(v && typeof v === 'object' && !Array.isArray(v), `${what} must be an object`); return v; };
  const arr = (v, what) => { need(Array.isArray(v), `${what} must be an array`); return v; };
  const int = (v, what, max = Number.MAX_SAFE_INTEGER) => {
    need(Number.isSafeInteger(v) && v >= 0 && v <= max, `${what} must be an integer in [0, ${max}] (got ${JSON.stringify(v)})`);
    return v;
  };
  const dist = (v, what) => {  // a distortion: a finite number, or missing (NaN)
    need(v == null || Number.isFinite(v), `${what} must be a finite number`);
    return v == null ? NaN : v;
  };
  const range = (r, what) => {
    const offset = dataStart + int(r.offset, `${what}.offset`), size = int(r.size, `${what}.size`);
    need(offset + size <= fileSize, `${what} [${offset}, ${offset + size}) runs past the end of the file (${fileSize} bytes)`);
    return { offset, size };
  };

  obj(t, 'the table');
  need(t.version === PACKAGE_VERSION || t.version === BLOCK_PACKAGE_VERSION,
    `table version ${JSON.stringify(t.version)}, expected ${PACKAGE_VERSION} or ${BLOCK_PACKAGE_VERSION}`);
  const num = (v, what, lo = -Infinity, hi = Infinity) => {
    need(Number.isFinite(v) && v >= lo && v <= hi, `${what} must be a number in [${lo}, ${hi}] (got ${JSON.stringify(v)})`);
    return v;
  };
  const vec3 = (v, what) => { need(Array.isArray(v) && v.length === 3, `${what} must be 3 numbers`); return v.map((x, i) => num(x, `${what}[${i}]`)); };
  // How the distortion was measured: the viewer frames and shades with these (no copies here).
  const v = obj(t.view, 'view');
  const view = {
    fov: num(v.fov_y_degrees, 'view.fov_y_degrees', 0, 180), fill: num(v.fill, 'view.fill', 1e-3, 1e3),
    direction: vec3(v.direction, 'view.direction'), clipMargin: num(v.clip_margin, 'view.clip_margin', 1e-3, 1e3),
    ambient: num(v.ambient, 'view.ambient', 0, 10), diffuse: num(v.diffuse, 'view.diffuse', 0, 10),
    lightDirection: vec3(v.light_direction, 'view.light_direction'), lightFollowsCamera: v.light_follows_camera !== false,
    // "physical" = MeshStandardMaterial under a uniform environment and a light;
    // packages without the field were measured with the Lambert shading.
    physical: v.shading === 'physical',
  };
  // As the C++ reader (stream/package_read.cpp read_view): the field of view inside (0, 180).
  need(view.fov > 0 && view.fov < 180, `view.fov_y_degrees must be in (0, 180) (got ${view.fov})`);
  need(v.shading === undefined || v.shading === 'lambert' || v.shading === 'physical', `view.shading must be "lambert" or "physical" (got ${JSON.stringify(v.shading)})`);
  // Optional, as the C++ reader: the display the order was made for, two integers in [1, 65536].
  if (v.display !== undefined) {
    need(Array.isArray(v.display) && v.display.length === 2, 'view: "display" must be two integers');
    view.display = v.display.map((x, i) => int(x, `view.display[${i}]`, 65536));
    need(view.display.every((x) => x >= 1), 'view: display out of range');
  }
  // Optional, as the C++ reader: what the distortions are ("mse" or "ciede2000", the default).
  need(v.metric === undefined || v.metric === 'mse' || v.metric === 'ciede2000', `view.metric must be "mse" or "ciede2000" (got ${JSON.stringify(v.metric)})`);
  view.metric = v.metric === 'mse' ? 'mse' : 'ciede2000';
  if (view.physical) {
    view.environment = num(v.environment, 'view.environment', 0, 100);
    view.lightIntensity = num(v.light_intensity, 'view.light_intensity', 0, 1000);
  }
  const limits = obj(t.limits, 'limits');
  const MAX_ELEMENTS = Math.min(int(limits.max_elements, 'limits.max_elements'), TYPED_ARRAY_ELEMENTS);
  const maxSide = Math.min(int(limits.max_texture_side, 'limits.max_texture_side'), MAX_TEXTURE_SIDE);
  const base = { ...range(obj(t.base, 'base'), 'base'), distortion: dist(t.base.distortion, 'base.distortion') };
  need(typeof t.base.deflated === 'boolean', 'base.deflated must be true or false');
  base.deflated = t.base.deflated;
  base.glbSize = int(t.base.glb_size, 'base.glb_size', MAX_BASE_BYTES);
  // Optional: the base is the whole model (Draco-coded, no mesh chunk follows).
  need(t.base.whole === undefined || typeof t.base.whole === 'boolean', 'base.whole must be true or false');
  base.whole = t.base.whole === true;
  // The block index (version 17): right after the base; the table alone waits for it.
  const index = t.version === BLOCK_PACKAGE_VERSION && t.index !== undefined ? range(obj(t.index, 'index'), 'index') : null;
  need(t.version === BLOCK_PACKAGE_VERSION || t.index === undefined, `index in a version ${t.version} package`);
  need(!index || (index.offset === base.offset + base.size && index.size > 0), 'index must follow the base, not empty');
  const pending = index !== null && t.merged !== true;
  need(base.deflated || base.glbSize === base.size, `base.glb_size ${base.glbSize} differs from its stored size ${base.size}`);
  need(base.glbSize >= 20, `the base .glb is ${base.glbSize} bytes, too small for a glb`);
  const meshes = arr(t.meshes, 'meshes').map((m, i) => {
    const w = `meshes[${i}]`;
    obj(m, w);
    const d = {
      vertices: int(m.vertices, `${w}.vertices`, MAX_ELEMENTS), faces: int(m.faces, `${w}.faces`, MAX_ELEMENTS),
      base_vertices: int(m.base_vertices, `${w}.base_vertices`, m.vertices), base_faces: int(m.base_faces, `${w}.base_faces`, m.faces),
      bounds: arr(m.bounds, `${w}.bounds`), quantization: obj(m.quantization, `${w}.quantization`),
    };
    need(d.bounds.length === 6 && d.bounds.every(Number.isFinite), `${w}.bounds must be 6 finite numbers`);
    d.quantization = { origin: vec3(d.quantization.origin, `${w}.quantization.origin`), step: num(d.quantization.step, `${w}.quantization.step`, Number.MIN_VALUE) };
    if (pending && m.blocks !== undefined) {  // the count; the list is in the index
      d.blocks = [];
      d.blockCount = int(m.blocks, `${w}.blocks (count)`, 65535);
      need(d.blockCount > 0, `${w}.blocks: a block mesh has no blocks`);
    } else {
      d.blocks = m.blocks === undefined ? [] : readBlocks(m.blocks, d, w);
      d.blockCount = d.blocks.length;
    }
    return d;
  });
  // A mesh's block hierarchy (stream/format.h "Blocks"): [level, error, box, deps] each, the
  // dependencies on earlier blocks only (a later or the same block would be a cycle), the box on
  // the position grid, the error finite; the ranges come from the parts (blockRanges below).
  function readBlocks(list, d, w) {
    need(t.version === BLOCK_PACKAGE_VERSION, `${w}.blocks in a version ${t.version} package`);
    arr(list, `${w}.blocks`);
    need(list.length > 0 && list.length <= 65535, `${w}.blocks must hold 1 to 65535 blocks`);
    return list.map((b, k) => {
      const bw = `${w}.blocks[${k}]`;
      need(Array.isArray(b) && b.length === 4, `${bw} must be [level, error, box, deps]`);
      const box = arr(b[2], `${bw}[2] (box)`);
      need(box.length === 6 && box.every((x) => Number.isSafeInteger(x) && x >= 0 && x <= 65535)
        && box[0] <= box[3] && box[1] <= box[4] && box[2] <= box[5], `${bw}: box must be 6 grid integers, minimum then maximum`);
      const deps = arr(b[3], `${bw}[3] (deps)`).map((x, i) => int(x, `${bw}.deps[${i}]`));
      deps.forEach((x, i) => {
        need(x < list.length, `${bw}: depends on block ${x}, which is missing`);
        need(x < k, `${bw}: depends on block ${x}, not an earlier one (a dependency cycle)`);
        need(i === 0 || x > deps[i - 1], `${bw}: dependencies must be strictly ascending`);
      });
      return { level: int(b[0], `${bw}[0] (level)`, 65535), error: num(b[1], `${bw}[1] (error)`, 0), box, deps,
        vertex_begin: 0, vertex_end: 0, face_begin: 0, face_end: 0 };
    });
  }
  // The blocks' ranges from the parts naming them: each begins where the one before it ends
  // (the first at the base) and ends where its part does (or where it begins, named by none);
  // the last ends at the mesh's end unless a completion ends its splits.
  function blockRanges(chunkList) {
    const ends = meshes.map((m) => m.blocks.map(() => null));
    const completed = meshes.map(() => false);  // a completion ends the mesh's splits
    for (const c of Array.isArray(chunkList) ? chunkList : []) {
      if (c && c.kind === 'complete' && Array.isArray(c.meshes)) {
        for (const e of c.meshes) if (Array.isArray(e) && Number.isSafeInteger(e[0]) && e[0] >= 0 && e[0] < meshes.length) completed[e[0]] = true;
      }
      for (const p of c && Array.isArray(c.parts) ? c.parts : []) {
        if (!Array.isArray(p) || p.length !== 5 || !p.every(Number.isSafeInteger)) continue;
        const e = ends[p[0]];
        if (e && p[4] >= 0 && p[4] < e.length && e[p[4]] === null) e[p[4]] = [p[1], p[2]];
      }
    }
    meshes.forEach((m, i) => {
      if (m.blocks.length === 0) return;
      let vertexAt = m.base_vertices, faceAt = m.base_faces;
      m.blocks.forEach((b, k) => {
        b.vertex_begin = vertexAt;
        b.face_begin = faceAt;
        const e = ends[i][k];
        if (e) {
          need(e[0] >= vertexAt && e[1] >= faceAt && e[0] <= m.vertices && e[1] <= m.faces,
            `meshes[${i}].blocks[${k}] ends at vertex ${e[0]}, face ${e[1]}, before it begins or past the mesh`);
          [vertexAt, faceAt] = e;
        }
        b.vertex_end = vertexAt;
        b.face_end = faceAt;
      });
      need(completed[i] || (vertexAt === m.vertices && faceAt === m.faces), `meshes[${i}].blocks end at vertex ${vertexAt}, face ${faceAt}, not at the mesh's end`);
    });
  }
  const texture = t.texture == null ? null
    : { width: int(obj(t.texture, 'texture').width, 'texture.width'), height: int(t.texture.height, 'texture.height') };

  // Chunks, with the parts simulated in stream order: each continues where its mesh stands.
  blockRanges(t.chunks);
  const held = meshes.map((m) => ({ vertices: m.base_vertices, faces: m.base_faces }));
  const sent = meshes.map((m) => new Uint8Array(m.blocks.length));  // per block mesh: its parts read
  let completed = false;  // the completion was read: no mesh chunk may follow
  const chunks = arr(t.chunks, 'chunks').map((c, i) => {
    const w = `chunks[${i}]`;
    const chunk = { kind: obj(c, w).kind, ...range(c, w), distortion: dist(c.distortion, `${w}.distortion`) };
    if (c.kind === 'texture') {
      // Its maps' files one after another, base colour first (one texture step may carry
      // several channels at one size).
      const CHANNELS = CHANNEL_NAMES;
      let at = chunk.offset;
      const maps = arr(c.maps, `${w}.maps`).map((m, j) => {
        const mw = `${w}.maps[${j}]`;
        obj(m, mw);
        need(CHANNELS.includes(m.channel), `${mw}.channel ${JSON.stringify(m.channel)} is not one of ${CHANNELS.join(', ')}`);
        need((j === 0) === (m.channel === 'base_color'), `${mw}: base_color must come first, once`);
        need(/^image\/(jpeg|png|ktx2)$/.test(m.mime), `${mw}.mime ${JSON.stringify(m.mime)} is not image/jpeg, image/png or image/ktx2`);
        const size = int(m.size, `${mw}.size`);
        need(size > 0 && at + size <= chunk.offset + chunk.size, `${mw}: ${size} bytes do not fit the chunk`);
        const map = { channel: m.channel, mime: m.mime, offset: at, size };
        at += size;
        return map;
      });
      // Then the images of materials kept beside the atlas at this level's scale, each standing
      // for the base .glb image tagged extras.meshmux_image = image.
      const kept = (c.kept === undefined ? [] : arr(c.kept, `${w}.kept`)).map((k, j) => {
        const kw = `${w}.kept[${j}]`;
        obj(k, kw);
        need(/^image\/(jpeg|png|ktx2)$/.test(k.mime), `${kw}.mime ${JSON.stringify(k.mime)} is not image/jpeg, image/png or image/ktx2`);
        const size = int(k.size, `${kw}.size`);
        need(size > 0 && at + size <= chunk.offset + chunk.size, `${kw}: ${size} bytes do not fit the chunk`);
        const map = { image: int(k.image, `${kw}.image`, MAX_KEPT_IMAGES - 1), width: int(k.width, `${kw}.width`, maxSide),
          height: int(k.height, `${kw}.height`, maxSide), mime: k.mime, offset: at, size };
        need(map.width > 0 && map.height > 0, `${kw}: a side is 0`);
        at += size;
        return map;
      });
      need(maps.length > 0 && at === chunk.offset + chunk.size, `${w}: its maps hold ${at - chunk.offset} bytes, the chunk ${chunk.size}`);
      need(new Set(maps.map((m) => m.channel)).size === maps.length, `${w}: a channel appears twice`);
      need(new Set(kept.map((m) => m.image)).size === kept.length, `${w}: a kept image appears twice`);
      return { ...chunk, width: int(c.width, `${w}.width`), height: int(c.height, `${w}.height`), maps, kept };
    }
    need(c.kind === 'mesh' || c.kind === 'complete', `${w}.kind ${JSON.stringify(c.kind)} is not "mesh", "complete" or "texture"`);
    need(!base.whole, `${w}: a mesh refinement in a package whose base is the whole model`);
    need(!completed, `${w}: a mesh chunk after the completion`);
    if (c.kind === 'complete') {
      // The full mesh single-rate (stream/format.h "Completion"): per mesh [mesh, points,
      // faces, bytes], a Draco bitstream each, one after the other; each mesh once.
      completed = true;
      let at = chunk.offset;
      const seen = new Set();
      chunk.meshes = arr(c.meshes, `${w}.meshes`).map((e, j) => {
        const ew = `${w}.meshes[${j}]`;
        need(Array.isArray(e) && e.length === 4, `${ew} must be [mesh, points, faces, bytes]`);
        const entry = { mesh: int(e[0], `${ew}[0] (mesh)`, meshes.length - 1), vertices: int(e[1], `${ew}[1] (points)`, MAX_ELEMENTS),
          faces: int(e[2], `${ew}[2] (faces)`, MAX_ELEMENTS), offset: at, bytes: int(e[3], `${ew}[3] (bytes)`) };
        entry.face_begin = held[entry.mesh].faces;  // what the splits before it hold
        need(!seen.has(entry.mesh), `${ew}: mesh ${entry.mesh} twice`);
        seen.add(entry.mesh);
        need(entry.bytes > 0 && at + entry.bytes <= chunk.offset + chunk.size, `${ew}: ${entry.bytes} bytes do not fit the chunk`);
        at += entry.bytes;
        held[entry.mesh] = { vertices: meshes[entry.mesh].vertices, faces: meshes[entry.mesh].faces };
        return entry;
      });
      need(chunk.meshes.length > 0 && at === chunk.offset + chunk.size, `${w}: its meshes hold ${at - chunk.offset} bytes, the chunk ${chunk.size}`);
      chunk.parts = [];
      return chunk;
    }
    if (pending) {  // its parts are in the index
      need(c.parts === undefined, `${w}: parts in the table of a package with a block index`);
      chunk.parts = [];
      return chunk;
    }
    let bytes = 0;
    chunk.parts = arr(c.parts, `${w}.parts`).map((p, j) => {
      // [mesh, vertex_end, face_end, bytes], starting where its mesh stands; a block mesh's
      // [mesh, vertex_end, face_end, bytes, block], its block's range, after its dependencies.
      const pw = `${w}.parts[${j}]`;
      need(Array.isArray(p) && p.length >= 4, `${pw} must be [mesh, vertex_end, face_end, bytes]`);
      const mesh = int(p[0], `${pw}[0] (mesh)`, meshes.length - 1), m = meshes[mesh], h = held[mesh];
      const blocky = m.blocks.length > 0;
      need(p.length === (blocky ? 5 : 4), blocky ? `${pw} must be [mesh, vertex_end, face_end, bytes, block]`
        : `${pw} must be [mesh, vertex_end, face_end, bytes]`);
      const part = { mesh, vertex_begin: h.vertices, vertex_end: int(p[1], `${pw}[1] (vertex_end)`),
        face_begin: h.faces, face_end: int(p[2], `${pw}[2] (face_end)`), bytes: int(p[3], `${pw}[3] (bytes)`), block: -1 };
      if (blocky) {
        const k = int(p[4], `${pw}[4] (block)`, m.blocks.length - 1), b = m.blocks[k];
        need(part.vertex_end === b.vertex_end && part.face_end === b.face_end,
          `${pw}: block ${k} ends at vertex ${b.vertex_end}, face ${b.face_end}`);
        need(!sent[mesh][k], `${pw}: block ${k} sent twice`);
        for (const x of b.deps) {
          const y = m.blocks[x];
          need(sent[mesh][x] || (y.vertex_end === y.vertex_begin && y.face_end === y.face_begin),
            `${pw}: block ${k} before block ${x}, which it depends on`);
        }
        sent[mesh][k] = 1;
        part.block = k;
        part.vertex_begin = b.vertex_begin;
        part.face_begin = b.face_begin;
      }
      need(part.vertex_end >= part.vertex_begin && part.vertex_end <= m.vertices, `${pw}: vertex_end ${part.vertex_end} outside [${part.vertex_begin}, ${m.vertices}]`);
      need(part.face_end >= part.face_begin && part.face_end <= m.faces, `${pw}: face_end ${part.face_end} outside [${part.face_begin}, ${m.faces}]`);
      const nv = part.vertex_end - part.vertex_begin, nf = part.face_end - part.face_begin;
      // Coded: the range coder's head, and no more splits and faces than its bytes can carry.
      need(part.bytes >= PART_MIN_BYTES && nv + nf <= PART_ELEMENTS_PER_BYTE * part.bytes + PART_ELEMENTS_CONSTANT,
        `${pw}: ${part.bytes} bytes cannot hold ${nv} splits and ${nf} faces`);
      h.vertices = Math.max(h.vertices, part.vertex_end);
      h.faces = Math.max(h.faces, part.face_end);
      bytes += part.bytes;
      return part;
    });
    // The chunk is the parts' coded bytes one after the other.
    need(bytes === chunk.size, `${w}: its parts hold ${bytes} bytes, the chunk ${chunk.size}`);
    return chunk;
  });
  const n = chunks.length;
  meshes.forEach((m, i) => m.blocks.forEach((b, k) => need(sent[i][k] || (b.vertex_end === b.vertex_begin && b.face_end === b.face_begin),
    `meshes[${i}].blocks[${k}] is in no part`)));
  need(pending || meshes.every((m) => m.blockCount === m.blocks.length), 'a block mesh without its block list');

  // Orders: permutations of the chunks that keep the mesh chunks' relative order.
  const orders = (t.orders === undefined ? [{ name: 'rate-distortion', chunks: chunks.map((_, i) => i) }] : arr(t.orders, 'orders')).map((o, k) => {
    const w = `orders[${k}] ("${obj(o, `orders[${k}]`).name}")`;
    need(typeof o.name === 'string' && o.name, `orders[${k}].name must be a non-empty string`);
    const seq = arr(o.chunks, `${w}.chunks`), seen = new Uint8Array(n);
    need(seq.length === n, `${w} lists ${seq.length} chunks, the package has ${n}`);
    let lastMesh = -1;
    seq.forEach((c, i) => {
      need(!seen[int(c, `${w}.chunks[${i}]`, n - 1)]++, `${w} lists chunk ${c} twice`);
      if (chunks[c].kind === 'texture') return;  // mesh chunks and the completion keep their order
      need(c > lastMesh, `${w} reorders mesh chunks (${c} after ${lastMesh})`);
      lastMesh = c;
    });
    const distortion = o.distortion === undefined ? seq.map((c) => chunks[c].distortion)
      : arr(o.distortion, `${w}.distortion`).map((d, i) => dist(d, `${w}.distortion[${i}]`));
    need(distortion.length === n, `${w} has ${distortion.length} distortion values for ${n} chunks`);
    return { name: o.name, chunks: seq.slice(), distortion };
  });
  need(orders.length > 0, 'orders is empty');
  need(orders[0].chunks.every((c, i) => c === i), `orders[0] ("${orders[0].name}") is not the file order`);

  // The per-view table (optional): the distortion of every cell (mesh layers received ×
  // texture levels received) from each view of the viewing sphere, for re-planning the order
  // for the viewer's camera (view_plan.js).
  let viewTable = null;
  if (t.view_table !== undefined && t.view_table !== null) {
    const v = obj(t.view_table, 'view_table');
    const meshLayers = int(v.mesh_layers, 'view_table.mesh_layers', n + 1);
    const textureLayers = int(v.texture_layers, 'view_table.texture_layers', n + 1);
    const meshChunks = chunks.filter((c) => c.kind !== 'texture').length;
    need(meshLayers === meshChunks + 1 && textureLayers === n - meshChunks + 1,
      `view_table is ${meshLayers} × ${textureLayers} cells, the chunks make ${meshChunks + 1} × ${n - meshChunks + 1}`);
    const directions = arr(v.directions, 'view_table.directions').map((d, i) => {
      need(Array.isArray(d) && d.length === 3 && d.every(Number.isFinite), `view_table.directions[${i}] must be 3 finite numbers`);
      return d.slice();
    });
    need(directions.length > 0 && directions.length <= 4096, 'view_table.directions must hold 1 to 4096 views');
    const triangles = arr(v.triangles, 'view_table.triangles').map((tri, i) => {
      need(Array.isArray(tri) && tri.length === 3, `view_table.triangles[${i}] must be 3 view indices`);
      return tri.map((x, k) => int(x, `view_table.triangles[${i}][${k}]`, directions.length - 1));
    });
    const cells = arr(v.distortion, 'view_table.distortion');
    need(cells.length === meshLayers * textureLayers, `view_table.distortion has ${cells.length} cells, not ${meshLayers * textureLayers}`);
    const distortion = cells.map((c, i) => {
      if (c === null) return null;
      need(Array.isArray(c) && c.length === directions.length && c.every(Number.isFinite),
        `view_table.distortion[${i}] must be null or ${directions.length} finite numbers`);
      return c.slice();
    });
    viewTable = { directions, triangles, mesh_layers: meshLayers, texture_layers: textureLayers, distortion };
    if (v.texture_widths !== undefined) {
      const widths = arr(v.texture_widths, 'view_table.texture_widths');
      need(widths.length === textureLayers, `view_table.texture_widths has ${widths.length} widths, not ${textureLayers}`);
      viewTable.texture_widths = widths.map((w, i) => {
        const x = int(w, `view_table.texture_widths[${i}]`, maxSide);
        need(x >= 1 && (i === 0 || x >= widths[i - 1]), `view_table.texture_widths[${i}] must be at least 1 and not below the level before`);
        return x;
      });
    }
  }

  // Not fatal: a complete stream should end on the full mesh sizes.
  const notes = pending ? [] : held.flatMap((h, i) => (h.vertices === meshes[i].vertices && h.faces === meshes[i].faces ? []
    : [`mesh ${i}: the stream ends at ${h.vertices} vertices / ${h.faces} faces, the table says ${meshes[i].vertices} / ${meshes[i].faces}`]));
  return { version: t.version, view, base, index, indexPending: pending, meshes, texture, chunks, orders, view_table: viewTable, notes };
}

// ---- HTTP ranges -----------------------------------------------------------------------------

// What the reader needs of a response: {status, statusText, contentRange, bytes}.
async function responseParts(res) {
  return { status: res.status, statusText: res.statusText, contentRange: res.headers.get('Content-Range'),
    bytes: new Uint8Array(await res.arrayBuffer()) };
}

// Bytes [start, end) of `url` asked for with a Range header; resolves with responseParts.
export async function fetchRange(url, start, end, signal) {
  return responseParts(await fetch(url, { headers: { Range: `bytes=${start}-${end - 1}` }, signal }));
}

// At most `max` tasks at once (range requests of several streams): run(fn) waits for a slot.
// `peak` is the most that ran at once.
export class RequestLimiter {
  constructor(max = 6) {
    this.max = Number.isFinite(max) && max >= 1 ? Math.floor(max) : 6;
    this.active = 0;
    this.peak = 0;
    this._waiting = [];
  }

  async run(fn) {
    while (this.active >= this.max) await new Promise((resolve) => this._waiting.push(resolve));
    this.active++;
    this.peak = Math.max(this.peak, this.active);
    try {
      return await fn();
    } finally {
      this.active--;
      const next = this._waiting.shift();
      if (next) next();
    }
  }
}

// Reads byte ranges of one URL; falls back to the whole body when the server ignores Range.
export class RangeReader {
  constructor(url) {
    this.url = url;
    this.limiter = null;  // a RequestLimiter its requests wait for, or null
    this.whole = null;   // the entire file, once a server answered 200
    this.prefix = null;  // the probe's bytes, reused when a later range falls inside
    this.size = NaN;     // the file size, once known
  }

  _error(message) { return new Error(`meshmux: ${this.url}: ${message}`); }

  // `pending`: a fetch of exactly this range already under way (a Promise of its Response).
  // Later ranges go through `this.fetchRange` when set (a function like fetchRange: the
  // stream's worker fetches them, so their bodies never pass through the page's main thread).
  async _fetch(start, end, signal, pending = null, hold = false) {
    let res;
    try {
      const request = () => (this.fetchRange || fetchRange)(this.url, start, end, signal, hold);
      res = pending ? await responseParts(await pending)
        : await (this.limiter ? this.limiter.run(request) : request());
    } catch (e) {
      if (e.name === 'AbortError') throw e;
      throw this._error(`cannot fetch bytes ${start}-${end - 1} (${e.message})`);
    }
    if (res.status === 200) {
      this.whole = res.bytes;
      this.size = this.whole.length;
      return this.whole.subarray(start, Math.min(end, this.size));
    }
    if (res.status !== 206) throw this._error(`HTTP ${res.status}${res.statusText ? ' ' + res.statusText : ''} for bytes ${start}-${end - 1}`);
    const range = /^bytes (\d+)-(\d+)\/(\d+|\*)$/.exec(res.contentRange || '');
    if (range && Number(range[1]) !== start) {
      if (res.bytes.release) res.bytes.release();  // held by a worker (read's hold)
      throw this._error(`asked for bytes from ${start}, the server sent ${range[0]}`);
    }
    if (range && range[3] !== '*') this.size = Number(range[3]);
    return res.bytes;
  }

  // The first n bytes (fewer if the file is shorter); `pending`, a request for them (Range:
  // bytes=0-(n-1)) the page already made, is taken over instead of asking again.
  async probe(n, signal, pending = null) {
    this.prefix = await this._fetch(0, n, signal, pending);
    if (!Number.isFinite(this.size) && this.prefix.length < n) this.size = this.prefix.length;
    return this.prefix;
  }

  // Exactly bytes [start, end). With `hold`, where `this.fetchRange` is a worker's that can
  // keep them (StreamWorker.fetchRange), they may come as the worker's HeldBytes (release()
  // them once used) instead of a Uint8Array.
  async read(start, end, signal, hold = false) {
    if (end <= start) return new Uint8Array(0);
    if (this.whole && end > this.whole.length) throw this._error(`bytes ${start}-${end - 1} lie past the end of the file (${this.whole.length} bytes)`);
    if (this.whole) return this.whole.subarray(start, end);
    if (this.prefix && end <= this.prefix.length) return this.prefix.subarray(start, end);
    const bytes = await this._fetch(start, end, signal, null, hold);
    if (bytes.length < end - start) {
      if (bytes.release) bytes.release();
      throw this._error(`short read: bytes ${start}-${end - 1} gave ${bytes.length} bytes`);
    }
    return bytes.subarray(0, end - start);
  }
}
