// Instance-aware progressive simplification.
// - Azim, Cheslack-Postava and Levis, "Instance-aware simplification of 3D polygonal meshes"
//   (IAS) §3.2: vertex quadrics summed over instance transforms (equation 5), boundary
//   constraint planes weighted by edge length, no vanishing submeshes, the < 1.75
//   instances-per-submesh flatten fallback (§4).
// - Hoppe, "Octaviewer: spherically parameterized progressive meshes": half-edge collapses
//   only, so every level is a prefix of one vertex buffer with a parent per vertex; seam
//   duplicates collapse together (no cracks).
// - Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D models for
//   interactive metaverses" §4.5: the base level stops at log(1+E)/log(1+Emax) ≥ 0.9
//   (formula 1); small models ship whole.
// - Attribute terms after Hoppe 1999 ("New quadric metric for simplifying meshes with
//   appearance attributes"): per face, each attribute channel is a linear function of position
//   over the face; its squared deviation, area-weighted, is folded into the wedge's quadric.
//
// The collapse loop runs in passes (Simplifier::run): the positions whose neighbourhood changed
// re-costed on every core, the cheapest independent collapses applied, in a unit put in
// spatial order first (spatial_order). This keeps the work near O(T log T), the memory reads
// mostly local, and the result deterministic.
#include "simplify/simplify.h"

#include <malloc.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <mutex>
#include <optional>
#include <stdexcept>

#include "clean/flatten.h"
#include "core/key_table.h"
#include "core/parallel.h"
#include "scene/dvec3.h"
#include "scene/position_key.h"
#include "simplify/simplifier.h"

