// materials.js — how a meshmux stream's meshes are shaded (meshmux.js): the texture settings of
// a streamed map (texels as stored bytes), the shared Lambert ShaderMaterial of the package's
// view.shading "lambert" (base colour × texture × two-sided Lambert, light following the
// camera, as meshmux's offscreen renderer draws it) and, for "physical", the
// MeshStandardMaterial made from a base material with the slots each streamed channel fills.

import * as THREE from 'three';

// ---- Textures and material -------------------------------------------------------------------

// Texels used as stored bytes (no colour management), glTF's uv convention (no flip),
// trilinear + anisotropic filtering, wrapped as `wrap` says ([wrapS, wrapT], three.js
// constants): the base .glb's atlas sampler, which GLTFLoader gives its map (meshmux keeps a
// source image's REPEAT there, and the image's edges then continue across), clamped by default.
export function configureTexture(texture, anisotropy, wrap = [THREE.ClampToEdgeWrapping, THREE.ClampToEdgeWrapping]) {
  texture.colorSpace = THREE.NoColorSpace;
  texture.flipY = false;
  texture.magFilter = THREE.LinearFilter;
  if (texture.isCompressedTexture) {  // KTX2: its mipmaps come inside the file (three cannot make them)
    texture.generateMipmaps = false;
    texture.minFilter = texture.mipmaps.length > 1 ? THREE.LinearMipmapLinearFilter : THREE.LinearFilter;
  } else {
    texture.minFilter = THREE.LinearMipmapLinearFilter;
    texture.generateMipmaps = true;
  }
  [texture.wrapS, texture.wrapT] = wrap;
  texture.anisotropy = anisotropy;
  texture.needsUpdate = true;
  return texture;
}

const VERTEX_SHADER = /* glsl */ `
out vec3 vNormal;
out vec2 vUv;
flat out float vMirror;  // -1 where the instance matrix mirrors (the winding flips on screen)
void main() {
  vec4 p = vec4(position, 1.0);
  vec3 n = normal;
  float mirror = 1.0;
#ifdef USE_INSTANCING
  p = instanceMatrix * p;
  mat3 im = mat3(instanceMatrix);
  n = im * n;
  if (determinant(im) < 0.0) mirror = -1.0;
#endif
  gl_Position = projectionMatrix * viewMatrix * modelMatrix * p;
  vNormal = normalMatrix * n;  // view space
  vUv = uv;
  vMirror = mirror;
}`;

const FRAGMENT_SHADER = /* glsl */ `
uniform vec4 baseColorFactor;
uniform sampler2D map;
uniform bool textured;
uniform vec3 lightDirection;  // view space, unit, towards the light
uniform float ambient, diffuse;  // the package's "view": what the distortion was measured with
in vec3 vNormal;
in vec2 vUv;
flat in float vMirror;
out vec4 fragColor;
void main() {
  vec4 base = baseColorFactor;
  if (textured) {
    // Trilinear + anisotropic where a pixel spans more than one texel; level 0 bilinear where
    // the texture is magnified (as meshmux's offscreen renderer: some software rasterizers
    // blur magnified texels under anisotropic filtering; GPUs filter them bilinearly anyway).
    vec2 t = vUv * vec2(textureSize(map, 0));
    vec2 dx = dFdx(t), dy = dFdy(t);
    bool minified = max(dot(dx, dx), dot(dy, dy)) > 1.0;
    vec4 filtered = texture(map, vUv);
    vec4 plain = textureLod(map, vUv, 0.0);
    base *= minified ? filtered : plain;
  }
  float len = length(vNormal);
  vec3 n = len > 1e-20 ? vNormal / len : vec3(0.0, 0.0, 1.0);
  bool front = vMirror < 0.0 ? !gl_FrontFacing : gl_FrontFacing;
  if (!front) n = -n;  // two-sided lighting
  fragColor = vec4(base.rgb * (ambient + diffuse * max(dot(n, lightDirection), 0.0)), 1.0);
}`;

