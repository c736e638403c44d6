// The multiplexer (Yang, Shen and Kuo, "Progressive coding of 3D textured graphic model via
// joint mesh-texture optimization" §3): layers with their stream bytes, renders from the viewing
// sphere, distortion against the full-quality render, steepest descent and the baselines.
// Mesh-layer bytes are the stream's compact vertex splits (stream/mesh_stream.h).
#include "multiplex/multiplex.h"

#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iterator>
#include <map>
#include <memory>
#include <optional>

#include "core/parallel.h"
#include "image/kept_levels.h"
#include "multiplex/decode_ahead.h"
#include "multiplex/distortion.h"
#include "simplify/lod.h"
#include "stream/mesh_stream.h"

namespace meshmux {

namespace {
// The most cells evaluated in full for the per-view table (beyond, the client keeps the stored
// order where a cell is missing).
constexpr size_t kViewTableMaxCells = 96;
}  // namespace

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Estimated bytes of the vertices [v0, v1) and faces [f0, f1) of a progressive mesh: quantized
// vertices and faces through order-preserving codecs cost about 6 bytes per vertex and 1.5 per
// face (meshopt on the base, vertex splits on refinements). For sizing the layers and for the
// base; the refinement layers are costed by the package's own encoder below.
uint64_t chunk_bytes(uint32_t v0, uint32_t v1, uint32_t f0, uint32_t f1) {
  return uint64_t(v1 - v0) * 6 + (uint64_t(f1 - f0) * 3 + 1) / 2;
}

// Bytes to go from one selection to the next (previous == nullptr: the base from nothing).
uint64_t layer_bytes(const ProgressiveScene& ps, const LodSelection* previous,
                     const LodSelection& next) {
  uint64_t total = 0;
  for (size_t m = 0; m < ps.meshes.size(); ++m) {
    const ProgressiveMesh& pm = ps.meshes[m];
    const ProgressiveLevel& b = pm.levels[next.level[m]];
    uint32_t v0 = 0, f0 = 0;
    if (previous) {
      const ProgressiveLevel& a = pm.levels[previous->level[m]];
      v0 = a.vertex_end, f0 = a.face_end;
    }
    total += chunk_bytes(v0, b.vertex_end, f0, b.face_end);
  }
  return total;
}

// The level that ends the block run holding `level` (a block mesh's parts are whole blocks:
// stream/format.h "Blocks"), or `level` itself for a chain or at a run's end.
size_t block_run_end(const ProgressiveMesh& pm, size_t level) {
  if (pm.blocks.empty() || level == 0) return level;
  while (level + 1 < pm.levels.size() && pm.level_block[level] == pm.level_block[level - 1])
    ++level;
  return level;
}

// Encodes the mesh layers once (stream/mesh_stream.h): layer 0 is the base (its encoded
// vertices and faces stand for the base's bytes); each further layer's parts are what the
// package's mesh chunk holds. Fills r's mesh_streams, layer_parts, layer_chunks, mesh_bytes,
// layer_triangles, layer_levels and stream_digests, and nothing else of r; `layer_digests` gets
// per layer every mesh's state digest once the layer's parts are applied.
Status encode_layers(const ProgressiveScene& ps, const std::vector<LodSelection>& layers,
                     const LodSelection& base, EncodeCounts* counts, MultiplexResult& r,
                     std::vector<std::vector<uint32_t>>& layer_digests) {
  const int m = int(layers.size());
  std::vector<MeshStreamEncoder> encoders;
  encoders.reserve(ps.meshes.size());
  for (size_t i = 0; i < ps.meshes.size(); ++i) {
    encoders.emplace_back(ps.meshes[i], package_quantization(ps.meshes[i]), uint32_t(i),
                          base.level[i], counts);
    if (!encoders.back().status()) return encoders.back().status().with_prefix("multiplex");
    const ProgressiveMesh& pm = ps.meshes[i];
    MeshStreamBase head;
    head.vertices = uint32_t(pm.vertex_count()), head.faces = uint32_t(pm.face_count());
    head.base_vertices = pm.levels[base.level[i]].vertex_end;
    head.base_faces = pm.levels[base.level[i]].face_end;
    head.bounds = package_bounds(pm);
    head.normals = encoders.back().normals();
    head.quantization = package_quantization(pm);
    head.base_order = encoders.back().stream_order();
    head.base_primitive_faces = encoders.back().base_faces();
    head.blocks = encoders.back().stream_blocks();
    r.mesh_streams.push_back(std::move(head));
  }
  r.layer_parts.resize(size_t(m));
  r.layer_chunks.resize(size_t(m));
  // Each mesh's parts in layer order: the next one's plan (its split order and faces, a walk
  // of the record) is made on another core while this one is coded (the coding is serial:
  // it simulates the client part by part). The same parts, in the same order.
  using Plan = Result<MeshStreamEncoder::PartPlan>;
  std::vector<std::vector<size_t>> to_come(ps.meshes.size());  // per mesh: its levels ahead
  // A block mesh's parts are one block run each (the runs a layer holds, in turn).
  for (size_t i = 0; i < ps.meshes.size(); ++i)
    for (size_t k = 1, at = base.level[i]; k < size_t(m); ++k)
      while (layers[k].level[i] > at) {
        at = ps.meshes[i].blocks.empty()
                 ? layers[k].level[i]
                 : std::min(layers[k].level[i], block_run_end(ps.meshes[i], at + 1));
        to_come[i].push_back(at);
      }
  std::vector<size_t> next_part(ps.meshes.size(), 0);
  std::vector<std::optional<Plan>> planned(ps.meshes.size());           // made ahead
  std::vector<std::unique_ptr<Background>> planning(ps.meshes.size());  // making it
  const bool ahead = worker_threads() > 1;
  auto plan_of = [&](size_t i) -> Plan {  // mesh i's next part's plan, the one after begun
    if (planning[i]) planning[i]->wait(), planning[i].reset();
    Plan plan = planned[i] ? std::move(*planned[i]) : encoders[i].prepare(to_come[i][next_part[i]]);
    planned[i].reset();
    if (!plan.ok()) return plan;
    encoders[i].adopt(*plan);
    if (++next_part[i] < to_come[i].size() && ahead)
      planning[i] = std::make_unique<Background>([&, i, level = to_come[i][next_part[i]]] {
        planned[i].emplace(encoders[i].prepare(level));
      });
    return plan;
  };
  for (int k = 0; k < m; ++k) {
    uint64_t bytes = 0;
    if (k == 0) {
      bytes = layer_bytes(ps, nullptr, layers[0]);
    } else {
      for (size_t i = 0; i < ps.meshes.size(); ++i)
        while (layers[size_t(k)].level[i] > encoders[i].level()) {
          Plan plan = plan_of(i);
          if (!plan.ok()) return plan.status().with_prefix("multiplex");
          auto part = encoders[i].encode(plan.take());
          if (!part.ok()) return part.status().with_prefix("multiplex");
          r.layer_parts[size_t(k)].push_back(part.take());
        }
      r.layer_chunks[size_t(k)] = take_chunk_payload(r.layer_parts[size_t(k)]);
      bytes = r.layer_chunks[size_t(k)].size();
    }
    r.mesh_bytes.push_back(bytes);
    r.layer_triangles.push_back(uint32_t(selection_triangles(ps, layers[size_t(k)])));
    r.layer_levels.push_back(layers[size_t(k)].level);
    std::vector<uint32_t> digests;
    for (const MeshStreamEncoder& e : encoders) digests.push_back(state_digest(e.client()));
    layer_digests.push_back(std::move(digests));
    // Each part's working lists are freed into the allocator's heap, between arrays that stay
    // (the client state grows part by part): handed back to the OS here, or a 4M-triangle
    // record's encoding held ~200 MB of freed pages at its end (RSS 732 MB against 536).
    malloc_trim(0);
  }
  r.stream_digests = layer_digests.back();
  return Status::ok();
}

// The metric of images[v * sets + k] against reference[v], for every view v and set k but
// `skip` (-1: none), on every core: while it runs, llvmpipe's threads have nothing to draw.
double metric_of(const Distortion& d, DistortionMetric m) {
  return m == DistortionMetric::kMse ? d.mse : d.ciede2000;
}

std::vector<double> distortions(const std::vector<RenderImage>& reference,
                                const std::vector<RenderImage>& images, size_t sets, int skip,
                                DistortionMetric metric) {
  std::vector<double> out(images.size(), 0.0);
  parallel_chunks(images.size(), 1, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k)
      if (int(k % sets) != skip)
        out[k] = metric_of(measure_distortion(reference[k / sets], images[k]), metric);
  });
  return out;
}

