// Type declarations of meshmux-stream (meshmux.js): the three.js client of meshmux stream
// packages. See README.md for an example.
import type { Box3, Group, PerspectiveCamera, Camera, Scene, WebGLRenderer } from 'three';

/** The package format version this client reads. */
export const PACKAGE_VERSION: number;
/** three's Draco glTF decoder files by default: beside this module, as meshmux lays them out. */
export const DRACO_DECODER_PATH: string;
/** The bytes of the first request (header, table, often the base). */
export const PROBE_BYTES: number;
/** Resolves after a task boundary (a message, no timer clamping): the page runs its other tasks first. */
export function nextTask(): Promise<void>;
/**
 * Uploads a texture (an ImageBitmap's, or a DataTexture's bytes: a band of those costs the page
 * only the band, an ImageBitmap's is converted whole by chromium for every band) to the GPU in
 * bands of rows of at most `bandBytes`, one band
 * per task while the bands the GPU has not taken yet (over every texture uploading on the
 * context) leave room, then its mipmaps; resolves
 * false (the texture left unfinished) once `alive()` is false. A texture that fits in one band
 * is left to three.js. Bands grow up to `grow` (default 4) times `bandBytes` while the GPU
 * takes them quickly.
 */
export function uploadInBands(renderer: WebGLRenderer, texture: import('three').Texture, bandBytes: number, alive?: () => boolean, grow?: number): Promise<boolean>;

export interface MeshmuxStreamOptions {
  /** The order to play: a name from the package's orders (default "rate-distortion"). */
  order?: string;
  /** Stop before a chunk would take the bytes received past this (default: no limit). */
  budgetBytes?: number;
  /** The most bytes per range request, unless one chunk is larger (default 256 kB). */
  chunkBatchBytes?: number;
  /** The application's renderer: texture anisotropy and GPU pacing between chunks. */
  renderer?: WebGLRenderer | null;
  /**
   * Where three.js's Draco glTF decoder files are (draco_wasm_wrapper.js, draco_decoder.wasm):
   * packages of small models carry a Draco-coded base. Default: beside this module, as
   * `meshmux convert` lays them out; with npm, point it at three's
   * examples/jsm/libs/draco/gltf/ as served by your site.
   */
  dracoDecoderPath?: string;
  /** Where three's basis/ transcoder files are (KTX2 texture levels); default: beside meshmux.js. */
  basisTranscoderPath?: string;
  /** A function giving a Promise of a three KTX2Loader, support detected, shared by many streams. */
  ktx2Loader?: (() => Promise<unknown>) | null;
  /** The camera the model is seen through: the stored order is re-planned for it before each batch. */
  camera?: Camera | null;
  /** false keeps the stored order whatever the camera and canvas (default true). */
  adaptive?: boolean;
  /**
   * A big mesh's block package seen through `camera` (with `adaptive`) is played by view: the
   * blocks the camera needs are fetched by range, detail that left the view is dropped again,
   * and at most this many faces are held (settable). play() then runs until stop(), emitting
   * 'settled' whenever the view is refined to a pixel of screen-space error or the budget is
   * full. Default Infinity: the stored order.
   */
  triangleBudget?: number;
  /**
   * The canvas the model is seen on, [width, height] device pixels: smaller than the package's
   * display (its table's view.display), the order is re-planned so that texture levels no pixel
   * of it resolves come last. Default: the renderer's drawing buffer, read at each re-plan.
   */
  display?: [number, number] | null;
  /**
   * A request for the package's first PROBE_BYTES bytes (Range: bytes=0-65535) the page made
   * before this module loaded: taken over instead of asking again.
   */
  firstBytes?: Promise<Response> | null;
  /**
   * Decode mesh refinements in a Web Worker (stream_worker.js beside this module; default true),
   * with the WebAssembly decoder stream_decoder.wasm beside it (serve it as application/wasm).
   * false, or a page where no worker can start (file://), loads that module on the page and
   * decodes there.
   */
  worker?: boolean;
  /** A WorkerPool whose shared workers decode for this stream instead of a worker of its own. */
  workers?: WorkerPool | null;
  /**
   * The first request's bytes (default PROBE_BYTES): where the header, table and base are known
   * to end (a world file's head_bytes), exactly that, so that the package opens in one request.
   */
  probeBytes?: number;
  /**
   * Gives a three DRACOLoader (a Promise of it, its decoder preloaded) shared with other streams,
   * called only for a Draco-coded base: each DRACOLoader starts its own decoding workers. Not
   * disposed by the stream.
   */
  dracoLoader?: (() => Promise<unknown>) | null;
  /**
   * With a renderer, a texture level goes to the GPU in bands of rows of at most this many
   * bytes, one band per task while the bands the GPU has not taken yet (over every texture
   * uploading on the context) leave room, before it is shown (default 256 KiB; Infinity: three.js uploads it whole inside the next frame).
   */
  uploadBandBytes?: number;
  /**
   * A limiter whose run(job) the base's build waits for (like a RequestLimiter): many streams
   * on one page then build their bases a few at a time, first come first built (MeshmuxWorld
   * passes one).
   */
  builds?: { run<T>(job: () => Promise<T>): Promise<T> } | null;
  /**
   * Default false: a texture level is on screen before the chunk after it is taken. True: once
   * its maps are decoded the stream goes on, the level's upload and swap running beside the
   * next chunks (levels still shown in order; `uploading` is the Promise of the last one).
   * MeshmuxWorld sets it.
   */
  uploadsBeside?: boolean;
  /** A RequestLimiter shared with other streams: their range requests wait for it. */
  limiter?: RequestLimiter | null;
}

