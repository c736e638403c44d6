// The conversion pipeline (pipeline/convert.h). convert() is the numbered stage list; each step
// below is one stage call plus its progress line. Stages: Terrace, Cheslack-Postava, Levis and
// Freedman, "Unsupervised conversion of 3D models for interactive metaverses" §4.1 (clean),
// §4.2–4.4 (atlas, texture levels); Azim, Cheslack-Postava and Levis, "Instance-aware
// simplification of 3D polygonal meshes" with Terrace et al. §4.5 (simplify); Yang, Shen and
// Kuo, "Progressive coding of 3D textured graphic model via joint mesh-texture optimization" §3
// (multiplex); docs/ARCHITECTURE.md "Package" (the stream).
#include "pipeline/convert.h"

#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cstdarg>
#include <cstdio>
#include <optional>

#include "atlas/atlas_bytes.h"
#include "atlas/kept.h"
#include "clean/flatten.h"
#include "core/parallel.h"
#include "exporters/draco_encode.h"
#include "image/encode.h"
#include "image/kept_levels.h"
#include "image/ktx2_encode.h"
#include "multiplex/report.h"
#include "multiplex/stream_plan.h"
#include "simplify/block_dag.h"
#include "simplify/lod.h"
#include "stream/deflate.h"
#include "stream/package.h"
#include "stream/package_base.h"

namespace meshmux {

namespace {

std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char* fmt, ...) {
  char buf[512];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buf, sizeof buf, fmt, args);
  va_end(args);
  return buf;
}

// 1. Clean (Terrace et al. §4.1).
Scene clean_step(Scene scene, const ConvertOptions& o, Progress* progress) {
  CleanReport r;
  Scene out = clean(std::move(scene), o.clean, &r);
  report_step(progress,
              format("cleaned: %llu unique triangles (%llu degenerate, %llu duplicate removed), "
                     "%llu vertices",
                     (unsigned long long)r.triangles_out, (unsigned long long)r.degenerate_removed,
                     (unsigned long long)r.duplicates_removed, (unsigned long long)r.vertices_out));
  return out;
}

// 2. Atlas: one material, one texture (Terrace et al. §4.2–4.4); then the one flattening
// decision (Azim et al.: below 1.75 instances per submesh, one mesh is one draw call).
// `*streamed_material` gets the material whose texture set the texture levels stream (the
// atlas's, AtlasReport::streamed_material), -1 without an atlas; `*atlas_pages` the atlas's
// pages (AtlasReport::pages); `*baked_encoded` whether the atlas's images hold their top level's
// bytes (baked, not the source's own image).
Result<Scene> atlas_step(Scene scene, const ConvertOptions& o, Warnings* warnings,
                         Progress* progress, int32_t* streamed_material,
                         std::vector<AtlasPage>* atlas_pages, bool* baked_encoded) {
  *streamed_material = -1;
  *baked_encoded = false;
  if (!o.atlas) return scene;
  report_step(progress, "building the atlas (charts, parameterization, packing, baking)");
  AtlasReport ar;
  auto atlased = build_atlas_within_bytes(scene, o.atlas_options, o.textures.jpeg_quality, &ar,
                                          warnings, o.textures.counts);
  for (const AtlasBytesRound& r : ar.bytes_rounds)
    report_step(progress, format("atlas: %.0f kB encoded, over %.0f kB for %.0f kB of sources; "
                                 "charts at %.0f%% of their density",
                                 r.atlas_bytes / 1e3, r.bound / 1e3, r.source_bytes / 1e3,
                                 100 * r.next_density));
  if (!atlased.ok()) {
    // Valid input never fails here: a model whose charts cannot share one atlas keeps its
    // own materials (as --no-atlas), said once.
    warn(warnings, atlased.status().message() + "; the source materials are kept (no atlas)");
    return scene;
  }
  *streamed_material = ar.streamed_material;
  // Baked atlas images carry the bytes the bytes bound measured: the top level's own.
  *baked_encoded = ar.built && !ar.reused_source && ar.atlas_images > 0;
  if (!ar.built) {
    report_step(progress, "atlas: not needed (one material, no texture)");
    return scene;
  }
  const std::string palettes =
      ar.palette_materials > 0
          ? format(" (%zu palette material(s) among them, atlas/palette.h)", ar.palette_materials)
          : "";
  if (ar.reused_source)
    report_step(progress, format("atlas: the source's one texture kept as it is, %dx%d, + %zu "
                                 "plain colours in unused texels%s (no resampling)",
                                 ar.size, ar.height, ar.flat_colors, palettes.c_str()));
  else if (ar.size > 0)
    report_step(progress,
                format("atlas: %zu charts + %zu flat colours, %dx%d (%.0f texels of "
                       "%.0f referenced), %.0f%% used, charts at ≥ %.0f%% of their sources' "
                       "density, %.0f kB encoded for %.0f kB of sources, L2 stretch mean %.3f "
                       "max %.3f, tangent frames within %.2f° of MikkTSpace's, %.2f s",
                       ar.charts, ar.flat_colors, ar.size, ar.height, double(ar.size) * ar.height,
                       ar.reference_texels, 100 * ar.utilization, 100 * ar.min_density,
                       ar.atlas_bytes / 1e3, ar.source_bytes / 1e3, ar.mean_stretch_l2,
                       ar.max_stretch_l2, ar.tangent_deviation_deg, ar.seconds));
  if (ar.kept_materials > 0)
    report_step(progress,
                format("atlas: %zu material(s) kept with their own textures and samplers: %zu "
                       "tiled (repeated over more than %.0f periods), %zu with layer textures or "
                       "anisotropy, %zu sampled without mipmaps or NEAREST",
                       ar.kept_materials, ar.tiled_materials, o.atlas_options.tiled_periods,
                       ar.layer_materials, ar.texel_grid_materials));
  Scene out = atlased.take();
  if (ar.pages.size() > 1) {
    std::string sizes;
    for (const AtlasPage& p : ar.pages)
      sizes +=
          format("%s%dx%d (%zu charts)", sizes.empty() ? "" : ", ", p.width, p.height, p.charts);
    report_step(progress,
                format("atlas: %zu pages (charts at their density past %dx%d): %s", ar.pages.size(),
                       o.atlas_options.max_size, o.atlas_options.max_size, sizes.c_str()));
    // Every page's images carry the bytes the bytes bound measured, encoded as the first page's
    // top level (build_atlas_within_bytes): model.glb embeds them so, and the stream carries
    // them at every level's scale as it carries a kept material's images
    // (image/kept_levels.h), from their pixels.
  }
  *atlas_pages = ar.pages;
  if (ar.kept_materials > 0)
    if (size_t saved =
            encode_kept_images(out, ar.kept_materials, o.textures.jpeg_quality, o.counts))
      report_step(progress, format("atlas: the kept materials' opaque images re-encoded as JPEG, "
                                   "%.0f kB smaller",
                                   double(saved) / 1e3));
  if (should_flatten(out, o.simplify.flatten_below_ips)) {
    out = flatten(std::move(out));
    report_step(progress, format("flattened (fewer than %.2f instances per submesh): one mesh",
                                 o.simplify.flatten_below_ips));
  }
  return out;
}