// One map of a texture level as the stream carries it: the channel it stands for, a name for
// errors, and its encoded bytes, decoded just ahead of its upload (multiplex/decode_ahead.h: a
// few maps' texels are held at a time besides the renderer's).
struct LevelMap {
  std::string channel;  // empty for a kept image
  std::string name;
  const std::vector<uint8_t>* encoded = nullptr;
  std::string mime_type;
  int32_t image = -1;  // a kept image: the scene's image it stands for
};

// The maps of every level in level order, as upload_textures takes them.
std::vector<EncodedItem> level_map_items(const std::vector<std::vector<LevelMap>>& textures) {
  std::vector<EncodedItem> items;
  for (const std::vector<LevelMap>& level : textures)
    for (const LevelMap& map : level) items.push_back({map.name, map.encoded, map.mime_type});
  return items;
}

// Mesh layers: scene-wide selections from the base (layer 0) to the full detail (the last),
// as many as the refinement's bytes call for within the options' bounds.
std::vector<LodSelection> mesh_layers(const ProgressiveScene& ps, const LodSelection& base,
                                      const LodSelection& full, const MultiplexOptions& o) {
  uint64_t base_tris = selection_triangles(ps, base), full_tris = selection_triangles(ps, full);
  uint64_t refine_bytes = layer_bytes(ps, &base, full);
  int m = 1;
  if (full_tris > base_tris) {
    m = int(std::ceil(double(refine_bytes) / double(std::max<uint64_t>(1, o.layer_bytes))));
    m = std::clamp(m, o.min_mesh_layers, o.max_mesh_layers) + 1;
  }
  std::vector<LodSelection> layers{base};
  for (int k = 1; k < m; ++k) {
    // Geometric growth: layer k holds base·(full/base)^(k/(m-1)) triangles, so each batch
    // splits about the same share of the vertices held before it and a split's parent costs a
    // small gap (compressed progressive meshes' batches; linear steps made the late batches
    // split one vertex in ten, ~5 bits per parent).
    const double ratio = double(full_tris) / double(std::max<uint64_t>(base_tris, 1));
    LodSelection s =
        k == m - 1 ? full
                   : select_triangles(
                         ps, uint64_t(std::llround(double(std::max<uint64_t>(base_tris, 1)) *
                                                   std::pow(ratio, double(k) / double(m - 1)))));
    for (size_t i = 0; i < s.level.size(); ++i) {
      s.level[i] = std::max(s.level[i], layers.back().level[i]);  // refinements only add
      s.level[i] = block_run_end(ps.meshes[i], s.level[i]);
      s.instances[i] = full.instances[i];
    }
    layers.push_back(s);
  }
  return layers;
}

