// Types the atlas stage's steps share (atlas.cpp orchestrates, layout.h sizes and packs, assemble.h
// builds the output scene; Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion
// of 3D models for interactive metaverses" §4.2–4.4). Internal to atlas/: other stages include
// atlas/atlas.h only.
#pragma once

#include <cstdint>
#include <vector>

#include "atlas/bake.h"
#include "atlas/charts.h"
#include "scene/scene.h"

namespace meshmux {

// The output's further channels: which are baked, and the factors shared when not.
struct ChannelNeeds {
  BakeChannels bake;          // baked channels (emissive_scale: the largest emissive component)
  Vec3 orm{1, 1, 1};          // shared occlusion-roughness-metallic factors (when not baked)
  Vec3 emissive{0, 0, 0};     // shared emissive factor (when not baked)
  Vec3 sheen{0, 0, 0};        // shared sheen colour factor (when not baked)
  float sheen_roughness = 0;  // sheen roughness: area-weighted over the sheen materials
};

// The images a bake produced, in Scene::images order after the base colour (index 0).
struct ChannelImages {
  Image normal, orm, emissive, sheen;  // empty when not baked
};

// One atlas page's images: the base colour and the baked channels (every page the same ones).
struct PageImages {
  Image atlas;
  ChannelImages channels;
};

// A mesh with its faces numbered (atlas/charts.h mesh_faces): corners and positions of face f.
// Borrows the mesh (it must outlive the view); O(1) per lookup.
struct MeshView {
  const Mesh& mesh;
  std::vector<FaceRef> faces;
  explicit MeshView(const Mesh& m) : mesh(m), faces(mesh_faces(m)) {}
  uint32_t corner(uint32_t f, int k) const {
    const FaceRef& r = faces[f];
    return mesh.primitives[r.primitive].indices[3 * r.triangle + uint32_t(k)];
  }
  Vec3 position(uint32_t f, int k) const {
    return mesh.primitives[faces[f].primitive].positions[corner(f, k)];
  }
};

}  // namespace meshmux
