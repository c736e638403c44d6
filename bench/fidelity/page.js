// The fidelity harness's page (bench/fidelity.mjs drives it in headless chromium): loads a
// model with three.js's own loaders (GLTFLoader with DRACOLoader, KTX2Loader and the meshopt
// decoder, or ColladaLoader), renders it with its materials under RoomEnvironment (lit) or with
// base colour × alpha only (unlit) or as its shading normals with normal maps applied (for the
// normal-map angular error), from cameras the driver gives, and measures how much of the surface
// is shaded against its winding. meshmux's own renderer is not involved: this is the judge.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { KTX2Loader } from 'three/addons/loaders/KTX2Loader.js';
import { ColladaLoader } from 'three/addons/loaders/ColladaLoader.js';
import { MeshoptDecoder } from 'three/addons/libs/meshopt_decoder.module.js';
import { RoomEnvironment } from 'three/addons/environments/RoomEnvironment.js';

const size = Number(new URLSearchParams(location.search).get('size') || 256);
const canvas = document.createElement('canvas');
canvas.width = canvas.height = size;
document.body.appendChild(canvas);
// Multisampled, as three.js applications render by default in practice: without it, PSNR at
// every silhouette and texture edge measures aliasing (a subpixel shift flips whole pixels),
// not appearance (DamagedHelmet through the same output: 24.7 dB aliased, 27.8 dB multisampled).
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, alpha: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setSize(size, size, false);
renderer.setClearColor(0x000000, 0);
renderer.outputColorSpace = THREE.SRGBColorSpace;
renderer.toneMapping = THREE.NoToneMapping;
const pmrem = new THREE.PMREMGenerator(renderer);
const environment = pmrem.fromScene(new RoomEnvironment(), 0.04).texture;

const draco = new DRACOLoader().setDecoderPath('/three/examples/jsm/libs/draco/');
// KTX2/BasisU textures (KHR_texture_basisu), which corpus originals use: without it the loader
// fails on them and the original cannot be judged.
const ktx2 = new KTX2Loader().setTranscoderPath('/three/examples/jsm/libs/basis/').detectSupport(renderer);
// KTX2 images referenced through a texture's core `source` rather than KHR_texture_basisu (the
// corpus's AnisotropyBarnLamp-ktx2: the validator warns) are read as KTX2 too: GLTFLoader would
// hand them to the browser's image decoder, which fails, and the original could not be judged.
class KTX2Source {
  constructor(parser) { this.parser = parser; this.name = 'fidelity_ktx2_source'; }
  loadTexture(index) {
    const json = this.parser.json, texture = json.textures[index];
    const image = json.images[texture.source];
    if (texture.extensions?.KHR_texture_basisu || !image) return null;
    if (!(image.mimeType === 'image/ktx2' || /\.ktx2$/i.test(image.uri || ''))) return null;
    return this.parser.loadTextureImage(index, texture.source, ktx2);
  }
}
const models = [];