// Texture layers: the atlas's mip levels as the stream carries them (encoded upstream, decoded
// when uploaded to render what the client decodes). Per level: its maps, base colour first,
// each with the channel it stands for. Fills r's texture_channels, texture_bytes (one level of
// 0 bytes without textures), texture_levels_shipped and texture_levels_dropped.
std::vector<std::vector<LevelMap>> texture_layers(const TextureLevels& levels, MultiplexResult& r) {
  std::vector<std::vector<LevelMap>> textures;
  if (levels.levels.empty()) {
    r.texture_bytes.push_back(0);
    return textures;
  }
  for (const TextureLevel& l : levels.levels) {
    std::vector<LevelMap> maps;
    auto add = [&](const std::string& channel, const std::vector<uint8_t>& bytes,
                   const std::string& mime) {
      maps.push_back({channel, "level " + std::to_string(l.width) + " " + channel, &bytes, mime});
    };
    if (r.texture_channels.empty()) {
      r.texture_channels.push_back(kBaseColorChannel);
      for (const TextureMap& tm : l.other_maps) r.texture_channels.push_back(tm.channel);
    }
    add(kBaseColorChannel, l.encoded, l.mime_type);
    for (const TextureMap& tm : l.other_maps) add(tm.channel, tm.encoded, tm.mime_type);
    for (const KeptMap& km : l.kept)
      maps.push_back(
          {"", "level " + std::to_string(l.width) + " kept image " + std::to_string(km.image),
           &km.encoded, km.mime_type, km.image});
    // A level's cost is all its maps: the channels move together.
    uint64_t bytes = l.encoded.size();
    for (const TextureMap& tm : l.other_maps) bytes += tm.encoded.size();
    // The kept materials' images at the level's scale ride with it (image/kept_levels.h): their
    // bytes count, and the cells draw the kept materials with them.
    for (const KeptMap& km : l.kept) bytes += km.encoded.size();
    r.texture_bytes.push_back(bytes);
    r.texture_levels_shipped.push_back({uint64_t(l.width), uint64_t(l.height), bytes});
    textures.push_back(std::move(maps));
  }
  r.texture_levels_dropped = levels.dropped;
  return textures;
}

// Renders and measures the grid's cells (mesh layer i, texture level j) from every camera of
// the viewing sphere, against the references: the full mesh at the finest texture level. Each
// mesh layer is uploaded when first drawn; every render is counted in r.renders and reported
// to `progress`.
struct CellRenders {
  CellRenders(const ProgressiveScene& scene, const std::vector<LodSelection>& selections,
              int32_t texture_material, Renderer& renderer, MultiplexResult& result,
              Progress* report_to, DistortionMetric measure)
      : ps(scene),
        streamed_material(texture_material),
        gl(renderer),
        r(result),
        progress(report_to),
        m(int(selections.size())),
        n(int(result.texture_bytes.size())),
        geometry(size_t(m), -1),
        measured(size_t(m) * size_t(n)),
        drawn(selections),
        metric(measure) {
    for (int i = 0; i < m; ++i) same.push_back(i);
  }

  // Renders on a cut (MultiplexOptions::cut_renders_above): each layer is drawn no finer than
  // `cut` (per mesh the coarser of the two levels), where the finer levels' detail is below a
  // pixel of every view; layers that draw the same selection share their renders and values
  // (the cells of layer i are those of same[i]).
  void draw_no_finer_than(const LodSelection& cut) {
    for (int i = 0; i < m; ++i) {
      LodSelection& d = drawn[size_t(i)];
      for (size_t k = 0; k < d.level.size(); ++k) d.level[k] = std::min(d.level[k], cut.level[k]);
      same[size_t(i)] = i;
      for (int e = 0; e < i; ++e)
        if (drawn[size_t(e)].level == d.level && drawn[size_t(e)].instances == d.instances) {
          same[size_t(i)] = e;
          break;
        }
    }
  }