// 3. Can it be streamed? Decided before the expensive stages: the stream needs one material
// per mesh (the atlas gives that).
std::string unstreamable_reason(const Scene& scene) {
  for (const Mesh& m : scene.meshes)
    if (m.primitives.size() != 1)
      return "a mesh has several materials (the stream needs the one-material atlas)";
  return "";
}

// What the progressive record can still rule out: a submesh with several primitives after the
// simplifier's flattening, or one that shows no triangle at the base level (`base_meshes`: the
// meshes the materialized base kept).
std::string unstreamable_record(const ProgressiveScene& ps, size_t base_meshes) {
  for (const ProgressiveMesh& pm : ps.meshes)
    if (pm.primitive_material.size() != 1)
      return "a mesh has several materials (the stream needs the one-material atlas)";
  if (base_meshes != ps.meshes.size()) return "a mesh has no triangles at the base level";
  return "";
}

// The scene's one streamed texture (material `material`'s base colour: the atlas's), or null.
// The texture levels need power-of-two sides, as the atlas has: a scene whose streamed material
// kept a source texture of other sides (a tiled texture, atlas/tiled.h, in a scene with nothing
// else) streams no texture levels, and its texture ships as it came.
Image* stream_texture(Scene& scene, int32_t material) {
  if (material < 0 || size_t(material) >= scene.materials.size() ||
      !scene.materials[size_t(material)].base_color.present())
    return nullptr;
  size_t i = size_t(scene.materials[size_t(material)].base_color.image);
  if (i >= scene.images.size()) return nullptr;
  auto pow2 = [](int v) { return v > 0 && (v & (v - 1)) == 0; };
  return pow2(scene.images[i].width) && pow2(scene.images[i].height) ? &scene.images[i] : nullptr;
}

// The atlas's further channels, in the order the texture levels carry them: the
// image each stands for in `scene` and how its texels filter.
struct SceneChannel {
  const char* channel;
  int32_t image;
  TexelFilter filter;
};
std::vector<SceneChannel> scene_channels(const Scene& scene, int32_t material) {
  std::vector<SceneChannel> out;
  if (material < 0 || size_t(material) >= scene.materials.size()) return out;
  const Material& m = scene.materials[size_t(material)];
  auto add = [&](const TextureRef& t, const char* name, TexelFilter f) {
    if (t.present() && size_t(t.image) < scene.images.size() &&
        scene.images[size_t(t.image)].width > 0)
      out.push_back({name, t.image, f});
  };
  add(m.normal, channel_name(Channel::kNormal), TexelFilter::kNormal);
  add(m.metallic_roughness, channel_name(Channel::kOcclusionRoughnessMetallic), TexelFilter::kData);
  add(m.emissive, channel_name(Channel::kEmissive), TexelFilter::kSrgb);
  add(m.sheen_color, channel_name(Channel::kSheenColor), TexelFilter::kSrgb);
  return out;
}

