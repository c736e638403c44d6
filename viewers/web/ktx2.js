// ktx2.js — KTX2 (Basis Universal, glTF's KHR_texture_basisu) texture levels in the client:
// what three's KTX2Loader gives back, wrapped as the stream's decoded maps are, and what each
// texture costs on the GPU. The transcoding itself is three's (KTX2Loader's worker pool runs the
// Basis transcoder: ETC1S and UASTC to BC7/BC1 on desktops, ASTC/ETC on phones, RGBA where the
// GPU reads none), so a KTX2 level reaches the GPU compressed with no RGBA copy on the page.
import * as THREE from 'three';

// A decoded KTX2 map, shaped as the stream's other decoded maps (ImageBitmap, PixelImage):
// width, height and close(); `texture` is KTX2Loader's CompressedTexture (its mipmaps inside).
export class Ktx2Image {
  constructor(texture) {
    this.isKtx2Image = true;
    this.texture = texture;
    this.width = texture.image.width;
    this.height = texture.image.height;
  }

  close() { this.texture.dispose(); }
}

// The KTX2Loader's formats for `renderer` (KTX2Loader.detectSupport); without one, for the GPU
// a WebGL2 context of a canvas of its own reports (a page that draws the stream with a renderer
// it did not pass still gets compressed textures), and where there is none (no DOM, no WebGL)
// none is assumed, so every KTX2 texture is transcoded to RGBA.
export function detectKtx2Support(loader, renderer) {
  if (renderer) return loader.detectSupport(renderer);
  const gl = typeof document !== 'undefined' ? document.createElement('canvas').getContext('webgl2') : null;
  if (!gl) {
    loader.workerConfig = { astcSupported: false, astcHDRSupported: false, etc1Supported: false, etc2Supported: false,
      dxtSupported: false, bptcSupported: false, pvrtcSupported: false };
    return loader;
  }
  const names = new Set(gl.getSupportedExtensions() || []);
  loader.detectSupport({ extensions: { has: (n) => names.has(n), get: (n) => gl.getExtension(n) } });
  const lose = gl.getExtension('WEBGL_lose_context');
  if (lose) lose.loseContext();
  return loader;
}

// One KTX2Loader per transcoder folder for the page (three warns of several active ones: each
// starts its own transcoding workers), its support detected by the first stream that asks
// (detectKtx2Support); kept for the page's lifetime. `KTX2Loader`: the class (imported lazily).
const sharedLoaders = new Map();
export function sharedKtx2Loader(KTX2Loader, transcoderPath, renderer) {
  let loader = sharedLoaders.get(transcoderPath);
  if (!loader) {
    loader = detectKtx2Support(new KTX2Loader().setTranscoderPath(transcoderPath), renderer);
    sharedLoaders.set(transcoderPath, loader);
  }
  return loader;
}

// Whether a .glb's JSON chunk names KHR_texture_basisu (its images are KTX2: GLTFLoader then
// needs a KTX2Loader). Reads the JSON chunk's text only.
export function usesBasisu(glb) {
  if (glb.length < 20) return false;
  const view = new DataView(glb.buffer, glb.byteOffset, glb.byteLength);
  const length = Math.min(view.getUint32(12, true), glb.length - 20);
  return new TextDecoder().decode(glb.subarray(20, 20 + length)).includes('"KHR_texture_basisu"');
}

// The image a glTF texture definition shows: its source, or for a KTX2 image (no core source)
// the KHR_texture_basisu extension's; undefined for none.
export function textureSource(texture) {
  return texture ? texture.source ?? texture.extensions?.KHR_texture_basisu?.source : undefined;
}

// Every texture the materials show, each once (by its source: copies sharing pixels count once).
export function shownTextures(materials, more = []) {
  const seen = new Set(), out = [];
  const add = (v) => { if (v && v.isTexture && !seen.has(v.source)) { seen.add(v.source); out.push(v); } };
  for (const m of materials) for (const v of Object.values(m)) add(v);
  for (const v of more) add(v);
  return out;
}

// GPU bytes a texture holds: a compressed texture's mip levels as stored, else 4 bytes a texel
// (RGBA8) and a third more with mipmaps. 0 for a texture with no image.
export function gpuBytesOf(texture) {
  if (!texture) return 0;
  if (texture.isCompressedTexture) return (texture.mipmaps || []).reduce((n, m) => n + (m.data ? m.data.byteLength : 0), 0);
  const image = texture.image, w = image && image.width, h = image && image.height;
  if (!(w > 0 && h > 0)) return 0;
  const mipmapped = texture.generateMipmaps && texture.minFilter !== THREE.LinearFilter && texture.minFilter !== THREE.NearestFilter;
  return Math.round(4 * w * h * (mipmapped ? 4 / 3 : 1));
}

// Bytes a texel of a map of type `mime` takes on the GPU, mipmaps included: KTX2 transcoded to
// a block format (`workerConfig`: KTX2Loader's detected support; null: not known yet, assumed
// available) is at most one byte a texel (BC7, ASTC 4×4, ETC2 RGBA; BC1/ETC1 half that), RGBA8
// four.
export function texelGpuBytes(mime, workerConfig = null) {
  const blocks = !workerConfig || workerConfig.bptcSupported || workerConfig.dxtSupported || workerConfig.astcSupported ||
    workerConfig.etc2Supported || workerConfig.etc1Supported;
  return (mime === 'image/ktx2' && blocks ? 1 : 4) * 4 / 3;
}

// A copy of texture `like` (sampler, uv set, transform, colour space: a kept material's own
// texture) showing the compressed texture `compressed`'s mip levels instead of its pixels.
export function compressedLike(compressed, like) {
  const t = new THREE.CompressedTexture(compressed.mipmaps, compressed.image.width, compressed.image.height,
    compressed.format, compressed.type);
  for (const key of ['wrapS', 'wrapT', 'magFilter', 'anisotropy', 'channel', 'rotation', 'matrixAutoUpdate', 'colorSpace'])
    t[key] = like[key];
  t.offset.copy(like.offset);
  t.repeat.copy(like.repeat);
  t.center.copy(like.center);
  t.matrix.copy(like.matrix);
  t.minFilter = compressed.mipmaps.length > 1 ? like.minFilter : THREE.LinearFilter;
  t.generateMipmaps = false;
  t.premultiplyAlpha = compressed.premultiplyAlpha;
  t.needsUpdate = true;
  return t;
}