  // The sampler the streamed material samples its base colour with (every channel of the atlas
  // shares it, atlas/atlas.cpp merged_material); clamped without one.
  Sampler atlas_sampler() const {
    Sampler clamped;
    clamped.wrap_s = clamped.wrap_t = Wrap::kClampToEdge;
    if (streamed_material < 0 || size_t(streamed_material) >= ps.scene.materials.size())
      return clamped;
    const TextureRef& t = ps.scene.materials[size_t(streamed_material)].base_color;
    return t.present() ? t.sampler : clamped;
  }

  // The sampler of the first texture reference (material order, base colour first) that
  // samples a kept image; clamped if none does.
  Sampler sampler_of(int32_t image) const {
    for (const Material& m : ps.scene.materials)
      for (const TextureRef* t : texture_refs(m))
        if (t->present() && t->image == image) return t->sampler;
    Sampler clamped;
    clamped.wrap_s = clamped.wrap_t = Wrap::kClampToEdge;
    return clamped;
  }

  // Uploads every level's maps in level order, as `decoded` (DecodeAhead over level_map_items
  // of `textures`) hands them over: what the client decodes, JPEG losses included; the upload,
  // mipmaps included, runs on the renderer's thread. A level's kept images are the last map of
  // each at that level or below (a level carries one only where its size changes).
  Status upload_textures(const std::vector<std::vector<LevelMap>>& textures, DecodeAhead& decoded) {
    texture.resize(textures.size());
    std::map<int32_t, int> kept;  // kept image → its handle so far
    size_t level = 0;             // the level whose kept images are assigned next
    size_t k = 0;                 // the map's place in level order
    for (size_t j = 0; j < textures.size(); ++j)
      for (const LevelMap& map : textures[j]) {
        Result<Image> image = decoded.take(k++);
        for (; level < j; ++level) texture[level].kept.assign(kept.begin(), kept.end());
        if (!image.ok()) return image.status().with_prefix("multiplex");
        upload_map(map, *image, texture[j], kept);
      }
    for (; level < textures.size(); ++level) texture[level].kept.assign(kept.begin(), kept.end());
    return Status::ok();
  }

  // One decoded map uploaded: a kept image's handle into `kept`, a channel's into its slot.
  void upload_map(const LevelMap& map, const Image& image, TextureSet& set,
                  std::map<int32_t, int>& kept) {
    if (map.image >= 0) {
      const Sampler smp = sampler_of(map.image);
      kept[map.image] =
          gl.add_texture(image, kept_image_filter(ps.scene, map.image) == TexelFilter::kSrgb,
                         smp.wrap_s, smp.wrap_t);
      return;
    }
    // Each channel's slot in the set and whether its texels are sRGB colour, by Channel.
    struct Slot {
      int TextureSet::*field;
      bool srgb;
    };
    static constexpr Slot kSlots[] = {{&TextureSet::base_color, true},
                                      {&TextureSet::normal, false},
                                      {&TextureSet::orm, false},
                                      {&TextureSet::emissive, true},
                                      {&TextureSet::sheen, true}};
    static_assert(std::size(kSlots) == kChannelNames.size());
    if (std::optional<Channel> c = parse_channel(map.channel)) {
      const Slot& slot = kSlots[size_t(*c)];
      const Sampler smp = atlas_sampler();
      set.*slot.field = gl.add_texture(image, slot.srgb, smp.wrap_s, smp.wrap_t);
    }
  }

  // One camera per direction of the viewing sphere, each framing the full detail.
  void place_cameras(const ViewingSphere& sphere, const LodSelection& full,
                     const RenderOptions& render, const ViewOptions& views) {
    Bounds box = selection_bounds(ps, full);  // materializing the full detail: 640 MB at 20M
    r.bounds = box;
    float aspect = float(render.width) / float(std::max(1, render.height));
    for (Vec3 d : sphere.directions) cameras.push_back(camera_for(d, box, aspect, views));
    r.views = cameras.size();
    most_renders = double(cameras.size()) * (double(m) * double(n) + 1);
  }

  // Every cell of the given rows (mesh layers) from every view, each mesh layer once for every
  // view and texture level: one depth pass per view, the passes pipelined (Renderer::render
  // with sets and cameras). The full mesh goes first, its last level giving the references;
  // `after_references` runs then (the rows may be known only by then). The descent then reads
  // the stored metrics, exactly what rendering cell by cell gives.
  void render_grid(const std::function<std::vector<int>()>& after_references) {
    const int top = same[size_t(m - 1)];
    render_row(top);
    const std::vector<int> rows = after_references();
    std::vector<char> done(size_t(m), 0);
    done[size_t(top)] = 1;
    for (auto it = rows.rbegin(); it != rows.rend(); ++it)
      if (!done[size_t(same[size_t(*it)])]) {
        done[size_t(same[size_t(*it)])] = 1;
        render_row(same[size_t(*it)]);
      }
  }