// 4. Texture levels, encoded once (model.glb embeds the top level, the stream all of them).
// Without a stream only the top level is built. The atlas's channels move together: every level
// carries each at its size.
Result<TextureLevels> texture_step(Scene& scene, int32_t streamed_material, const ConvertOptions& o,
                                   bool whole_pyramid, bool baked_encoded, Progress* progress) {
  Image* texture = o.atlas ? stream_texture(scene, streamed_material) : nullptr;
  if (!texture) return TextureLevels{};
  TextureLevelOptions to = o.textures;
  if (!whole_pyramid) to.base_size = 1 << 30;  // a base larger than the texture: one level
  to.top_from_encoded = baked_encoded;
  const std::vector<SceneChannel> sc = scene_channels(scene, streamed_material);
  std::vector<ChannelTexture> channels;
  for (const SceneChannel& c : sc)
    channels.push_back({c.channel, &scene.images[size_t(c.image)], c.filter});
  auto levels = make_texture_levels(*texture, to, channels);
  if (!levels.ok()) return levels.status();
  levels->material = streamed_material;
  // The kept materials' images go with the levels, each at its level's scale.
  if (whole_pyramid)
    if (Status st = add_kept_levels(scene, *levels, to); !st) return st;
  // With KTX2 levels model.glb carries the kept images as the top level does (KTX2 too).
  if (whole_pyramid && to.ktx2) apply_kept_level(scene, *levels, levels->levels.size() - 1);
  // From here on the levels stand for the atlas's images: their pixels are released (a 4096²
  // atlas's four channels are 256 MB, which every later copy of the scene would repeat).
  texture->encoded = levels->levels.back().encoded;
  texture->mime_type = levels->levels.back().mime_type;
  std::vector<uint8_t>().swap(texture->rgba);
  for (size_t c = 0; c < sc.size(); ++c) {
    Image& img = scene.images[size_t(sc[c].image)];
    img.encoded = levels->levels.back().other_maps[c].encoded;
    img.mime_type = levels->levels.back().other_maps[c].mime_type;
    std::vector<uint8_t>().swap(img.rgba);
  }
  size_t kept_bytes = 0, kept_maps = 0;
  for (const TextureLevel& l : levels->levels)
    for (const KeptMap& k : l.kept)
      if (&l != &levels->levels.back()) kept_bytes += k.encoded.size(), ++kept_maps;
  if (kept_maps > 0)
    report_step(progress, format("texture levels: %zu kept image(s) at the levels' scales below "
                                 "the top, %zu maps, %.1f kB",
                                 kept_level_images(scene, levels->material).size(), kept_maps,
                                 kept_bytes / 1e3));
  std::string dropped;
  for (const DroppedTextureLevel& d : levels->dropped)
    dropped += format(", %dx%d dropped (%s)", d.width, d.height, d.why.c_str());
  report_step(progress,
              format("texture levels: %zu, %dx%d down to %dx%d%s", levels->levels.size(),
                     levels->levels.back().width, levels->levels.back().height,
                     levels->levels.front().width, levels->levels.front().height, dropped.c_str()));
  return levels;
}

// The scene at `sel` showing texture level `level` (when there are levels).
Scene level_scene(const ProgressiveScene& ps, const LodSelection& sel, const TextureLevels& levels,
                  size_t level, bool keep_prefix) {
  // The images the level replaces are not copied (a 4096² atlas's four channels are 256 MB,
  // and the base's bytes bound asks for a dozen such scenes): every image comes as its header
  // (name, type, size), then those the level keeps are filled in.
  Scene s = materialize(ps, sel, keep_prefix, /*with_images=*/false);
  s.images.resize(ps.scene.images.size());
  for (size_t i = 0; i < s.images.size(); ++i) {
    const Image& from = ps.scene.images[i];
    s.images[i].name = from.name, s.images[i].mime_type = from.mime_type;
    s.images[i].width = from.width, s.images[i].height = from.height;
  }
  std::vector<char> replaced(s.images.size(), 0);
  if (Image* texture = stream_texture(s, levels.material);
      texture && level < levels.levels.size()) {
    replaced[size_t(texture - s.images.data())] = 1;
    const std::vector<SceneChannel> sc = scene_channels(s, levels.material);
    for (size_t c = 0; c < sc.size() && c < levels.levels[level].other_maps.size(); ++c)
      replaced[size_t(sc[c].image)] = 1;
  }
  for (size_t j = 0; j <= level && j < levels.levels.size(); ++j)
    for (const KeptMap& map : levels.levels[j].kept)
      if (map.image >= 0 && size_t(map.image) < replaced.size()) replaced[size_t(map.image)] = 1;
  for (size_t i = 0; i < s.images.size(); ++i)
    if (!replaced[i]) s.images[i] = ps.scene.images[i];
  Image* texture = stream_texture(s, levels.material);
  if (texture && level < levels.levels.size()) {
    const TextureLevel& l = levels.levels[level];
    const std::vector<SceneChannel> sc = scene_channels(s, levels.material);
    Image img;
    img.name = "texture level " + std::to_string(level);
    img.encoded = l.encoded;
    img.mime_type = l.mime_type;
    img.width = l.width, img.height = l.height;
    *texture = std::move(img);
    for (size_t c = 0; c < sc.size() && c < l.other_maps.size(); ++c) {
      Image& ci = s.images[size_t(sc[c].image)];
      ci = Image{};
      ci.name = "texture level " + std::to_string(level) + " " + sc[c].channel;
      ci.encoded = l.other_maps[c].encoded;
      ci.mime_type = l.other_maps[c].mime_type;
      ci.width = l.width, ci.height = l.height;
    }
  }
  apply_kept_level(s, levels, level);
  return s;
}