namespace meshmux {

using namespace simplify_detail;

namespace {

// Morton code of a point quantized to 21 bits per axis inside `lo` + [0, extent).
uint64_t morton(const DVec3& p, const DVec3& lo, double scale) {
  auto spread = [](uint64_t v) {
    v &= 0x1FFFFF;
    v = (v | v << 32) & 0x1F00000000FFFFull;
    v = (v | v << 16) & 0x1F0000FF0000FFull;
    v = (v | v << 8) & 0x100F00F00F00F00Full;
    v = (v | v << 4) & 0x10C30C30C30C30C3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
  };
  auto q = [&](double x, double l) {
    double t = (x - l) * scale;
    return uint64_t(std::clamp(t, 0.0, 2097151.0));
  };
  return spread(q(p.x, lo.x)) | spread(q(p.y, lo.y)) << 1 | spread(q(p.z, lo.z)) << 2;
}

// Puts the unit in spatial order: positions along a Morton curve, wedges by position, faces by
// their first position in that order. The collapse loop reads a position's faces, their
// corners, the neighbours' quadrics and wedges: in the source's order (a scan's shuffled
// vertices and triangles) nearly every read is a cache miss; in spatial order the neighbours
// are near in memory. What the loop decides depends on the numbering only through ties, the
// order a pass applies its collapses in (a refusal caused by a neighbour applied earlier) and
// the rounding of the quadric sums: the same input in another order gives a record of the same
// quality, not the same bytes.
// Moves v's items (`width` values each) so that item i lands at dest[i] (a permutation): into a
// fresh array, the old one freed at once (each array's copy is held alone, not beside the
// others'). O(items · width).
template <typename T>
void permute(std::vector<T>& v, size_t width, const std::vector<uint32_t>& dest) {
  if (v.empty()) return;
  std::vector<T> out(v.size());
  for (size_t i = 0; i < dest.size(); ++i)
    std::copy_n(v.begin() + std::ptrdiff_t(i * width), width,
                out.begin() + std::ptrdiff_t(size_t(dest[i]) * width));
  v.swap(out);
}

void spatial_order(Unit& u) {
  const size_t np = u.pos.size(), nw = u.wedge_pos.size(), nf = u.corners.size() / 3;
  const size_t k = size_t(u.channels);
  DVec3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (const DVec3& p : u.pos) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  const double scale = extent > 0 && std::isfinite(extent) ? 2097151.0 / extent : 0.0;
  std::vector<uint32_t> new_pos(np);
  {
    std::vector<std::pair<uint64_t, uint32_t>> keyed(np);
    for (uint32_t p = 0; p < np; ++p) keyed[p] = {morton(u.pos[p], lo, scale), p};
    std::sort(keyed.begin(), keyed.end());
    for (uint32_t i = 0; i < np; ++i) new_pos[keyed[i].second] = i;
  }
  permute(u.pos, 1, new_pos);
  // Wedges by (new position, old index): a counting sort.
  std::vector<uint32_t> start(np + 1, 0);
  for (uint32_t w = 0; w < nw; ++w) ++start[new_pos[u.wedge_pos[w]] + 1];
  for (size_t p = 0; p < np; ++p) start[p + 1] += start[p];
  std::vector<uint32_t> new_wedge(nw);
  for (uint32_t w = 0; w < nw; ++w) new_wedge[w] = start[new_pos[u.wedge_pos[w]]]++;
  for (uint32_t& p : u.wedge_pos) p = new_pos[p];
  std::vector<uint32_t>().swap(new_pos);
  permute(u.wedge_pos, 1, new_wedge);
  permute(u.wedge_group, 1, new_wedge);
  permute(u.wedge_prim, 1, new_wedge);
  permute(u.wedge_vertex, 1, new_wedge);
  permute(u.wedge_normal, 1, new_wedge);
  permute(u.attr, k, new_wedge);
  // Faces by their smallest new position (a counting sort, stable).
  for (uint32_t& c : u.corners) c = new_wedge[c];
  std::vector<uint32_t>().swap(new_wedge);
  std::fill(start.begin(), start.end(), 0);
  std::vector<uint32_t> face_to(nf);  // each face's key, then its place
  for (size_t f = 0; f < nf; ++f) {
    face_to[f] = std::min({u.wedge_pos[u.corners[3 * f]], u.wedge_pos[u.corners[3 * f + 1]],
                           u.wedge_pos[u.corners[3 * f + 2]]});
    ++start[face_to[f] + 1];
  }
  for (size_t p = 0; p < np; ++p) start[p + 1] += start[p];
  for (size_t f = 0; f < nf; ++f) face_to[f] = start[face_to[f]]++;
  permute(u.corners, 3, face_to);
  permute(u.face_prim, 1, face_to);
}

// Each wedge's class (Unit::wedge_group): wedges at one position, of one primitive, whose
// attributes but the normal are the same values (bit for bit, NaN never), numbered in the order
// of their first wedge. Found among the earlier wedges at the wedge's own position (a few),
// through lists of wedges per position: 8 bytes per wedge, where a table keyed by the
// attributes held 24-48 beside the position table (800 MB for both at 20M triangles).
void wedge_classes(Unit& u) {
  const size_t np = u.pos.size(), nw = u.wedge_pos.size(), k = size_t(u.channels);
  const size_t skip = u.normals ? 3 : 0;
  std::vector<uint32_t> start(np + 1, 0), at(nw);  // wedges per position, in wedge order
  for (uint32_t w = 0; w < nw; ++w) ++start[u.wedge_pos[w] + 1];
  for (size_t p = 0; p < np; ++p) start[p + 1] += start[p];
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t w = 0; w < nw; ++w) at[fill[u.wedge_pos[w]]++] = w;
  }
  auto same_value = [](float a, float b) {
    return a == b && std::memcmp(&a, &b, sizeof(float)) == 0;
  };
  auto same_class = [&](uint32_t e, uint32_t w) {
    bool same = u.prim_of_wedge(e) == u.prim_of_wedge(w);
    for (size_t c = skip; c < k && same; ++c)
      same = same_value(u.attr[e * k + c], u.attr[w * k + c]);
    return same;
  };
  // First each wedge's first wedge of its class (an earlier one at its position, or itself):
  // compared with the earlier classes' first wedges, or, where a position has many wedges (a
  // pole where hundreds of uv seams meet), looked up by their values' hash.
  constexpr uint32_t kScanned = 32;
  u.wedge_group.assign(nw, 0);
  std::vector<uint32_t> firsts;
  for (size_t p = 0; p < np; ++p) {
    const uint32_t n = start[p + 1] - start[p];
    std::optional<KeyTable> by_value;
    if (n > kScanned) by_value.emplace(n);
    firsts.clear();
    for (uint32_t i = start[p]; i < start[p + 1]; ++i) {
      const uint32_t w = at[i];
      uint32_t first = KeyTable::kEmpty;
      if (by_value) {
        uint64_t h = (uint64_t(u.prim_of_wedge(w)) + 1) * 0xD6E8FEB86659FD93ull;
        for (size_t c = skip; c < k; ++c) {
          uint32_t b;
          std::memcpy(&b, &u.attr[w * k + c], 4);
          h = (h ^ b) * 0x100000001B3ull;
        }
        first = by_value->find(h, [&](uint32_t e) { return same_class(e, w); });
        if (first == KeyTable::kEmpty) by_value->insert(h, w);
      } else {
        for (size_t j = 0; j < firsts.size() && first == KeyTable::kEmpty; ++j)
          if (same_class(firsts[j], w)) first = firsts[j];
        if (first == KeyTable::kEmpty) firsts.push_back(w);
      }
      u.wedge_group[w] = first == KeyTable::kEmpty ? w : first;
    }
  }
  // ... then the classes numbered in wedge order (a first wedge comes before its class's others).
  uint32_t groups = 0;
  for (uint32_t w = 0; w < nw; ++w)
    u.wedge_group[w] = u.wedge_group[w] == w ? groups++ : u.wedge_group[u.wedge_group[w]];
}

