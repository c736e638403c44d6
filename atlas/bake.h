// Atlas baking (Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D
// models for interactive metaverses" §4.4): each chart's faces are rasterized at their place in the
// atlas and every covered texel takes the base colour the original material shows at the
// corresponding surface point (atlas/material_sample.h: factor × vertex colour × texture, bilinear,
// wrap and KHR_texture_transform honoured). Flat-colour charts fill their block with their colour.
// Gutters are then filled by dilation (each empty texel next to filled ones takes their average,
// ring by ring, `gutter` rings), so bilinear filtering and every mip level stay clean at chart
// borders. Texels no chart reaches take the colour and alpha of the nearest charts by dilation to
// convergence (opaque when no source uses alpha). The further channels (BakeChannels) are sampled
// at the same surface points from the same source material (atlas/material_sample.h) and dilated
// alike (data channels averaged as stored).
#pragma once

#include <cstdint>
#include <vector>

#include "atlas/charts.h"
#include "atlas/parameterize.h"
#include "scene/scene.h"

namespace meshmux {

// Where each chart goes: atlas texel = offset + scale * chart_uv (chart_uv from ChartUv).
struct AtlasLayout {
  int size = 0;    // atlas width, texels (power of two)
  int height = 0;  // atlas height, texels (power of two; 0: size)
  int rows() const { return height > 0 ? height : size; }
  std::vector<Vec2> offset;   // per chart: texel coordinates of chart uv (0, 0)
  std::vector<double> scale;  // per chart: texels per chart-uv unit (0 for flat charts)
  std::vector<int> block;     // per chart: side of its placed rectangle, texels (gutters
                              // included); flat charts fill [offset, offset + block)
};

struct BakeOptions {
  int gutter = 2;       // dilation rings around every chart, texels
  int supersample = 1;  // samples per texel side (1 = texel centre only)
};

// The material channels a bake fills besides base colour (build_atlas decides which), each in
// an image of the atlas's size with the same charts, gutters and fill.
struct BakeChannels {
  bool normal = false;    // tangent-space normal map (linear), in the frame glTF viewers derive
                          // from the atlas uvs (atlas/tangent_frame.h); 1 sample per texel
  bool orm = false;       // occlusion (R), roughness (G), metallic (B), linear, factors folded in
  bool emissive = false;  // emissive radiance / emissive_scale, sRGB
  bool sheen = false;     // sheen colour (KHR_materials_sheen), sRGB
  float emissive_scale = 1;  // the divisor (> 0): the largest emissive component
};

struct BakeResult {
  Image atlas;                         // size × rows() RGBA8, sRGB, row 0 at the top
  Image normal, orm, emissive, sheen;  // the same size, RGBA8 (alpha 255) when baked, else
                                       // empty
  std::vector<int32_t>
      texel_chart;         // per texel: the chart it belongs to (incl. its gutter), -1 none
  bool has_alpha = false;  // some baked texel has alpha < 255
};

BakeResult bake_atlas(const Scene& scene, const ChartSet& charts, const std::vector<ChartUv>& uvs,
                      const AtlasLayout& layout, const BakeOptions& options = {},
                      const BakeChannels& channels = {});

}  // namespace meshmux