// 8. Multiplex (Yang, Shen and Kuo §3). No offscreen OpenGL: a warning, no report and no package.
Result<std::optional<MultiplexResult>> multiplex_step(const ProgressiveScene& ps,
                                                      const TextureLevels& levels,
                                                      const ConvertOptions& o,
                                                      const PackageBound& bound, Warnings* warnings,
                                                      Progress* progress) {
  report_step(progress, "multiplexing (rendering levels from the viewing sphere)");
  auto mx = multiplex(ps, levels, o.multiplex, progress, &bound);
  if (!mx.ok() && mx.status().kind() == ErrorKind::kUnavailable) {
    warn(warnings,
         "report: " + mx.status().message() + "; report.json, rd.svg and model.mmxp not written");
    return std::optional<MultiplexResult>();
  }
  if (!mx.ok()) return mx.status();
  report_step(progress,
              format("multiplexed: %zu mesh x %zu texture layers, %zu views, %zu of "
                     "%zu cells rendered (%zu images), %.1f s",
                     mx->mesh_bytes.size(), mx->texture_bytes.size(), mx->views,
                     mx->cells_evaluated, mx->cells_total, mx->renders, mx->seconds_total));
  return std::optional<MultiplexResult>(mx.take());
}

// The stream package's base when refinements follow: meshoptimizer's order-keeping codecs over
// attributes quantized exactly as the stream codes them (stream/quantize.h), so vertex i is the
// stream's vertex i and its integers are the ones the vertex splits are predicted from.
Result<std::vector<uint8_t>> ordered_base_glb(const ProgressiveScene& ps,
                                              const std::vector<MeshStreamBase>& heads,
                                              const TextureLevels& levels, const ConvertOptions& o,
                                              Warnings* warnings) {
  GltfExportOptions plain = o.gltf;
  plain.draco = false;
  plain.meshopt = true;
  plain.tag_meshes = true;
  for (const MeshStreamBase& m : heads) plain.position_quantization.push_back(m.quantization);
  Scene base_scene = level_scene(ps, select_base(ps), levels, 0, /*keep_prefix=*/true);
  if (Status st = order_base_scene(base_scene, heads); !st) return st;
  return export_glb_bytes(base_scene, plain, warnings);
}

// The completion (stream/format.h "Completion") of mesh m: its full detail, single-rate, as
// model.glb codes it (Draco) but with positions on the stream's grid, so that the base's node
// transforms dequantize it; normals where the stream carries them, the first uv set where the
// mesh has one.
Result<CompletionMesh> completion_mesh(const ProgressiveMesh& pm, const MeshStreamBase& head,
                                       uint32_t m, const GltfExportOptions& gltf) {
  const size_t V = pm.vertex_count();
  std::vector<Vec3> grid(V);
  for (size_t v = 0; v < V; ++v) {
    const QuantizedVertex q = quantize_vertex(pm, head.quantization, uint32_t(v));
    grid[v] = {float(q.p[0]), float(q.p[1]), float(q.p[2])};
  }
  std::vector<std::vector<Vec2>> uvs;
  if (!pm.uvs.empty() && pm.uvs[0].size() == V) uvs.push_back(pm.uvs[0]);
  DracoInput in;
  in.positions = &grid;
  in.normals = head.normals && pm.normals.size() == V ? &pm.normals : nullptr;
  in.uvs = uvs.empty() ? nullptr : &uvs;
  in.indices = &pm.indices;
  DracoSettings settings;
  settings.position_bits = kPositionBits;  // the grid's integers, exactly
  settings.normal_bits = gltf.normal_bits, settings.uv_bits = gltf.uv_bits;
  settings.speed = gltf.draco_speed;
  auto coded = draco_encode(in, settings);
  if (!coded.ok())
    return Status::error("completion: mesh " + std::to_string(m) + ": " + coded.status().message(),
                         ErrorKind::kInternal);
  CompletionMesh out;
  out.mesh = m, out.vertices = coded->num_points, out.faces = coded->num_faces;
  out.data = std::move(coded->bytes);
  return out;
}