export type MeshmuxState =
  | 'idle' | 'opening' | 'base' | 'streaming' | 'complete' | 'stopped' | 'error' | 'disposed';

/** A snapshot of the stream (also every event's detail). */
export interface MeshmuxStats {
  bytesReceived: number;
  bytesTotal: number;
  chunksApplied: number;
  chunkCount: number;
  triangles: number;
  vertices: number;
  textureWidth: number;
  textureHeight: number;
  /** Texels of the images of materials kept beside the atlas, as shown (texture levels bring them up). */
  keptTexels: number;
  /** GPU bytes of every texture shown (RGBA8 with mipmaps, or a KTX2 level's block format). */
  gpuBytes: number;
  /** GPU bytes of the last texture level applied (its maps and kept maps). */
  levelGpuBytes: number;
  /** The distortion the package expects at this point (CIEDE2000, lower is better). */
  distortion: number;
  order: string;
  /** The order being followed: `order`, or "view-adapted" once re-planned for the camera. */
  orderFollowed: string;
  trianglesApplied: number;
  /** Seconds spent decoding and applying mesh refinements (in the worker, when it decodes). */
  applySeconds: number;
  state: MeshmuxState;
  /** Where mesh refinements are decoded. */
  decoder: 'worker' | 'page';
  /** Played by view (triangleBudget): faces held now, the most ever, the budget. */
  residentTriangles?: number;
  peakResidentTriangles?: number;
  triangleBudget?: number;
  /** Played by view: blocks held, in the package, applied in all; times detail was dropped. */
  blocksHeld?: number;
  blockCount?: number;
  blocksApplied?: number;
  rebuilds?: number;
  /** Played by view: the largest screen-space error (pixels) of a block in view not held. */
  screenError?: number;
  /** Played by view: nothing more is needed for this view (or the budget is full). */
  settled?: boolean;
}

/** The view and shading the package's order was measured with (the table's "view"). */
export interface MeshmuxView {
  /** What the table's distortions are: mean squared error per RGB channel, or mean CIEDE2000. */
  metric: 'mse' | 'ciede2000';
  /** The display the order was made for ([width, height] device pixels), when the table says. */
  display?: [number, number];
  physical: boolean;
  environment: number;
  lightIntensity: number;
  lightDirection: [number, number, number];
  lightFollowsCamera: boolean;
  [key: string]: unknown;
}

export interface MeshmuxEventMap {
  /** The base is built: `object` shows the model. */
  base: CustomEvent<MeshmuxStats>;
  /** One chunk applied (render now to show it); played by view, a block too (kind 'block'). */
  chunk: CustomEvent<MeshmuxStats & { chunk?: number; kind: 'mesh' | 'texture' | 'block'; mesh?: number; block?: number }>;
  /** Played by view: the view is refined (or the budget full) until the camera moves. */
  settled: CustomEvent<MeshmuxStats>;
  /** Bytes received changed. */
  progress: CustomEvent<MeshmuxStats>;
  /** Budget reached or stop() called. */
  stopped: CustomEvent<MeshmuxStats>;
  error: CustomEvent<MeshmuxStats & { error: Error }>;
}