// Builds the simplification unit for one mesh: wedges = the primitives' vertices, positions
// welded exactly, attribute classes (position + everything but the normal) for wedge mapping.
Unit make_unit(const Mesh& mesh, const SimplifyOptions& opt) {
  Unit u;
  size_t uv_sets = 0;
  bool colors = false, normals = true;
  for (const Primitive& p : mesh.primitives) {
    uv_sets = std::max(uv_sets, p.uvs.size());
    colors = colors || !p.colors.empty();
    normals = normals && !p.normals.empty();
  }
  u.channels = int((normals ? 3 : 0) + 2 * uv_sets + (colors ? 4 : 0));
  u.normals = normals;
  size_t wedges = 0, corners = 0;
  for (const Primitive& p : mesh.primitives)
    wedges += p.vertex_count(), corners += p.indices.size();
  // Sized once: grown by doubling, a 4M-triangle scan's arrays held up to twice their size and
  // both copies while moving, at the stage's peak (with the table below).
  // One primitive (a scan, most big meshes) keeps no primitive per wedge and face: 120 MB at
  // 20M triangles.
  const bool many = mesh.primitives.size() > 1;
  u.wedge_pos.reserve(wedges), u.wedge_vertex.reserve(wedges);
  if (many) u.wedge_prim.reserve(wedges), u.face_prim.reserve(corners / 3);
  u.attr.reserve(wedges * size_t(u.channels));
  if (normals) u.wedge_normal.reserve(wedges);
  u.corners.reserve(corners);
  u.pos.reserve(wedges);  // at most one position per wedge (grown by doubling: 400 MB at 20M)
  {  // the table goes before the classes' lists and spatial_order's arrays come
    KeyTable pos_of(wedges);  // position hash → positions
    for (uint32_t pi = 0; pi < mesh.primitives.size(); ++pi) {
      const Primitive& p = mesh.primitives[pi];
      const uint32_t first = uint32_t(u.wedge_pos.size());
      for (size_t v = 0; v < p.vertex_count(); ++v) {
        Vec3 x = p.positions[v];
        uint64_t h = position_hash(x);
        uint32_t pid = pos_of.find(h, [&](uint32_t c) {
          return u.pos[c].x == x.x && u.pos[c].y == x.y && u.pos[c].z == x.z;
        });
        if (pid == KeyTable::kEmpty) {
          pid = uint32_t(u.pos.size());
          u.pos.push_back(to_dvec3(x));
          pos_of.insert(h, pid);
        }
        u.wedge_pos.push_back(pid);
        if (many) u.wedge_prim.push_back(pi);
        u.wedge_vertex.push_back(uint32_t(v));
        if (normals) u.wedge_normal.push_back(p.normals[v]);
        // Weighted attribute channels.
        if (normals)
          for (float c : {p.normals[v].x, p.normals[v].y, p.normals[v].z})
            u.attr.push_back(c * opt.normal_weight);
        for (size_t s = 0; s < uv_sets; ++s) {
          Vec2 t = s < p.uvs.size() ? p.uvs[s][v] : Vec2{};
          u.attr.push_back(t.x * opt.uv_weight);
          u.attr.push_back(t.y * opt.uv_weight);
        }
        if (colors) {
          Vec4 c = p.colors.empty() ? Vec4{1, 1, 1, 1} : p.colors[v];
          for (float ch : {c.x, c.y, c.z, c.w}) u.attr.push_back(ch * opt.color_weight);
        }
      }
      for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
        for (int c = 0; c < 3; ++c) u.corners.push_back(first + p.indices[t + size_t(c)]);
        if (many) u.face_prim.push_back(pi);
      }
    }
  }
  wedge_classes(u);
  spatial_order(u);
  return u;
}