// 9. The stream package: the base (mesh layer 0 with texture level 0: ordered_base_glb, or
// Draco when every mesh ships whole), then the descent's steps as chunks made of the bytes the
// multiplexer encoded; the baselines ride along as orders of the same chunks.
Result<std::vector<uint8_t>> package_step(const ProgressiveScene& ps, const MultiplexResult& mx,
                                          const TextureLevels& levels, const ConvertOptions& o,
                                          std::optional<std::vector<uint8_t>> ordered_base,
                                          Warnings* warnings) {
  auto plan = stream_plan(mx);
  if (!plan.ok()) return plan.status();
  // Every mesh ships whole (no refinement follows; small models, docs/ARCHITECTURE.md "Simplify"):
  // no vertex order needs keeping, so the base is coded as model.glb is, with Draco (about 0.6x the
  // bytes of meshopt + deflate on Duck), its meshes tagged for the client.
  bool whole = mx.completion.empty();
  for (const std::vector<EncodedMeshPart>& parts : mx.layer_parts) whole = whole && parts.empty();
  GltfExportOptions tagged = o.gltf;
  tagged.tag_meshes = true;
  Result<std::vector<uint8_t>> base =
      whole ? export_glb_bytes(level_scene(ps, select_base(ps), levels, 0, false), tagged, warnings)
      : ordered_base ? Result<std::vector<uint8_t>>(std::move(*ordered_base))
                     : ordered_base_glb(ps, mx.mesh_streams, levels, o, warnings);
  if (!base.ok()) return base.status();
  PackageInput in;
  in.base_glb = base.take();
  in.base_whole = whole;
  in.meshes = mx.mesh_streams;
  in.mesh_layers = &mx.layer_parts;
  in.mesh_chunks = &mx.layer_chunks;
  in.completion = mx.completion;
  in.textures = levels.levels.empty() ? nullptr : &levels;
  in.steps = plan->steps;
  in.base_distortion = plan->base_distortion;
  in.orders = plan->orders;
  in.view = package_view(o.multiplex);
  in.view_table = &mx.view_table;
  return write_package(in);
}

// The package as a viewer receives it (the stored order, real bytes): nothing until the header,
// table and base are in, then each chunk. For report.json's download comparison.
Result<DownloadComparison> download_comparison(const std::vector<uint8_t>& package,
                                               uint64_t model_glb_bytes, double empty) {
  auto pkg = read_package(package);
  if (!pkg.ok()) return pkg.status();
  DownloadComparison c;
  c.model_glb_bytes = model_glb_bytes;
  uint64_t first = pkg->base_offset + pkg->base_size;
  c.package.push_back({0, empty});
  c.package.push_back({first, pkg->base_distortion});
  if (!pkg->orders.empty()) {
    const PackageOrder& order = pkg->orders[0];
    uint64_t received = first;
    for (size_t k = 0; k < order.chunks.size(); ++k) {
      received += pkg->chunks[order.chunks[k]].size;
      c.package.push_back({received, k < order.distortion.size() ? order.distortion[k] : 0.0});
    }
  }
  return c;
}

}  // namespace

uint64_t first_picture_bytes(uint64_t model_bytes, const ConvertOptions& o) {
  if (!(o.base_model_share > 0)) return 0;
  const double share = o.base_model_share * double(model_bytes);
  return std::min(o.base_max_bytes,
                  std::max(o.base_min_bytes, uint64_t(std::min(share, double(UINT64_MAX / 2)))));
}