  // Mesh layer i with every texture level, from every view (the last layer: the references).
  void render_row(int i) {
    const size_t V = cameras.size();
    std::vector<TextureSet> sets;
    for (int j = 0; j < n; ++j) sets.push_back(texture_of(j));
    std::vector<RenderImage> images = gl.render(geometry_of(i), sets, cameras);
    const bool top = i == same[size_t(m - 1)];
    if (top) {
      for (size_t v = 0; v < V; ++v)
        reference.push_back(std::move(images[v * size_t(n) + size_t(n - 1)]));
      r.renders += V;
    }
    const std::vector<double> values =
        distortions(reference, images, size_t(n), top ? n - 1 : -1, metric);
    for (int j = 0; j < n; ++j) {
      if (top && j == n - 1) continue;  // the reference itself: distortion 0
      std::vector<double>& per_view = measured[size_t(i) * size_t(n) + size_t(j)];
      for (size_t v = 0; v < V; ++v) per_view.push_back(values[v * size_t(n) + size_t(j)]);
      r.renders += V;
    }
    report();
  }

  // The references alone; the other cells are rendered as the descent asks for them.
  void render_references() {
    reference = gl.render(geometry_of(m - 1), {texture_of(n - 1)}, cameras);
    r.renders += cameras.size();
    report();
  }

  // Nothing shown yet: blank frames against the references (r.empty_distortion).
  void measure_blank_frames() {
    for (const RenderImage& ref : reference) {
      RenderImage blank;
      blank.width = ref.width;
      blank.height = ref.height;
      blank.rgba.assign(ref.rgba.size(), 0);
      blank.coverage.assign(ref.coverage.size(), 0);
      r.empty_distortion +=
          metric_of(measure_distortion(ref, blank), metric) / double(reference.size());
    }
  }

  // The distortion of cell (i, j), the mean over the views, with the per-view values written to
  // `per_view` (when not null); rendered now unless measured up front or asked for before.
  double distortion(int i, int j, std::vector<double>* per_view_out) {
    const size_t V = cameras.size();
    std::vector<double> scratch;
    std::vector<double>& per_view = per_view_out ? *per_view_out : scratch;
    per_view.assign(cameras.size(), 0.0);
    i = same[size_t(i)];
    if (i == same[size_t(m - 1)] && j == n - 1) return 0.0;
    std::vector<double>& stored = measured[size_t(i) * size_t(n) + size_t(j)];
    if (stored.empty()) {
      const std::vector<RenderImage> images = gl.render(geometry_of(i), {texture_of(j)}, cameras);
      stored = distortions(reference, images, 1, -1, metric);
      r.renders += V;
      report();
    }
    double sum = 0;
    for (size_t v = 0; v < V; ++v) sum += per_view[v] = stored[v];
    return sum / double(V);
  }

  // Mesh layer i's geometry handle, uploaded on first use.
  int geometry_of(int i) {
    i = same[size_t(i)];
    if (geometry[size_t(i)] < 0)
      geometry[size_t(i)] =
          gl.add_geometry(materialize(ps, drawn[size_t(i)], false, /*with_images=*/false), false,
                          streamed_material);
    return geometry[size_t(i)];
  }
  // Texture level j's maps (an empty set without textures).
  TextureSet texture_of(int j) const { return texture.empty() ? TextureSet{} : texture[size_t(j)]; }
  void report() { report_fraction(progress, double(r.renders) / most_renders); }

  const ProgressiveScene& ps;
  const int32_t streamed_material;  // the material the texture levels stream (TextureLevels)
  Renderer& gl;
  MultiplexResult& r;
  Progress* progress;
  const int m;                      // mesh layers
  const int n;                      // texture levels (one without textures)
  std::vector<TextureSet> texture;  // per texture level (none without textures)
  std::vector<Camera> cameras;
  double most_renders = 0;                    // renders if every cell is rendered
  std::vector<int> geometry;                  // per mesh layer: its handle, -1 until drawn
  std::vector<std::vector<double>> measured;  // per cell: per view
  std::vector<RenderImage> reference;         // per view
  std::vector<LodSelection> drawn;            // per mesh layer: what its renders draw
  DistortionMetric metric;                    // what a cell's distortion is
  std::vector<int> same;  // per mesh layer: the first layer drawing the same selection
};