export class MeshmuxStream extends EventTarget {
  constructor(url: string | URL, options?: MeshmuxStreamOptions);
  readonly url: string;
  readonly options: Required<MeshmuxStreamOptions>;
  /** Add this to your scene: standard three.js meshes and materials, updated as chunks arrive. */
  readonly object: Group;
  /** The validated package table, once open() resolved. */
  readonly table: ({ view: MeshmuxView; orders: { name: string }[] } & Record<string, unknown>) | null;
  /** Non-fatal findings about the package. */
  readonly notes: string[];
  budgetBytes: number;
  /** Played by view: the faces held at most (lowering it drops detail). */
  triangleBudget: number;
  /** The canvas the order is planned for ([width, height] device pixels), null: the renderer's. */
  display: [number, number] | null;
  /** The canvas size used: `display`, else the renderer's drawing buffer, else null. */
  canvasSize(): [number, number] | null;
  readonly state: MeshmuxState;
  readonly playing: boolean;
  /** uploadsBeside: the Promise of the texture level going up (and those before it), or null. */
  readonly uploading: Promise<void> | null;
  readonly stats: MeshmuxStats;
  /** Fetches the table and the base; resolves to `object`, which then shows the model. */
  open(): Promise<Group>;
  /** Applies the remaining chunks in order, one per animation frame, up to the budget. */
  play(): Promise<MeshmuxStats>;
  /** Stops after the chunk being applied. */
  stop(): void;
  /** Releases the geometry, materials and textures; the stream cannot be used after. */
  dispose(): void;
  /** Per package mesh, the digest of the decoded state (report.json's stream_digests when complete). */
  /** Texels of the kept materials' image `image` (the base .glb's extras.meshmux_image) as shown, or of all of them; 0 for one no material shows. */
  keptTexels(image?: number): number;
  /** GPU bytes of every texture shown. */
  gpuBytes(): number;
  /** GPU bytes texture chunk `index` shows once applied (0 for other chunks). */
  chunkGpuBytes(index: number): number;
  /** three's KTX2Loader this stream transcodes KTX2 maps with (the page's one, or options.ktx2Loader's). */
  ktx2Loader(): Promise<unknown>;
  stateDigests(): Promise<number[]>;
  /** The world-space bounds of what is shown. */
  worldBounds(target?: Box3): Box3;
  /**
   * The chunks play() would fetch next (re-planned for the camera), at most `max` (default 1),
   * each with the chunks applied before it and the order's distortion before and after it.
   */
  nextChunks(max?: number): MeshmuxNextChunk[];
  /** nextChunks(1)'s entry, or null when every chunk is applied. */
  nextChunk(): MeshmuxNextChunk | null;
  addEventListener<K extends keyof MeshmuxEventMap>(
    type: K, listener: (event: MeshmuxEventMap[K]) => void, options?: boolean | AddEventListenerOptions): void;
  addEventListener(type: string, listener: EventListenerOrEventListenerObject | null,
    options?: boolean | AddEventListenerOptions): void;
}

/**
 * Lights `scene` as the package's order was measured (physically based packages: a uniform
 * environment and a directional light, following `camera` when the view says so). Returns a
 * function that removes the rig.
 */
export function addStreamLighting(view: MeshmuxView, scene: Scene, camera: Camera | PerspectiveCamera,
  renderer: WebGLRenderer): () => void;

export interface MeshmuxNextChunk {
  index: number;
  chunk: { kind: 'mesh' | 'texture'; offset: number; size: number } & Record<string, unknown>;
  applied: Set<number>;
  before: number;
  after: number;
}

/** Web Workers shared by many streams' decoding (default size: the cores but one, 1 to 4). */
export class WorkerPool {
  constructor(size?: number, url?: URL | string);
  readonly size: number;
  /** Stops every worker. */
  terminate(): void;
}

/** At most `max` range requests in flight over the streams that share it. */
export class RequestLimiter {
  constructor(max?: number);
  readonly max: number;
  /** The most requests that were in flight at once. */
  readonly peak: number;
  run<T>(fn: () => Promise<T>): Promise<T>;
}