// The first picture's bound (first_picture_bytes), on models the stream refines. When the
// stopping rule's base is over it, the finest coarser base under it is taken: one error
// threshold over the submeshes (select_triangles), every instance, found by bisection on its
// triangles (each step encodes a trial base.glb), and written back as each mesh's base_level,
// so the package's base and the multiplexer follow. When even the coarsest levels are over it
// (thousands of separate parts, kept materials' images at full size, a collapse loop that the
// link condition stops early), the coarsest levels are taken and the progress says what they
// hold. A trial encode that fails counts as over the bound; the chosen base is encoded again by
// the caller, where a failure is reported. `limit`: first_picture_bytes, or less where the
// package's bound asks for it (convert), `what` names it for the progress line. Returns the base
// chosen.
LodSelection bound_base(ProgressiveScene& ps, const LodSelection& base, const TextureLevels& levels,
                        const ConvertOptions& o, size_t model_bytes, uint64_t limit,
                        const char* what, Progress* progress) {
  const double budget = double(limit);
  if (limit == 0 || selection_triangles(ps, select_full(ps)) < o.simplify.ship_whole_below)
    return base;
  auto bytes = [&](const LodSelection& sel) {
    Warnings scratch;  // the chosen base is encoded again with the caller's sink
    auto glb = export_glb_bytes(level_scene(ps, sel, levels, 0, false), o.gltf, &scratch);
    return glb.ok() ? double(glb->size()) : double(INFINITY);
  };
  auto write_back = [&](const LodSelection& sel) {
    for (size_t m = 0; m < ps.meshes.size(); ++m) ps.meshes[m].base_level = sel.level[m];
  };
  const double base_bytes = bytes(base);
  if (base_bytes <= budget) return base;
  LodSelection coarsest = base;
  std::fill(coarsest.level.begin(), coarsest.level.end(), size_t(0));
  const double coarsest_bytes = bytes(coarsest);
  if (coarsest_bytes > budget) {
    size_t image_bytes = 0;
    for (const Image& im : level_scene(ps, coarsest, levels, 0, false).images)
      image_bytes += im.encoded.size();
    write_back(coarsest);
    report_step(progress,
                format("base: over %s %.1f kB even at the coarsest levels: "
                       "%llu triangles, %.1f kB (images %.1f kB) instead of %.1f kB",
                       what, budget / 1e3, (unsigned long long)selection_triangles(ps, coarsest),
                       coarsest_bytes / 1e3, double(image_bytes) / 1e3, base_bytes / 1e3));
    return coarsest;
  }
  uint64_t lo = selection_triangles(ps, coarsest), hi = selection_triangles(ps, base);
  LodSelection best = coarsest;
  for (int it = 0; it < 10 && hi > lo + std::max<uint64_t>(16, hi / 50); ++it) {
    const uint64_t mid = lo + (hi - lo) / 2;
    LodSelection sel = select_triangles(ps, mid);
    for (size_t m = 0; m < sel.level.size(); ++m)
      sel.level[m] = std::min(sel.level[m], base.level[m]);
    sel.instances = base.instances;
    if (bytes(sel) <= budget)
      lo = mid, best = sel;
    else
      hi = mid;
  }
  write_back(best);
  report_step(progress, format("base: %.1f kB was over %s %.1f kB (model.glb "
                               "%.1f kB): a coarser base of %llu triangles instead",
                               base_bytes / 1e3, what, budget / 1e3, double(model_bytes) / 1e3,
                               (unsigned long long)selection_triangles(ps, best)));
  return best;
}