// The geometric error a display pixel stands for, in the record's units (fractions of the
// scene's diagonal: world units × normalization_scale): the world extent of one display pixel
// (an image pixel over render.display_scale) at the nearest point of the bounding sphere, the
// smallest over the cameras (each framing the sphere alike, so they agree).
double pixel_error(const std::vector<Camera>& cameras, const Bounds& box,
                   const RenderOptions& render, double normalization_scale) {
  const double radius = 0.5 * double(box.diagonal());
  const double pixels = double(std::max(1, render.height)) * std::max(1.0f, render.display_scale);
  double best = INFINITY;
  for (const Camera& c : cameras) {
    const double near = std::max(double(length(c.eye - c.target)) - radius, 1e-9);
    const double tan_half = std::tan(double(c.fov_y_degrees) * 3.14159265358979323846 / 360.0);
    best = std::min(best, 2 * near * tan_half / pixels);
  }
  return best * (normalization_scale > 0 ? normalization_scale : 1.0);
}

// Descent and baselines: the steepest descent over the grid (the order the stream ships), the
// fixed orders it is compared with, and where a choice exists on a small grid, every cell for
// the per-view table. The grid's row i is mesh layer rows[i] of the renders (the completion's
// row draws the full mesh); r.mesh_bytes has one entry per row. Fills r's rd, and unless
// `descent_only` (a descent that only places the completion), the baselines' paths, the view
// table and the cell counts.
void descend(CellRenders& cells, const std::vector<int>& rows, MultiplexResult& r,
             bool descent_only = false) {
  const int m = int(rows.size()), n = cells.n;
  r.view_table.mesh_layers = m;
  r.view_table.texture_layers = n;
  r.view_table.cells.assign(size_t(m) * size_t(n), {});
  RdGrid grid;
  grid.mesh_bytes = r.mesh_bytes;
  grid.texture_bytes = r.texture_bytes;
  grid.distortion = [&](int i, int j) {
    return cells.distortion(rows[size_t(i)], j,
                            &r.view_table.cells[size_t(i) * size_t(n) + size_t(j)]);
  };
  RdCache cache(grid);
  r.rd = steepest_descent(cache);
  if (descent_only) return;
  r.cells_descent = cache.evaluated();
  r.mesh_first = mesh_first(cache);
  r.texture_first = texture_first(cache);
  r.constant_ratio = constant_ratio(cache);
  // Where a choice exists (mesh layers and texture levels), every cell: a client re-plans the
  // order for its own camera from any cell. Small grids are already complete here.
  if (m > 1 && n > 1 && size_t(m) * size_t(n) <= kViewTableMaxCells)
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < n; ++j) cache.at(i, j);
  r.cells_evaluated = cache.evaluated();
  r.cells_total = size_t(m) * size_t(n);
}

// The package's header and table, estimated: the fixed fields, an entry per chunk and the
// per-view table (a number per view and cell, deflated).
uint64_t table_estimate(size_t chunks, size_t views, size_t cells) {
  return kPackageHeaderBytes + 2048 + 96 * uint64_t(chunks) +
         4 * uint64_t(views) * std::min(cells, kViewTableMaxCells);
}

// The completion step (stream/format.h "Completion") by bytes alone, known once the mesh layers
// are encoded and before any cell but the references is rendered: when the package with every
// mesh layer would be over bound.max_bytes, the chain of splits ends after layer k and the
// completion (every mesh not yet full at k, single-rate) follows; k is the latest layer that
// keeps the bound (where none does, the base, if that makes the package smaller). Fills r's
// completion report's chain figures and, where unused, why not.
struct CompletionCut {
  bool used = false;
  size_t k = 0;                        // the chain of splits ends after layer k
  std::vector<uint32_t> refined;       // meshes the chain refines past the base
  std::vector<CompletionMesh> meshes;  // their completions, in that order
  uint64_t fixed = 0, textures = 0;    // the package's bytes besides mesh chunks and table
  std::vector<uint64_t> chain;         // splits up to layer k
  size_t texture_levels = 0;           // n
  size_t views = 0;
  // The completion's bytes after layer k (its meshes not yet full there).
  uint64_t completion_bytes(const std::vector<LodSelection>& layers, size_t k) const {
    uint64_t b = 0;
    for (size_t c = 0; c < refined.size(); ++c)
      if (layers[k].level[refined[c]] < layers.back().level[refined[c]]) b += meshes[c].data.size();
    return b;
  }
  // The package as planned with the completion after layer k (header and table estimated).
  uint64_t planned(const std::vector<LodSelection>& layers, size_t k) const {
    return fixed + textures + chain[k] + completion_bytes(layers, k) +
           table_estimate(k + 1 + texture_levels - 1, views, (k + 2) * texture_levels);
  }
};