size_t counts_for(const Scene& scene, uint32_t mesh) {
  size_t n = 0;
  for (const Instance& inst : scene.instances) n += inst.mesh == mesh;
  return n;
}

uint64_t splitmix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Instance order for thinning: instances that stay inside the scene bounds when scaled up 2x
// about their centre come first, then the rest; within each, a fixed pseudo-random order so
// the kept ones spread over the scene (Azim et al. §3.2's stochastic simplification).
InstanceOrder instance_order(const Scene& scene, uint32_t mesh, const Bounds& scene_box) {
  InstanceOrder io;
  io.mesh = mesh;
  Bounds local = mesh_bounds(scene.meshes[mesh]);
  struct Entry {
    int outside;
    uint64_t key;
    uint32_t index;
    Vec3 centre;
  };
  std::vector<Entry> entries;
  for (uint32_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& inst = scene.instances[i];
    if (inst.mesh != mesh) continue;
    Bounds wb;
    for (int c = 0; c < 8; ++c)
      wb.add(inst.world.transform_point({c & 1 ? local.max.x : local.min.x,
                                         c & 2 ? local.max.y : local.min.y,
                                         c & 4 ? local.max.z : local.min.z}));
    Vec3 centre = wb.center();
    Vec3 half = (wb.max - wb.min) * 0.5f * 2.0f;  // scaled up 2x
    bool inside = centre.x - half.x >= scene_box.min.x && centre.x + half.x <= scene_box.max.x &&
                  centre.y - half.y >= scene_box.min.y && centre.y + half.y <= scene_box.max.y &&
                  centre.z - half.z >= scene_box.min.z && centre.z + half.z <= scene_box.max.z;
    entries.push_back({inside ? 0 : 1, splitmix(i), i, centre});
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.outside != b.outside ? a.outside < b.outside
                                  : (a.key != b.key ? a.key < b.key : a.index < b.index);
  });
  for (const Entry& e : entries) {
    io.order.push_back(e.index);
    io.centres.push_back(e.centre);
  }
  return io;
}

}  // namespace

std::array<double, 16> instance_face_quadric(Vec3 a, Vec3 b, Vec3 c,
                                             const std::vector<Mat4>& transforms) {
  DVec3 P[3] = {to_dvec3(a), to_dvec3(b), to_dvec3(c)}, Q[3], un;
  double area0, world_area = 0;
  Quadric unit_q, sum;
  if (instance_plane(P, Mat4::identity(), Q, &un, &area0, &unit_q))
    sum = scaled(unit_q, placement_factor(make_placements(transforms), un, area0, &world_area),
                 world_area);
  return {sum.a00, sum.a01, sum.a02, sum.b0, sum.a01, sum.a11, sum.a12, sum.b1,
          sum.a02, sum.a12, sum.a22, sum.b2, sum.b0,  sum.b1,  sum.b2,  sum.c};
}

// The scene without its primitives' vertex and index arrays (everything else kept): what the
// record refers to, where a full copy would hold the geometry twice beside the record.
Scene without_vertex_data(const Scene& scene) {
  Scene out = empty_like(scene);
  out.instances = scene.instances;
  out.meshes.resize(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    out.meshes[m].name = scene.meshes[m].name;
    for (const Primitive& p : scene.meshes[m].primitives) {
      Primitive q;
      q.material = p.material;
      q.flat = p.flat;
      out.meshes[m].primitives.push_back(std::move(q));
    }
  }
  return out;
}