// Steps 7–10 of convert on the record `ps`: the base under `base_limit` bytes (bound_base; set
// by the package's bound when `package_bound`, else the first picture's),
// base.glb, the multiplexer's order (within the package's bound), the package and the report,
// into `out` (which holds model.glb and the figures so far).
Status stream_steps(ProgressiveScene& ps, const TextureLevels& levels_ref, const ConvertOptions& o,
                    uint64_t base_limit, bool package_bound, const SimplifyReport& sr,
                    const OutputFigures& figures, ConvertOutputs& out, Warnings* warnings,
                    Progress* progress) {
  const TextureLevels* levels = &levels_ref;
  const LodSelection base = bound_base(
      ps, select_base(ps), *levels, o, out.model_glb.size(), base_limit,
      package_bound ? "what the package's bound leaves it," : "the first picture's", progress);
  out.base_triangles = selection_triangles(ps, base);
  report_step(progress,
              format("base level: %llu of %llu triangles%s, %llu collapses in %d ms",
                     (unsigned long long)out.base_triangles, (unsigned long long)sr.input_triangles,
                     sr.flattened ? " (flattened: few instances per submesh)" : "",
                     (unsigned long long)sr.collapses, int(sr.seconds * 1000)));
  // 7. base.glb: the base mesh with texture level 0, Draco-coded.
  Scene base_scene = level_scene(ps, base, *levels, 0, false);
  const size_t base_meshes = base_scene.meshes.size();
  auto base_glb = export_glb_bytes(base_scene, o.gltf, warnings);
  if (!base_glb.ok()) return base_glb.status();
  out.base_glb = base_glb.take();
  if (!o.report) return Status::ok();
  // 8. Multiplex: renders, the order, the mesh parts encoded once; past the package's bound the
  // chain of splits ends in the completion. The package's base is built when the bound asks for
  // its bytes, and handed on to the package.
  std::optional<std::vector<uint8_t>> ordered_base;
  const std::vector<MeshStreamBase>* heads = nullptr;  // the multiplexer's, while it runs
  PackageBound bound;
  if (o.max_package_ratio > 0) {
    bool blocks = false;  // block parts are bounded at the larger of the two ratios
    for (const ProgressiveMesh& pm : ps.meshes) blocks = blocks || !pm.blocks.empty();
    bound.max_bytes =
        uint64_t(std::max(o.max_package_ratio, blocks ? o.max_block_package_ratio : 0.0) *
                 double(out.model_glb.size()));
    bound.fixed_bytes = [&](const std::vector<MeshStreamBase>& h) -> Result<uint64_t> {
      heads = &h;
      auto glb = ordered_base_glb(ps, h, *levels, o, warnings);
      if (!glb.ok()) return glb.status();
      const uint64_t stored = std::min(deflate_bytes(*glb).size(), glb->size());
      ordered_base = glb.take();
      return stored;
    };
    bound.completion =
        [&](const std::vector<uint32_t>& meshes) -> Result<std::vector<CompletionMesh>> {
      std::vector<Result<CompletionMesh>> coded(meshes.size(), Status::ok());
      parallel_chunks(meshes.size(), 1, [&](size_t begin, size_t end) {
        for (size_t c = begin; c < end; ++c)
          coded[c] = completion_mesh(ps.meshes[meshes[c]], (*heads)[meshes[c]], meshes[c], o.gltf);
      });
      std::vector<CompletionMesh> list;
      for (Result<CompletionMesh>& c : coded) {
        if (!c.ok()) return c.status();
        list.push_back(c.take());
      }
      return list;
    };
  }
  auto mx = multiplex_step(ps, *levels, o, bound, warnings, progress);
  if (!mx.ok()) return mx.status();
  if (!mx->has_value()) return Status::ok();
  out.multiplexed = std::move(**mx);
  const MultiplexResult& m = *out.multiplexed;
  // 9. The stream package.
  if (out.not_streamed.empty()) out.not_streamed = unstreamable_record(ps, base_meshes);
  if (!out.not_streamed.empty()) {
    warn(warnings, "package: " + out.not_streamed + "; model.mmxp and the viewer not written");
    out.report_json = report_json(m, nullptr, &figures);
    out.rd_svg = rd_svg(m);
    return Status::ok();
  }
  if (m.completion_report.used)
    report_step(progress,
                format("completion: after mesh layer %zu of %zu, the full mesh single-rate "
                       "(%.1f kB for %.1f kB of splits; %s): package planned at %.2f x model.glb "
                       "(%.2f x with every split)",
                       m.completion_report.after_layer, m.completion_report.chain_layers - 1,
                       m.completion_report.bytes / 1e3, m.completion_report.tail_bytes / 1e3,
                       m.completion_report.why == "bound"
                           ? "the latest layer within the package's bound"
                           : "earlier, where its slope beats the next mesh step's",
                       double(m.completion_report.planned_bytes) / double(out.model_glb.size()),
                       double(m.completion_report.chain_bytes) / double(out.model_glb.size())));
  auto package = package_step(ps, m, *levels, o, std::move(ordered_base), warnings);
  if (!package.ok()) return package.status();
  out.package = package.take();
  out.mesh_chunks = m.layer_parts.size() - 1;
  out.texture_chunks = levels->levels.empty() ? 0 : levels->levels.size() - 1;
  // 10. The report: the order's curves, costed from the base as it ships, and the package as
  // received against model.glb.
  auto cmp = download_comparison(out.package, out.model_glb.size(), m.empty_distortion);
  if (!cmp.ok()) return cmp.status();
  cost_base_as_shipped(*out.multiplexed, cmp->package[1].first);
  out.report_json = report_json(m, &*cmp, &figures);
  out.rd_svg = rd_svg(m, &*cmp);
  return Status::ok();
}