// One ShaderMaterial per distinct glTF material (normally one: the atlas); all share the
// texture uniform, so a streamed level reaches every material at once. Shading comes from the
// package table's "view" (light in view space: it follows the camera).
export function makeMaterial(source, mapUniform, view) {
  const color = source.color || new THREE.Color(1, 1, 1);
  return new THREE.ShaderMaterial({
    name: `meshmux(${source.name || 'material'})`,
    glslVersion: THREE.GLSL3,
    side: THREE.DoubleSide,
    uniforms: {
      baseColorFactor: { value: new THREE.Vector4(color.r, color.g, color.b, source.opacity ?? 1) },
      map: mapUniform,
      textured: { value: !!source.map },
      lightDirection: { value: new THREE.Vector3(...view.lightDirection).normalize() },
      ambient: { value: view.ambient },
      diffuse: { value: view.diffuse },
    },
    vertexShader: VERTEX_SHADER,
    fragmentShader: FRAGMENT_SHADER,
  });
}

// ---- Physically based shading (the package's view.shading "physical") ---------------------

// The material channels a texture step carries, and the MeshStandardMaterial slots each fills.
export const CHANNEL_SLOTS = {
  base_color: ['map'],
  normal: ['normalMap'],
  occlusion_roughness_metallic: ['aoMap', 'roughnessMap', 'metalnessMap'],
  emissive: ['emissiveMap'],
  sheen_color: ['sheenColorMap'],
};
const COLOR_CHANNELS = new Set(['base_color', 'emissive', 'sheen_color']);

export function configureMap(texture, channel, anisotropy, wrap) {
  configureTexture(texture, anisotropy, wrap);
  texture.colorSpace = COLOR_CHANNELS.has(channel) ? THREE.SRGBColorSpace : THREE.NoColorSpace;
  return texture;
}

// A MeshStandardMaterial like the base .glb's (glTF metal-roughness, which GLTFLoader gives),
// two-sided as meshmux's renderer draws, its maps the stream's shared textures. glTF normal maps
// without tangents: the map's y is negated (three.js's derivative frame runs against glTF's +y).
export function makeStandardMaterial(source, maps) {
  // A sheen layer (KHR_materials_sheen, which GLTFLoader gives as MeshPhysicalMaterial.sheen).
  const sheen = source.isMeshPhysicalMaterial && source.sheen > 0;
  // Glass (KHR_materials_transmission, _ior, _volume: MeshPhysicalMaterial.transmission, ior,
  // thickness, attenuation), kept as glass: never faded out through opacity.
  const glass = source.isMeshPhysicalMaterial && source.transmission > 0;
  // The reflection's layers: clearcoat, specular (KHR_materials_specular), iridescence.
  const layers = source.isMeshPhysicalMaterial;
  const m = new (sheen || glass || layers ? THREE.MeshPhysicalMaterial : THREE.MeshStandardMaterial)({
    name: `meshmux(${source.name || 'material'})`,
    side: THREE.DoubleSide,
    color: source.color ? source.color.clone() : new THREE.Color(1, 1, 1),
    metalness: source.metalness ?? 1,
    roughness: source.roughness ?? 1,
    emissive: source.emissive ? source.emissive.clone() : new THREE.Color(0, 0, 0),
    emissiveIntensity: source.emissiveIntensity ?? 1,
    aoMapIntensity: source.aoMapIntensity ?? 1,
    // A base without normals (a flat-shaded source: the stream carries none either) is shaded
    // with face normals, as GLTFLoader shades model.glb.
    flatShading: !!source.flatShading,
  });
  if (sheen) {
    m.sheen = source.sheen;
    m.sheenColor = source.sheenColor.clone();
    m.sheenRoughness = source.sheenRoughness;
  }
  if (layers) {
    m.clearcoat = source.clearcoat;
    m.clearcoatRoughness = source.clearcoatRoughness;
    m.specularIntensity = source.specularIntensity;
    m.specularColor = source.specularColor.clone();
    m.iridescence = source.iridescence;
    m.iridescenceIOR = source.iridescenceIOR;
    m.iridescenceThicknessMinimum = source.iridescenceThicknessMinimum;
    m.iridescenceThicknessMaximum = source.iridescenceThicknessMaximum;
  }
  if (glass) {
    m.transmission = source.transmission;
    m.transmissionMap = source.transmissionMap;
    m.ior = source.ior;
    m.thickness = source.thickness;
    m.thicknessMap = source.thicknessMap;
    m.attenuationDistance = source.attenuationDistance;
    m.attenuationColor = source.attenuationColor.clone();
  }
  const scale = source.normalScale ? Math.abs(source.normalScale.x) : 1;
  m.normalScale = new THREE.Vector2(scale, -scale);
  for (const [channel, slots] of Object.entries(CHANNEL_SLOTS))
    for (const slot of slots) m[slot] = maps[channel] || null;
  return m;
}