// COLLADA semantics, made explicit for three's ColladaLoader: every <instance_node url="#N">
// becomes a copy of node N (ids and sids suffixed). The loader builds each node once and adds
// that one Object3D wherever it is instanced; an Object3D has one parent, so a node both in the
// scene and instanced (TeapotInstanceNodes-dae: the teapot drawn twice) showed once. Nested
// instances are expanded level by level (at most 16 levels; cycles are refused by meshmux).
function inlineInstanceNodes(doc) {
  const byId = new Map();
  for (const n of doc.getElementsByTagName('node')) if (n.getAttribute('id')) byId.set(n.getAttribute('id'), n);
  let copies = 0;
  for (let level = 0; level < 16; ++level) {
    const refs = [...doc.getElementsByTagName('instance_node')];
    if (!refs.length) break;
    for (const ref of refs) {
      const target = byId.get((ref.getAttribute('url') || '').replace(/^#/, ''));
      if (!target) { ref.remove(); continue; }
      const copy = target.cloneNode(true);
      const suffix = `-instance-${++copies}`;
      for (const e of [copy, ...copy.getElementsByTagName('*')]) {
        if (e.getAttribute('id')) e.setAttribute('id', e.getAttribute('id') + suffix);
      }
      ref.replaceWith(copy);
    }
  }
}
// An <image> without <init_from> (gazebo's gear and u_joint parts: the exporter's line is
// commented out) names no file; ColladaLoader throws on it and the original could not be
// judged. Removed, the loader warns that the image is missing and draws without the texture.
function dropEmptyImages(doc) {
  for (const image of [...doc.getElementsByTagName('image')])
    if (!image.getElementsByTagName('init_from').length) image.remove();
}
// The COLLADA text ColladaLoader is given: the document with the two fixes above.
function prepareCollada(text) {
  const doc = new DOMParser().parseFromString(text, 'application/xml');
  inlineInstanceNodes(doc);
  dropEmptyImages(doc);
  return new XMLSerializer().serializeToString(doc);
}

// Loads a model and everything it references: ColladaLoader resolves before its textures have
// arrived (GLTFLoader waits for them), so every load goes through its own LoadingManager and
// waits for it to go idle. Without that, renders depended on timing.
async function load(url) {
  const manager = new THREE.LoadingManager();
  const idle = new Promise((resolve, reject) => {
    manager.onLoad = resolve;
    manager.onError = (item) => reject(new Error(`cannot load ${item}`));
  });
  let root;
  if (/\.dae$/i.test(url)) {
    manager.itemStart(url);  // the document itself, so the manager goes idle once, after it
    const text = prepareCollada(await (await fetch(url)).text());
    root = new ColladaLoader(manager).parse(text, url.slice(0, url.lastIndexOf('/') + 1)).scene;
    manager.itemEnd(url);
  } else {
    const loader = new GLTFLoader(manager).setDRACOLoader(draco).setKTX2Loader(ktx2).setMeshoptDecoder(MeshoptDecoder)
      .register((parser) => new KTX2Source(parser));
    const gltf = await loader.loadAsync(url);
    root = gltf.scene || gltf.scenes[0];
  }
  await idle;
  // Lights a file brings (COLLADA <instance_light>, KHR_lights_punctual) are removed: every model
  // is judged under the same fixed neutral environment, and with the file's own sun and ambient
  // on top, the original of 2CylinderEngine-dae rendered 1.4× brighter than the same material
  // and normals without them (lit 19.5 dB against identical normals and unlit colours).
  const lights = [];
  root.traverse((o) => { if (o.isLight) lights.push(o); });
  for (const l of lights) l.removeFromParent();
  root.userData.lightsRemoved = lights.length;
  return root;
}

// The unlit twin of a material: base colour (factor × map × vertex colour) and alpha only.
function unlit(m) {
  const u = new THREE.MeshBasicMaterial({
    color: m.color ? m.color.clone() : new THREE.Color(1, 1, 1),
    map: m.map || null,
    vertexColors: !!m.vertexColors,
    transparent: !!m.transparent,
    opacity: m.opacity ?? 1,
    alphaTest: m.alphaTest || 0,
    side: m.side,
  });
  return u;
}

function meshes(root) {
  const out = [];
  root.updateMatrixWorld(true);
  root.traverse((o) => { if (o.isMesh) out.push(o); });
  return out;
}

// Share of the surface area (world space) whose interpolated shading normal, at the triangle's
// centre, points against the triangle's winding normal (mirroring transforms accounted for).
function normalsAgainstWinding(root) {
  let against = 0, total = 0;
  const a = new THREE.Vector3(), b = new THREE.Vector3(), c = new THREE.Vector3();
  const na = new THREE.Vector3(), nb = new THREE.Vector3(), nc = new THREE.Vector3();
  const e1 = new THREE.Vector3(), e2 = new THREE.Vector3(), g = new THREE.Vector3(), n = new THREE.Vector3();
  for (const mesh of meshes(root)) {
    const geo = mesh.geometry, pos = geo.getAttribute('position'), nrm = geo.getAttribute('normal');
    if (!pos || !nrm) continue;
    const instances = mesh.isInstancedMesh ? mesh.count : 1;
    const im = new THREE.Matrix4(), world = new THREE.Matrix4(), nmat = new THREE.Matrix3();
    const index = geo.index, count = index ? index.count : pos.count;
    for (let k = 0; k < instances; ++k) {
      world.copy(mesh.matrixWorld);
      if (mesh.isInstancedMesh) { mesh.getMatrixAt(k, im); world.multiply(im); }
      nmat.getNormalMatrix(world);
      for (let t = 0; t + 2 < count; t += 3) {
        const i0 = index ? index.getX(t) : t, i1 = index ? index.getX(t + 1) : t + 1, i2 = index ? index.getX(t + 2) : t + 2;
        a.fromBufferAttribute(pos, i0).applyMatrix4(world);
        b.fromBufferAttribute(pos, i1).applyMatrix4(world);
        c.fromBufferAttribute(pos, i2).applyMatrix4(world);
        g.crossVectors(e1.subVectors(b, a), e2.subVectors(c, a));
        const area = 0.5 * g.length();
        if (!(area > 0)) continue;
        na.fromBufferAttribute(nrm, i0); nb.fromBufferAttribute(nrm, i1); nc.fromBufferAttribute(nrm, i2);
        n.copy(na).add(nb).add(nc).applyMatrix3(nmat);
        // A mirroring world transform flips the winding that three.js draws as front.
        const mirrored = world.determinant() < 0;
        const d = n.dot(g) * (mirrored ? -1 : 1);
        total += area;
        if (d < 0) against += area;
      }
    }
  }
  return { against, total, share: total > 0 ? against / total : 0 };
}

// Draw calls three.js issues for the model as loaded: one per mesh, line or point object (an
// InstancedMesh draws all its instances at once), or one per geometry group when it has an
// array of materials, as WebGLRenderer.projectObject does.
function drawCalls(root) {
  let n = 0;
  root.traverse((o) => {
    if (!(o.isMesh || o.isLine || o.isPoints)) return;
    if (Array.isArray(o.material)) n += o.geometry.groups.filter((g) => o.material[g.materialIndex]).length;
    else n += 1;
  });
  return n;
}

// The harness renders every model with MeshStandardMaterial: a loader's Phong or Lambert material
// (COLLADA's common profile) becomes the dielectric a PBR viewer shows for it: metalness 0,
// roughness from the Blinn-Phong exponent n through the Beckmann match α = sqrt(2 / (n + 2)), α =
// roughness² (Lambert: 1). Unlit materials stay unlit.
function standard(m) {
  if (!m || m.isMeshStandardMaterial || m.isMeshBasicMaterial) return m;
  const s = new THREE.MeshStandardMaterial({
    color: m.color ? m.color.clone() : new THREE.Color(1, 1, 1), map: m.map || null,
    emissive: m.emissive ? m.emissive.clone() : new THREE.Color(0, 0, 0), emissiveMap: m.emissiveMap || null,
    normalMap: m.normalMap || null, vertexColors: !!m.vertexColors, transparent: !!m.transparent,
    opacity: m.opacity ?? 1, alphaTest: m.alphaTest || 0, side: m.side, metalness: 0,
    roughness: m.isMeshPhongMaterial ? Math.pow(2 / (Math.max(0, m.shininess ?? 30) + 2), 0.25) : 1,
  });
  s.name = m.name;
  return s;
}

// The shading-normal twin of a material, for the normal-map angular error: the same material
// (a clone, so its normal map, normalScale, normalMapType, vertex tangents or derivative tangent
// frame, flat shading, side and alpha test all act exactly as when lit) whose fragment shader
// ends by writing three.js's final perturbed view-space `normal` instead of the lit colour, as
// raw floats (rgb) with alpha 1. Written unpacked, into a float target, so multisampling
// averages it (a silhouette pixel's alpha is its coverage) and the driver renormalises it.
// Blending is off (a transparent surface's normal is not mixed with what lies behind it);
// transmission is off (its extra pass would sample the scene). Materials without a shading
// normal (MeshBasicMaterial: KHR_materials_unlit) get MeshNormalMaterial's geometric normal.
function normalTwin(m) {
  if (!m || !(m.isMeshStandardMaterial || m.isMeshPhongMaterial || m.isMeshLambertMaterial)) {
    const n = new THREE.MeshNormalMaterial({ side: m ? m.side : THREE.FrontSide });
    n.onBeforeCompile = normalOutput;
    return n;
  }
  const c = m.clone();
  c.transparent = false;
  c.blending = THREE.NoBlending;
  c.depthWrite = true;
  c.opacity = 1;
  if (c.isMeshPhysicalMaterial) c.transmission = 0;
  c.onBeforeCompile = normalOutput;
  return c;
}
function normalOutput(shader) {
  // Appended at the very end of main(), after everything that writes gl_FragColor; `normal`
  // is final once normal_fragment_maps has run (the shader is seen before includes resolve).
  if (!shader.fragmentShader.includes('#include <normal_fragment_maps>') || !/}\s*$/.test(shader.fragmentShader))
    throw new Error('normal twin: fragment shader computes no shading normal');
  shader.fragmentShader = shader.fragmentShader.replace(/}\s*$/, '\tgl_FragColor = vec4( normalize( normal ), 1.0 );\n}\n');
}
// Float colour target for the normal renders (32-bit if the GPU renders to it, else 16-bit
// half floats: ≤ 0.06° rounding either way), multisampled like the canvas.
let normalTarget = null;
function floatTarget() {
  if (normalTarget) return normalTarget;
  const type = renderer.extensions.has('EXT_color_buffer_float') ? THREE.FloatType : THREE.HalfFloatType;
  normalTarget = new THREE.WebGLRenderTarget(size, size, { type, format: THREE.RGBAFormat, samples: 4,
    colorSpace: THREE.NoColorSpace, depthBuffer: true });
  return normalTarget;
}

