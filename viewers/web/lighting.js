// lighting.js — the light rig a meshmux package's order was measured under when its view is
// "physical" (addStreamLighting, re-exported by meshmux.js).

import * as THREE from 'three';

// The light rig the package's distortion was measured under when its view is "physical": a
// uniform environment of radiance view.environment (a constant map through PMREM, which keeps
// it constant at every roughness) and a white directional light of view.lightIntensity from
// view.lightDirection in camera space (it follows the camera). meshmux's offscreen renderer
// evaluates exactly this (multiplex/render_shaders.cpp). An application may light the stream's
// meshes its own way instead. Returns a function that removes and frees the rig.
export function addStreamLighting(view, scene, camera, renderer) {
  const L = view.environment;
  const data = new Float32Array(8 * 4 * 4);
  for (let i = 0; i < 32; ++i) data.set([L, L, L, 1], i * 4);
  const constant = new THREE.DataTexture(data, 8, 4, THREE.RGBAFormat, THREE.FloatType);
  constant.mapping = THREE.EquirectangularReflectionMapping;
  constant.colorSpace = THREE.LinearSRGBColorSpace;
  constant.needsUpdate = true;
  const pmrem = new THREE.PMREMGenerator(renderer);
  const environment = pmrem.fromEquirectangular(constant).texture;
  pmrem.dispose();
  constant.dispose();
  const previous = scene.environment;
  scene.environment = environment;
  const light = new THREE.DirectionalLight(0xffffff, view.lightIntensity);
  light.name = 'meshmux light';
  const target = new THREE.Object3D();
  light.target = target;
  if (view.lightFollowsCamera) {
    light.position.set(...view.lightDirection).normalize();
    camera.add(light, target);
    if (!camera.parent) scene.add(camera);
  } else {
    light.position.set(...view.lightDirection).normalize();
    scene.add(light, target);
  }
  return () => {
    light.removeFromParent();
    target.removeFromParent();
    light.dispose();
    if (scene.environment === environment) scene.environment = previous;
    environment.dispose();
  };
}
