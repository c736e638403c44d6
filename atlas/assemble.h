// The atlas stage's output scene (Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised
// conversion of 3D models for interactive metaverses" §4.2–4.4, steps 5a–5b of atlas.cpp): the
// source materials grouped by how surfaces show beyond their texels (alpha, sides, unlit, glass,
// reflection layers), one output material per group and atlas page, and every mesh re-indexed into
// the atlas (one primitive per material it has faces in, corners welded). Internal to atlas/.
// Deterministic.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "atlas/atlas.h"
#include "atlas/atlas_types.h"
#include "atlas/bake.h"
#include "scene/scene.h"

namespace meshmux {

// How the atlas is sampled: charts are clamped (each chart's gutter holds its edge); the
// source's image kept as the atlas (atlas/source_atlas.h) wraps as its sampler does.
struct AtlasSampling {
  bool source_texels = false;  // the atlas is the source's image, not resampled
  Wrap wrap_s = Wrap::kClampToEdge, wrap_t = Wrap::kClampToEdge;
};

// The atlas uv of a chart corner (corner k of mesh m's face f): the chart's parameterization
// placed by its page's layout (flat charts: the centre of their block). `face_slot[m][f]`: face
// f's index in its chart's list; `local[ci]`: chart ci's index in its page's layout. O(1).
Vec2 chart_corner_uv(const FlatCharts& fc, const AtlasLayout& layout,
                     const std::vector<uint32_t>& local,
                     const std::vector<std::vector<uint32_t>>& face_slot, uint32_t m, uint32_t f,
                     int k);

// Step 5, the output scene: one primitive per mesh and material into the atlas, one material per
// group and page (docs/ARCHITECTURE.md "Atlas pages"), each page's images (decoded pixels only:
// the texture levels encode them once, JPEG when opaque, PNG with alpha, and model.glb embeds
// their top level), page by page, base colour then the baked channels. `corner_uv[m]` gives mesh
// m's atlas uvs (on its face's page); `face_page[m][f]` the page of mesh m's face f (empty: every
// face on page 0); `sampling`: how the materials sample the atlas. `*page_material[p]`: page p's
// first material. Takes the pages' images; `views` and `scene` are read only. Instances are
// copied onto each mesh's parts; lines pass. O(faces × output materials).
Scene assemble(const Scene& scene, const std::vector<MeshView>& views,
               const std::vector<std::function<Vec2(uint32_t, int)>>& corner_uv,
               std::vector<PageImages> pages, const std::vector<std::vector<int32_t>>& face_page,
               const ChannelNeeds& need, const AtlasSampling& sampling,
               std::vector<int32_t>* page_material);

}  // namespace meshmux
