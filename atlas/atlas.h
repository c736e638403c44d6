// One material, one texture (Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised
// conversion of 3D models for interactive metaverses" §4.2–4.4): charts are segmented and
// parameterized, each sized to keep the density of the source texels it samples (charts without
// source texels by formula 2 within T = min(Σ source texture area the faces reference, max_size²)),
// packed into the smallest W × W or W × W/2 texels that holds them (up to max_size) so no chart
// crosses a power-of-two boundary, and baked from the source materials. Where they do not fit
// max_size² at that density, the atlas adds pages instead of shrinking them (DESIGN.md "Atlas":
// 4096 is the largest side every WebGL2 device reads): the charts, largest first, each go to the
// first max_size² page with room, each page is packed as one atlas is, and every page is an image
// set and a material of its own (AtlasReport::pages); every mesh becomes one
// primitive with one uv set into the atlas and the single material. Instancing is untouched (a
// shared mesh's charts are baked once). When every face already samples one image inside [0, 1]
// (atlas/source_atlas.h), that image is the atlas and the source uvs are kept: no charts, no
// resampling.
//
// The single material: base colour = the atlas (factors and vertex colours folded in), alpha mode
// BLEND if any source blends, else MASK if any masks (smallest cutoff), else OPAQUE; double-sided
// if any source is. Its textures are clamped, magnified LINEAR and minified LINEAR_MIPMAP_LINEAR,
// or, where the atlas is the source's own image texel for texel, with the mipmapped minFilter its
// textured materials agree on (NEAREST_MIPMAP_LINEAR shows those texels otherwise than trilinear
// filtering does). The physically based channels go through the same charts: when a material in use
// samples a normal, occlusion, metallic-roughness or emissive texture, or the materials' factors
// for a channel differ, that channel is baked into an image of the atlas's size (Scene::images
// after the base colour: normal, occlusion-roughness-metallic packed as glTF packs it, emissive),
// factors folded in; otherwise the shared factors stay factors. Normal maps are re-expressed in the
// tangent frame viewers derive from the atlas uvs (atlas/tangent_frame.h). Scenes with no texture,
// no vertex colour and at most one material are returned unchanged (they already have one material
// and need no texture).
// Materials the atlas cannot stand in for are not baked: tiled textures (a REPEAT sampler over
// more than `tiled_periods` periods), layer textures, anisotropy, samplers showing the texel
// grid; they stay as they came, after the atlas's (atlas/kept.h).
// Materials are grouped by how surfaces show beyond their texels (alpha mode and cutoff,
// double-sidedness, unlit, glass: KHR_materials_transmission with its ior and volume, and the
// reflection's layers: clearcoat, specular, iridescence factors), one output material per
// group, all sampling the one atlas; glass keeps its transmission (never folded into alpha,
// where a fully transmissive surface would vanish).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "atlas/bake.h"
#include "atlas/charts.h"
#include "atlas/pack.h"
#include "atlas/parameterize.h"
#include "scene/scene.h"