Result<ConvertOutputs> convert(Scene input, const ConvertOptions& options, Warnings* warnings,
                               Progress* progress) {
  ConvertOptions o = options;
  if (o.counts) o.textures.counts = o.gltf.counts = o.multiplex.counts = o.counts;
  ConvertOutputs out;
  out.input = compute_stats(input);
  // 1. Clean; the input is not read again.
  Scene scene = clean_step(std::move(input), o, progress);
  input = Scene{};
  // 2. Atlas (and the flattening decision).
  int32_t streamed_material = -1;
  std::vector<AtlasPage> atlas_pages;
  bool baked_encoded = false;  // the atlas's images hold their top level's bytes
  auto atlased = atlas_step(std::move(scene), o, warnings, progress, &streamed_material,
                            &atlas_pages, &baked_encoded);
  if (!atlased.ok()) return atlased.status();
  scene = atlased.take();
  // 3. Streamable? Decided now, before the expensive stages.
  out.not_streamed = o.stream && o.report ? unstreamable_reason(scene) : "";
  // 4. Texture levels, encoded once.
  auto levels = texture_step(scene, streamed_material, o, o.stream, baked_encoded, progress);
  if (!levels.ok()) return levels.status();
  out.texture_levels = levels->levels.size();
  // 5. model.glb, full quality; with a stream to make, encoded on a thread of its own while the
  // simplifier (6, no warnings of its own) runs: they only read the scene. Its warnings join
  // the sink afterwards, in the order a sequential run gives. On scenes of
  // `o.concurrent_model_below` unique triangles or more it is encoded first instead: Draco's
  // encoder holds ~110 bytes per triangle, the simplifier ~190, both at once their sum.
  report_step(progress, "encoding model.glb");
  Warnings model_warnings;
  Result<std::vector<uint8_t>> model = std::vector<uint8_t>{};
  auto encode_model = [&] { model = export_glb_bytes(scene, o.gltf, &model_warnings); };
  std::optional<Background> model_task;
  if (o.stream && compute_stats(scene).unique_triangles < o.concurrent_model_below)
    model_task.emplace(encode_model);
  else
    encode_model();
  ProgressiveScene ps;
  SimplifyReport sr;
  if (o.stream) {
    // 6. Simplify: the instance-aware progressive record and its base.
    report_step(progress, "simplifying (instance-aware progressive record)");
    ps = build_progressive(scene, o.simplify, &sr, progress);
  }
  if (model_task) model_task->wait();
  for (const std::string& w : model_warnings.items()) warn(warnings, w);
  if (!model.ok()) return model.status();
  out.model_glb = model.take();
  out.output = compute_stats(scene);
  OutputFigures figures;
  for (const AtlasPage& p : atlas_pages) figures.atlas_pages.push_back({p.width, p.height});
  figures.draw_calls = out.output.draw_calls;
  if (o.textures.ktx2) {
    auto version = ktx2_encoder_version(o.textures.ktx2_options);
    if (!version.ok()) return version.status();
    figures.texture_encoder = version.take();
  }
  if (!o.stream) return out;
  scene = Scene{};  // the record (ps) holds the geometry from here on
  // Its arrays under glibc's (risen) mmap threshold were freed into the heap, which keeps the
  // pages: handed back before the multiplexer allocates (4M scan: ~360 MB it started above its
  // record).
  malloc_trim(0);
  // A big mesh's block hierarchy ordered by blocks with its DAG: what the stream's block parts
  // need (stream/format.h "Blocks").
  {
    size_t blocks = 0;
    for (const ProgressiveMesh& pm : ps.meshes) blocks += pm.blocks.size();
    if (blocks) {
      const auto t0 = std::chrono::steady_clock::now();
      if (Status st = order_block_records(ps); !st) return st;
      size_t parts = 0;
      for (const ProgressiveMesh& pm : ps.meshes) parts += pm.blocks.size();
      report_step(
          progress,
          format("block hierarchy: %zu blocks, ordered with their dependencies in %.1f s", parts,
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()));
      malloc_trim(0);
    }
  }
  // 7–10. The base, the order and the package. The package's bound: the completion step keeps it
  // (multiplex/multiplex.h) down to the full mesh single-rate right after the base, the least a
  // package holds; where even that is over the bound (or the splits from the base cost less than
  // it, yet over the bound), the base gives way by the excess, once, as the first picture's bytes
  // bound it.
  uint64_t base_limit = first_picture_bytes(out.model_glb.size(), o);
  bool blocks = false;
  for (const ProgressiveMesh& pm : ps.meshes) blocks = blocks || !pm.blocks.empty();
  const double ratio = blocks && o.max_package_ratio > 0
                           ? std::max(o.max_package_ratio, o.max_block_package_ratio)
                           : o.max_package_ratio;
  for (int attempt = 0;; ++attempt) {
    Warnings attempt_warnings;
    ConvertOutputs tried = out;
    if (Status st = stream_steps(ps, *levels, o, base_limit, attempt > 0, sr, figures, tried,
                                 &attempt_warnings, progress);
        !st)
      return st;
    const uint64_t max_bytes = uint64_t(ratio * double(out.model_glb.size()));
    // (A model shipped whole has no base to give: its package is its base and the table.)
    const bool over = ratio > 0 && !tried.package.empty() && tried.package.size() > max_bytes &&
                      selection_triangles(ps, select_full(ps)) >= o.simplify.ship_whole_below;
    if (!over || attempt == 1) {
      if (over)
        report_step(progress, format("package: %.2f x model.glb, over its bound even with the "
                                     "coarsest base the record allows",
                                     double(tried.package.size()) / double(out.model_glb.size())));
      for (const std::string& w : attempt_warnings.items()) warn(warnings, w);
      out = std::move(tried);
      return out;
    }
    // Over by the excess, and half as much again: the base's bytes are a glb's, the package's a
    // deflated one's.
    const uint64_t excess = tried.package.size() - max_bytes;
    const double target =
        double(std::min<uint64_t>(base_limit, tried.base_glb.size())) - 1.5 * double(excess) - 512;
    base_limit = uint64_t(std::max(1.0, target));  // 0 would mean no bound
    report_step(progress,
                format("package: %.1f kB over its bound (%.2f x model.glb) even where the "
                       "base's refinements end soonest: the base gives way, to %.1f kB",
                       double(excess) / 1e3, ratio, double(base_limit) / 1e3));
  }
}

}  // namespace meshmux