window.fidelity = {
  // Loads a model; returns its handle, world bounds and normal statistics.
  async load(url) {
    const root = await load(url);
    root.traverse((o) => {
      if (o.isMesh) o.material = Array.isArray(o.material) ? o.material.map(standard) : standard(o.material);
    });
    const box = new THREE.Box3().setFromObject(root, true);
    const lit = root, flat = root.clone(true);
    flat.traverse((o) => {
      if (!o.isMesh) return;
      o.material = Array.isArray(o.material) ? o.material.map(unlit) : unlit(o.material);
    });
    const normals = root.clone(true);
    normals.traverse((o) => {
      if (o.isMesh) o.material = new THREE.MeshNormalMaterial({ side: [o.material].flat()[0].side });
    });
    const perturbed = root.clone(true);
    perturbed.traverse((o) => {
      if (o.isMesh) o.material = Array.isArray(o.material) ? o.material.map(normalTwin) : normalTwin(o.material);
    });
    models.push({ lit, flat, normals, perturbed });
    // What each material became (for the JSON report: a lit difference starts here).
    const materials = new Map();
    root.traverse((o) => {
      if (!o.isMesh) return;
      for (const m of [o.material].flat()) {
        if (materials.has(m.uuid)) continue;
        materials.set(m.uuid, { type: m.type, name: m.name, color: m.color?.getHexString(), roughness: m.roughness,
          metalness: m.metalness, emissive: m.emissive?.getHexString(), transparent: m.transparent,
          opacity: m.opacity, side: m.side, map: !!m.map, vertexColors: m.vertexColors });
      }
    });
    const c = box.getCenter(new THREE.Vector3()), r = 0.5 * box.getSize(new THREE.Vector3()).length();
    return { handle: models.length - 1, center: c.toArray(), radius: r, min: box.min.toArray(), max: box.max.toArray(),
      normals: normalsAgainstWinding(root), materials: [...materials.values()], lightsRemoved: root.userData.lightsRemoved,
      drawCalls: drawCalls(root) };
  },
  // Frees model `handle`'s GPU and CPU memory (its geometries, materials and textures, shared by
  // its four twins): a sweep loads hundreds of models into one page.
  release(handle) {
    const m = models[handle];
    if (!m) return;
    models[handle] = null;
    const textures = new Set();
    for (const root of [m.lit, m.flat, m.normals, m.perturbed])
      root.traverse((o) => {
        if (o.geometry) o.geometry.dispose();
        for (const mat of [o.material].flat().filter(Boolean)) {
          for (const v of Object.values(mat)) if (v && v.isTexture) textures.add(v);
          mat.dispose();
        }
        if (o.isInstancedMesh) o.dispose();
      });
    for (const t of textures) t.dispose();
  },
  // Renders model `handle` lit (its materials, RoomEnvironment), unlit, its view-space
  // geometric shading normals ('normals', MeshNormalMaterial, 8-bit), or its view-space shading
  // normals with normal maps applied ('perturbed': float RGBA, rgb = the normal, un-normalised
  // where multisampling averaged it, a = coverage) from a camera {eye, target, up, fov, near,
  // far}; returns base64 of the pixels (RGBA bytes, or little-endian float32 ×4 for
  // 'perturbed'), rows top first, alpha 0 = background.
  render(handle, camera, mode) {
    const m = models[handle];
    const scene = new THREE.Scene();
    scene.environment = mode === 'lit' ? environment : null;
    const shown = mode === 'lit' ? m.lit : mode === 'normals' ? m.normals : mode === 'perturbed' ? m.perturbed : m.flat;
    scene.add(shown);
    const cam = new THREE.PerspectiveCamera(camera.fov, 1, camera.near, camera.far);
    cam.position.fromArray(camera.eye);
    cam.up.fromArray(camera.up);
    cam.lookAt(new THREE.Vector3().fromArray(camera.target));
    cam.updateProjectionMatrix();
    let px;
    if (mode === 'perturbed') {
      const target = floatTarget();
      renderer.setRenderTarget(target);
      renderer.clear();
      renderer.render(scene, cam);
      renderer.setRenderTarget(null);
      px = new Float32Array(size * size * 4);
      if (target.texture.type === THREE.FloatType) renderer.readRenderTargetPixels(target, 0, 0, size, size, px);
      else {
        const half = new Uint16Array(px.length);
        renderer.readRenderTargetPixels(target, 0, 0, size, size, half);
        for (let i = 0; i < half.length; ++i) px[i] = THREE.DataUtils.fromHalfFloat(half[i]);
      }
    } else {
      renderer.render(scene, cam);
      const gl = renderer.getContext();
      px = new Uint8Array(size * size * 4);
      gl.readPixels(0, 0, size, size, gl.RGBA, gl.UNSIGNED_BYTE, px);
    }
    scene.remove(shown);
    const row = size * 4;
    const flipped = new px.constructor(px.length);
    for (let y = 0; y < size; ++y) flipped.set(px.subarray((size - 1 - y) * row, (size - y) * row), y * row);
    const bytes = new Uint8Array(flipped.buffer);
    let s = '';
    for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
    return btoa(s);
  },
  // What the normal renders are stored as ('float' or 'half-float' before readback).
  normalPrecision() { return floatTarget().texture.type === THREE.FloatType ? 'float' : 'half-float'; },
};
document.body.dataset.ready = '1';