ProgressiveScene build_progressive(const Scene& cleaned, const SimplifyOptions& options,
                                   SimplifyReport* report, Progress* progress) {
  auto start = std::chrono::steady_clock::now();
  SimplifyReport r;
  SceneStats st = compute_stats(cleaned);
  r.input_triangles = st.scene_triangles;
  r.instances_per_submesh = instances_per_submesh(cleaned);
  ProgressiveScene ps;
  ps.flattened = should_flatten(cleaned, options.flatten_below_ips);
  const Scene flat = ps.flattened ? flatten_geometry(cleaned) : Scene{};
  const Scene& scene = ps.flattened ? flat : cleaned;  // the geometry the record is made from
  ps.scene = without_vertex_data(scene);
  if (ps.flattened) ps.scene.images = cleaned.images;  // flatten_geometry left them out
  r.flattened = ps.flattened;
  double norm = scene.normalization_scale > 0 ? scene.normalization_scale : 1.0;
  Mat4 normalize_m = Mat4::scale(norm, norm, norm);
  Bounds box = scene_bounds(scene);
  ps.meshes.resize(scene.meshes.size());
  ps.instance_orders.resize(scene.meshes.size());
  // Progress: collapses over all submeshes' vertices (an upper bound of the positions).
  uint64_t total_vertices = 0;
  for (const Mesh& mesh : scene.meshes)
    for (const Primitive& p : mesh.primitives) total_vertices += p.positions.size();
  // Submeshes are independent: each is simplified on its own thread (its own report, summed in
  // mesh order below), so the record is the same whatever the thread count.
  std::vector<SimplifyReport> reports(scene.meshes.size());
  std::vector<std::atomic<uint64_t>> collapsed(scene.meshes.size());
  std::mutex progress_mutex;
  parallel_chunks(scene.meshes.size(), 1, [&](size_t begin, size_t end) {
    for (uint32_t m = uint32_t(begin); m < end; ++m) {
      std::vector<Mat4> transforms;
      for (const Instance& inst : scene.instances)
        if (inst.mesh == m) transforms.push_back(normalize_m * inst.world);
      if (transforms.empty()) transforms.push_back(normalize_m);  // unplaced: its own space
      Unit unit = make_unit(scene.meshes[m], options);
      const bool blocks = unit.corners.size() / 3 > options.block_above;
      Simplifier s(unit, transforms, options, reports[m],
                   blocks ? Simplifier::Quadrics::kByBlocks : Simplifier::Quadrics::kNow);
      auto on_progress = [&](uint64_t collapses) {
        collapsed[m] = collapses;
        if (!progress) return;
        uint64_t done = 0;
        for (const auto& c : collapsed) done += c;
        std::lock_guard<std::mutex> lock(progress_mutex);
        report_fraction(progress, double(done) / double(std::max<uint64_t>(1, total_vertices)));
      };
      if (blocks) reports[m].block_levels = uint32_t(s.run_block_levels(on_progress));
      s.run(on_progress);
      if (blocks)
        malloc_trim(0);  // the block levels' freed units back to the OS before the
                         // record is allocated
      s.record(scene.meshes[m], m, ps.meshes[m]);
      ps.instance_orders[m] = instance_order(scene, m, box);
    }
  });
  for (const SimplifyReport& x : reports) {
    r.block_levels = std::max(r.block_levels, x.block_levels);
    r.spilled_bytes += x.spilled_bytes;
    r.mapped_bytes += x.mapped_bytes;
    r.collapses += x.collapses;
    r.refused_flip += x.refused_flip;
    r.refused_link += x.refused_link;
    r.refused_wedge += x.refused_wedge;
    r.refused_vanish += x.refused_vanish;
  }
  // Terrace et al. §4.5: small models, or ones whose refinements would be under 10% of the mesh,
  // ship whole: the base level is the full mesh.
  uint64_t base_tris = 0, full_tris = 0;
  for (uint32_t m = 0; m < ps.meshes.size(); ++m) {
    const ProgressiveMesh& pm = ps.meshes[m];
    base_tris += uint64_t(pm.levels[pm.base_level].triangles) * counts_for(ps.scene, m);
    full_tris += uint64_t(pm.levels.back().triangles) * counts_for(ps.scene, m);
  }
  if (full_tris < options.ship_whole_below ||
      double(full_tris - base_tris) < options.ship_whole_fraction * double(full_tris))
    for (ProgressiveMesh& pm : ps.meshes) pm.base_level = pm.levels.size() - 1;
  // The units and quadrics freed above sit in the allocator's arenas (the worker threads' own
  // among them), which keep freed pages: handed back, so that the stages after start from the
  // record's own size (4M scan: the multiplexer began at ~650 MB RSS for a ~140 MB record).
  malloc_trim(0);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (report) *report = r;
  return ps;
}

}  // namespace meshmux