Result<CompletionCut> cut_completion(const std::vector<LodSelection>& layers,
                                     const PackageBound& bound, MultiplexResult& r) {
  CompletionCut cut;
  const size_t m = layers.size(), n = r.texture_bytes.size();
  if (m < 3 || !bound.fixed_bytes || !bound.completion) return cut;
  auto fixed = bound.fixed_bytes(r.mesh_streams);
  if (!fixed.ok()) return fixed.status().with_prefix("multiplex: completion");
  cut.fixed = *fixed;
  cut.texture_levels = n;
  cut.views = r.views;
  for (size_t j = 1; j < n; ++j) cut.textures += r.texture_bytes[j];
  cut.chain.assign(m, 0);
  for (size_t k = 1; k < m; ++k) cut.chain[k] = cut.chain[k - 1] + r.mesh_bytes[k];
  const uint64_t whole =
      cut.fixed + cut.textures + cut.chain[m - 1] + table_estimate(m - 1 + n - 1, r.views, m * n);
  CompletionReport& cr = r.completion_report;
  cr.chain_layers = m;
  cr.chain_bytes = whole;
  if (whole <= bound.max_bytes) return cut;
  for (size_t i = 0; i < layers[0].level.size(); ++i)
    if (layers[0].level[i] < layers[m - 1].level[i]) cut.refined.push_back(uint32_t(i));
  auto meshes = bound.completion(cut.refined);
  if (!meshes.ok()) return meshes.status().with_prefix("multiplex: completion");
  if (meshes->size() != cut.refined.size())
    return Status::error("multiplex: completion: one bitstream per mesh expected",
                         ErrorKind::kInternal);
  cut.meshes = meshes.take();
  size_t k = m;  // none yet
  for (size_t c = m - 1; c-- > 0;)
    if (cut.planned(layers, c) <= bound.max_bytes) {
      k = c, cr.why = "bound";
      break;
    }
  if (k == m) {  // no layer keeps the bound: the smaller package
    if (cut.planned(layers, 0) >= whole) {
      cr.why = "over the bound, and no smaller with it";
      return cut;
    }
    k = 0, cr.why = "bound";
  }
  cut.used = true;
  cut.k = k;
  return cut;
}

// The completion placed (after cut_completion found it needed): at the cut's layer k, or
// earlier where the descent over every split (r.rd) takes a mesh step whose slope the
// completion beats from the same state (distortion drop per byte: D(i, j) − D(i + 1, j) over
// the layer's bytes against D(i, j) − D(full, j) over the completion's; `cell` gives D over the
// renders' layers). Rewrites r's layer vectors (layers k + 1 … m − 2 dropped, the last layer the
// completion), its stream digests, completion and report; returns the grid's rows as mesh
// layers of the renders (the completion's row is the full mesh, m − 1).
std::vector<int> place_completion(const std::vector<LodSelection>& layers, CompletionCut& cut,
                                  const std::vector<std::vector<uint32_t>>& layer_digests,
                                  const std::function<double(int, int)>& cell, MultiplexResult& r) {
  const size_t m = layers.size();
  CompletionReport& cr = r.completion_report;
  size_t k = cut.k;
  // The descent's mesh steps before k: the first whose slope the completion beats.
  for (size_t s = 1; s < r.rd.cells.size(); ++s) {
    const auto [i0, j0] = r.rd.cells[s - 1];
    const auto [i1, j1] = r.rd.cells[s];
    if (i1 != i0 + 1 || size_t(i0) >= k) continue;
    const double here = r.rd.distortion[s - 1];
    const double step =
        (here - r.rd.distortion[s]) / double(std::max<uint64_t>(1, r.mesh_bytes[size_t(i1)]));
    const double full = cell(int(m - 1), j0);
    const double jump =
        (here - full) / double(std::max<uint64_t>(1, cut.completion_bytes(layers, size_t(i0))));
    if (jump > step) {
      k = size_t(i0), cr.why = "slope";
      break;
    }
  }
  cr.used = true;
  cr.after_layer = k;
  cr.bytes = cut.completion_bytes(layers, k);
  cr.tail_bytes = cut.chain[m - 1] - cut.chain[k];
  cr.planned_bytes = cut.planned(layers, k);
  std::vector<uint8_t> payload;
  for (size_t c = 0; c < cut.refined.size(); ++c)
    if (layers[k].level[cut.refined[c]] < layers[m - 1].level[cut.refined[c]]) {
      CompletionMesh& cm = cut.meshes[c];
      payload.insert(payload.end(), cm.data.begin(), cm.data.end());
      r.completion.push_back(std::move(cm));
    }
  const uint32_t full_triangles = r.layer_triangles.back();
  const std::vector<size_t> full_levels = r.layer_levels.back();
  r.mesh_bytes.resize(k + 1);
  r.layer_parts.resize(k + 1);
  r.layer_chunks.resize(k + 1);
  r.layer_triangles.resize(k + 1);
  r.layer_levels.resize(k + 1);
  r.mesh_bytes.push_back(payload.size());
  r.layer_parts.emplace_back();
  r.layer_chunks.push_back(std::move(payload));
  r.layer_triangles.push_back(full_triangles);
  r.layer_levels.push_back(full_levels);
  r.stream_digests = layer_digests[k];
  std::vector<int> rows;
  for (size_t i = 0; i <= k; ++i) rows.push_back(int(i));
  rows.push_back(int(m - 1));
  return rows;
}

}  // namespace