namespace meshmux {

struct AtlasOptions {
  ChartOptions charts;               // segmentation
  ParameterizeOptions parameterize;  // flattening
  BakeOptions bake;                  // resampling and gutters
  int max_size = 4096;               // largest atlas side
  double density = 1;                // atlas texels per source texel each textured chart gets
                                     // (its native density; area ratio; max_size and the
                                     // bytes bound, atlas/atlas_bytes.h, may shrink it)
  int min_size = 64;                 // smallest atlas side
  int flat_block = 4;                // least side of one flat-colour block, texels (gutters
                                     // around it); at least 1/64 of the atlas width
  int vertex_color_target = 512;     // largest T (side) for scenes whose only texture is vertex
                                     // colour (T: 256 texels per vertex, at least 128²)
  bool reuse_source_texture = true;  // keep the source's one texture as the atlas when every
                                     // face samples it inside [0, 1] (atlas/source_atlas.h)
  double tiled_periods = 2;          // a base colour texture repeated over more periods than
                                     // this on a piece keeps its material (atlas/tiled.h);
                                     // 0: every texture is baked
  bool keep_unbakeable = true;       // keep materials with layer textures, anisotropy or
                                     // texel-grid samplers beside the atlas (atlas/kept.h)
};

// One page of the atlas (Atlas pages, below).
struct AtlasPage {
  int width = 0, height = 0;  // texels
  size_t charts = 0;          // charts baked into it (0: the source's texture kept)
  double utilization = 0;     // packed texels / its texels
};

// One rebuild for the bytes bound (atlas/atlas_bytes.h).
struct AtlasBytesRound {
  double atlas_bytes = 0;   // the atlas's images encoded, before this rebuild
  double bound = 0;         // what they might cost
  double source_bytes = 0;  // the baked source images' encoded bytes
  double next_density = 1;  // the density the rebuild used
};

struct AtlasReport {
  bool built = false;               // false: the scene was returned unchanged
  bool reused_source = false;       // the source's one texture is the atlas (no charts, no baking)
  size_t kept_materials = 0;        // materials kept as they came beside the atlas (atlas/kept.h):
  size_t tiled_materials = 0;       //   for a tiled texture,
  size_t layer_materials = 0;       //   for layer or transmission textures or anisotropy,
  size_t texel_grid_materials = 0;  // for a sampler without mipmaps or NEAREST magnification
  size_t palette_materials = 0;     // materials whose palette texture became plain colours
                                    // (atlas/palette.h)
  size_t charts = 0;                // textured charts after splitting invalid ones
  size_t flat_colors = 0;           // distinct flat-colour blocks
  size_t split = 0;                 // charts split because they could not be flattened
  int size = 0;                     // atlas width, texels
  int height = 0;                   // atlas height, texels (size or size / 2)
  double reference_texels = 0;      // the base-colour texels the materials reference (T for
                                    // vertex colours), for comparison
  double utilization = 0;           // packed texels / atlas texels
  double reuse_scale = 1;           // the density the bytes bound leaves where charts reuse the
                                    // same source texels (1: none reused past 1.1×)
  double min_density = 0;           // the least, over charts sampling source texels, of atlas
                                    // texels per source texel (≥ 1 unless max_size stopped it;
                                    // 0: no such chart, or the source's texture was kept)
  double target_texels = 0;         // T of formula 2
  double mean_stretch_l2 = 0;       // area-weighted over textured charts
  double max_stretch_l2 = 0;
  double tangent_deviation_deg = 0;  // mean angle between dp/du and ∇u over the textured
                                     // charts (MikkTSpace's frame against the baked one)
  double seconds = 0;
  // The material whose texture set the texture levels stream (the atlas's first material: every
  // atlas material shares its images; where no atlas was needed, the scene's first material,
  // its one texture set), or -1 (no material). The others keep their own images (atlas/kept.h).
  int32_t streamed_material = -1;
  // For the bytes bound (atlas/atlas_bytes.h): the source images the atlas replaces (indices
  // into the input scene's images: those of the baked materials in use), and how many images
  // the atlas made (the output's first atlas_images; 0 when no charts were baked).
  std::vector<int32_t> baked_images;
  size_t atlas_images = 0;
  double atlas_bytes = 0;   // build_atlas_within_bytes: the atlas images encoded
  double source_bytes = 0;  // build_atlas_within_bytes: the baked images' encoded bytes
  std::vector<AtlasBytesRound> bytes_rounds;  // build_atlas_within_bytes: its rebuilds
  // Atlas pages: where the charts at their density do not fit one max_size² atlas, further
  // pages (each its own image set: base colour and every baked channel, at its own size; the
  // output's images page by page, `page_images` each) and one material per group and page, the
  // pages' in page order. size, height and utilization above are page 0's.
  std::vector<AtlasPage> pages;
  size_t page_images = 0;
  std::vector<int32_t> page_materials;  // per page: its first material (page 0's: 0)
  std::vector<int32_t> chart_page;      // per chart: its page
  // The layout, for tests and tools (page 0's texels; cells within each chart's page): per atlas
  // texel (size × height, row-major) its chart (gutters included; -1 none), and per chart its
  // exclusive power-of-two cell (flat charts of one colour share one).
  std::vector<int32_t> texel_chart;
  std::vector<PackPlacement> cell_pos;
  std::vector<PackRect> cell_size;
};

// The textured charts flattened (split where they would not flatten) and the flat charts: what a
// build computes before the density matters (Terrace et al. §4.2–4.3).
struct FlatCharts {
  ChartSet charts;
  std::vector<ChartUv> uvs;  // per chart
  size_t split = 0;          // charts split because they could not be flattened
};

// What one build hands to the next build of the same scene with the same chart and
// parameterization options (build_atlas_within_bytes rebuilds at a lower density: segmenting and
// flattening again would give the same charts, at most of the build's time). Empty at first;
// filled by the build.
struct AtlasMemo {
  std::optional<FlatCharts> charts;
};

// `scene` must be clean (clean/clean.h). Errors only for internal failures. With `memo`, the
// charts come from it when it holds them, and go into it when it does not.
Result<Scene> build_atlas(const Scene& scene, const AtlasOptions& options, AtlasReport* report,
                          Warnings* warnings, AtlasMemo* memo = nullptr);

}  // namespace meshmux
