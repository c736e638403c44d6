// Types of world.js (MeshmuxWorld) and world_plan.js.
import type { Camera, Group, WebGLRenderer } from 'three';
import type { RequestLimiter, WorkerPool } from './meshmux.js';

export interface WorldPackage {
  name: string; url: string; bounds: number[]; bytes: number;
  /** Where the package's base ends (its first request); 0: unknown. */
  headBytes: number;
}
export interface WorldPlacement { package: number; matrix: number[]; }
export interface WorldBudget {
  triangles: number;
  texels: number;
  /** GPU bytes of the textures shown (RGBA8 with mipmaps for JPEG/PNG, the block format for KTX2); unchecked when absent. */
  gpuBytes?: number;
}

export interface MeshmuxWorldOptions {
  renderer?: WebGLRenderer | null;
  /** The camera the world is seen through (needed to play). */
  camera?: Camera | null;
  /** Range requests in flight over all packages (default 6). */
  maxRequests?: number;
  /** Packages with a grant (one range request of their next chunks) at once (default 6). */
  concurrent?: number;
  /** Stop refining where the next chunk would pass it (default: defaultBudget()). */
  budget?: WorldBudget;
  /** Package URLs outside the world's folder: trusted worlds only (default false). */
  allowExternalUrls?: boolean;
  /** Decode in Web Workers (default true), shared by the packages. */
  worker?: boolean;
  /** Workers in the world's pool (default: the cores but one, 1 to 4). */
  workers?: number;
  /** three's draco/gltf/ decoder files (default: beside world.js, as batch lays them out). */
  dracoDecoderPath?: string;
  /**
   * Workers of three's MeshoptDecoder that decode the bases' meshopt-coded buffers off the page
   * (default 1; 0 leaves the decoder as the page set it: it is one module shared with the page).
   */
  meshoptWorkers?: number;
  /** How often play() looks at the camera while only off-screen work is left (ms, default 200). */
  pollMs?: number;
}

export interface MeshmuxWorldStats {
  packages: number;
  failed: { name: string; error: string }[];
  bytesReceived: number;
  bytesTotal: number;
  chunksApplied: number;
  chunkCount: number;
  triangles: number;
  vertices: number;
  /** Texels shown over the packages: texture levels and kept materials' images. */
  texels: number;
  /** GPU bytes of the textures shown over the packages (MeshmuxStream stats.gpuBytes). */
  gpuBytes: number;
  trianglesApplied: number;
  /** Seconds spent decoding and applying mesh refinements, over the packages. */
  applySeconds: number;
  /** Where mesh refinements are decoded ('page' if any package decodes there). */
  decoder: 'worker' | 'page';
  budget: WorldBudget;
  requestsPeak: number;
  state: string;
}

export class MeshmuxWorld extends EventTarget {
  constructor(world: string | URL | object, options?: MeshmuxWorldOptions);
  readonly object: Group;
  readonly limiter: RequestLimiter;
  /** The decoding workers the packages share (null with worker: false). */
  readonly workers: WorkerPool | null;
  readonly state: string;
  readonly stats: MeshmuxWorldStats;
  open(): Promise<Group>;
  play(): Promise<MeshmuxWorldStats>;
  stop(): void;
  dispose(): void;
}

export function defaultBudget(): WorldBudget;
export function validateWorld(json: unknown, file?: string, options?: { allowExternalUrls?: boolean }):
  { packages: WorldPackage[]; placements: WorldPlacement[] };
export function screenShare(bounds: number[], matrix: number[], viewProjection: number[]): number;