Result<MultiplexResult> multiplex(const ProgressiveScene& ps, const TextureLevels& levels,
                                  const MultiplexOptions& o, Progress* progress,
                                  const PackageBound* bound) {
  auto start = Clock::now();
  MultiplexResult r;
  const LodSelection base = select_base(ps), full = select_full(ps);
  const std::vector<LodSelection> layers = mesh_layers(ps, base, full, o);
  const int m = int(layers.size());
  // The layers' stream bytes are encoded on a thread of their own while the renders below run
  // (they need only the selections); the descent waits for them.
  Status encoded;
  std::vector<std::vector<uint32_t>> layer_digests;  // per layer, per mesh
  Background encoder([&] {
    const auto t = Clock::now();
    encoded = encode_layers(ps, layers, base, o.counts, r, layer_digests);
    r.seconds_layers = since(t);
  });
  const std::vector<std::vector<LevelMap>> textures = texture_layers(levels, r);
  const int n = int(r.texture_bytes.size());
  // The maps' decoding starts now, beside the renderer's set-up and the uploads.
  DecodeAhead decoded(level_map_items(textures));

  // Renders: the texture levels uploaded, the cameras placed, then the references and, where
  // every cell will be evaluated anyway (a grid of one row or column, whose descent walks it
  // all, or a small grid, which descend completes for the per-view table), every cell up front.
  // A grid of one row or column has one order whatever the renders say: asked to
  // (MultiplexOptions::forced_view_layers ≥ 0, off by default), they measure its curve from
  // fewer views on smaller images.
  const bool forced = (m == 1 || n == 1) && o.forced_view_layers >= 0;
  RenderOptions render = o.render;
  if (forced) render.width = render.height = std::max(16, o.forced_image_size);
  // Both are framed alike (the bounding sphere spans a fraction of the smaller side).
  if (o.display_width > 0 && o.display_height > 0)
    render.display_scale = float(std::min(o.display_width, o.display_height)) /
                           float(std::max(1, std::min(render.width, render.height)));
  auto renderer = Renderer::create(render);
  if (!renderer.ok()) return renderer.status();
  // Render time counts the texture levels' decoding and upload (it used to be spread over the
  // layers' time and the first renders).
  auto render_start = Clock::now();
  r.metric = metric_name(o.metric);
  CellRenders cells(ps, layers, levels.material, **renderer, r, progress, o.metric);
  if (Status s = cells.upload_textures(textures, decoded); !s) return s;
  ViewingSphere sphere = viewing_sphere(forced ? o.forced_view_layers : o.view_layers);
  cells.place_cameras(sphere, full, render, o.views);
  r.cut_triangles = selection_triangles(ps, full);
  if (r.cut_triangles > o.cut_renders_above && !cells.cameras.empty()) {
    const LodSelection cut = select_error(
        ps, float(pixel_error(cells.cameras, r.bounds, render, ps.scene.normalization_scale)));
    r.cut_error = cut.error;
    cells.draw_no_finer_than(cut);
    r.cut_triangles = selection_triangles(ps, cells.drawn.back());
  }
  // Once the layers are encoded, the completion's cut by bytes: the rows past it (but the full
  // mesh's) are never shipped, so only the descent over every split visits them, lazily.
  CompletionCut cut;
  auto encode_and_cut = [&]() -> Status {
    encoder.wait();
    if (!encoded) return encoded;
    if (!bound || bound->max_bytes == 0) return Status::ok();
    auto c = cut_completion(layers, *bound, r);
    if (!c.ok()) return c.status();
    cut = c.take();
    return Status::ok();
  };
  std::vector<int> rows(static_cast<size_t>(m), 0);
  for (int i = 0; i < m; ++i) rows[size_t(i)] = i;
  Status encoded_and_cut;
  if (m == 1 || n == 1 || size_t(m) * size_t(n) <= kViewTableMaxCells) {
    cells.render_grid([&] {
      encoded_and_cut = encode_and_cut();
      if (!encoded_and_cut || !cut.used) return rows;
      std::vector<int> kept(rows.begin(), rows.begin() + std::ptrdiff_t(cut.k) + 1);
      kept.push_back(m - 1);
      return kept;
    });
  } else {
    cells.render_references();
    encoded_and_cut = encode_and_cut();
  }
  if (!encoded_and_cut) return encoded_and_cut;
  cells.measure_blank_frames();
  r.view_table.directions = sphere.directions;
  r.view_table.triangles = sphere.triangles;

  if (!cut.used) {
    descend(cells, rows, r);
  } else {
    // The descent over every split places the completion; then the order with it, and what it
    // cost against the chain's (the same views; a cell is measured once, whichever grid asks).
    descend(cells, rows, r, /*descent_only=*/true);
    r.completion_report.chain_area = area_under(r.rd);
    auto cell = [&](int i, int j) { return cells.distortion(i, j, nullptr); };
    descend(cells, place_completion(layers, cut, layer_digests, cell, r), r);
    r.completion_report.area = area_under(r.rd);
  }
  r.seconds_render = since(render_start);
  r.seconds_total = since(start);
  return r;
}

}  // namespace meshmux
