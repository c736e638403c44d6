// Levels of detail from the progressive record. Extraction is the rule of Hoppe, "Octaviewer:
// spherically parameterized progressive meshes" ("traverse vertices fine-to-coarse, mapping
// vertex indices through the parent relations, then keep only non-degenerate triangles"); scene
// selection shares one error threshold across submeshes (IAS quadrics are in scene units, so
// errors compare) and falls back to the instance thinning with area-preserving scale-up of
// Azim, Cheslack-Postava and Levis, "Instance-aware simplification of 3D polygonal meshes"
// (IAS) §3.2.
#include "simplify/lod.h"

#include <algorithm>
#include <cmath>

namespace meshmux {

std::vector<uint32_t> level_indices(const ProgressiveMesh& pm, size_t level) {
  const ProgressiveLevel& lv = pm.levels[std::min(level, pm.levels.size() - 1)];
  uint32_t k = lv.vertex_end;
  std::vector<uint32_t> out;
  out.reserve(size_t(lv.face_end) * 3);
  auto map = [&](uint32_t v) {
    while (v >= k) v = pm.parent[v];
    return v;
  };
  for (uint32_t f = 0; f < lv.face_end; ++f) {
    uint32_t a = map(pm.indices[3 * f]), b = map(pm.indices[3 * f + 1]),
             c = map(pm.indices[3 * f + 2]);
    if (a == b || b == c || a == c) continue;
    out.insert(out.end(), {a, b, c});
  }
  return out;
}

Mesh extract_level(const ProgressiveMesh& pm, size_t level, bool keep_prefix) {
  level = std::min(level, pm.levels.size() - 1);
  const ProgressiveLevel& lv = pm.levels[level];
  uint32_t k = lv.vertex_end;
  auto map = [&](uint32_t v) {
    while (v >= k) v = pm.parent[v];
    return v;
  };
  Mesh mesh;
  size_t nprim = pm.primitive_material.size();
  std::vector<std::vector<uint32_t>> faces(nprim);
  for (uint32_t f = 0; f < lv.face_end; ++f) {
    uint32_t a = map(pm.indices[3 * f]), b = map(pm.indices[3 * f + 1]),
             c = map(pm.indices[3 * f + 2]);
    if (a == b || b == c || a == c) continue;
    std::vector<uint32_t>& to = faces[pm.face_primitive.empty() ? 0 : pm.face_primitive[f]];
    to.insert(to.end(), {a, b, c});
  }
  std::vector<uint32_t> remap(k, UINT32_MAX);
  std::vector<uint32_t> stamp(keep_prefix ? 0 : k, UINT32_MAX);  // vertex → last primitive using it
  for (size_t p = 0; p < nprim; ++p) {
    if (faces[p].empty()) continue;
    Primitive prim;
    prim.material = pm.primitive_material[p];
    prim.flat = p < pm.primitive_flat.size() && pm.primitive_flat[p] != 0;
    size_t sets = p < pm.primitive_uv_sets.size() ? pm.primitive_uv_sets[p] : pm.uvs.size();
    prim.uvs.resize(std::min(sets, pm.uvs.size()));
    bool colors =
        p < pm.primitive_has_colors.size() ? pm.primitive_has_colors[p] != 0 : !pm.colors.empty();
    // Vertices in ascending shared-buffer order: deterministic, and coherent with the stream.
    std::vector<uint32_t> used;
    if (keep_prefix) {  // the whole prefix, referenced or not: vertex i is shared vertex i
      used.resize(k);
      for (uint32_t v = 0; v < k; ++v) used[v] = v;
    } else {
      // The distinct corners, ascending: sorted when few, else read off a scan of the prefix
      // (sorting every corner cost a second per level at millions of faces).
      for (uint32_t v : faces[p])
        if (stamp[v] != uint32_t(p)) stamp[v] = uint32_t(p), used.push_back(v);
      if (used.size() < k / 16) {
        std::sort(used.begin(), used.end());
      } else {
        used.clear();
        for (uint32_t v = 0; v < k; ++v)
          if (stamp[v] == uint32_t(p)) used.push_back(v);
      }
    }
    for (uint32_t v : used) {
      remap[v] = uint32_t(prim.positions.size());
      prim.positions.push_back(pm.positions[v]);
      if (!pm.normals.empty()) prim.normals.push_back(pm.normals[v]);
      for (size_t s = 0; s < prim.uvs.size(); ++s) prim.uvs[s].push_back(pm.uvs[s][v]);
      if (colors && !pm.colors.empty()) prim.colors.push_back(pm.colors[v]);
    }
    prim.indices.reserve(faces[p].size());
    for (uint32_t v : faces[p]) prim.indices.push_back(remap[v]);
    mesh.primitives.push_back(std::move(prim));
  }
  return mesh;
}

size_t level_for_vertices(const ProgressiveMesh& pm, uint32_t vertices) {
  size_t best = 0;
  for (size_t i = 0; i < pm.levels.size() && pm.levels[i].vertex_end <= vertices; ++i) best = i;
  return best;
}

size_t level_for_triangles(const ProgressiveMesh& pm, uint32_t triangles) {
  // Triangles grow with the level: binary search the last level within the budget.
  auto it = std::upper_bound(pm.levels.begin(), pm.levels.end(), triangles,
                             [](uint32_t t, const ProgressiveLevel& l) { return t < l.triangles; });
  return it == pm.levels.begin() ? 0 : size_t(it - pm.levels.begin()) - 1;
}

size_t level_for_error(const ProgressiveMesh& pm, float error) {
  // Errors never increase with the level: the first level whose error is ≤ `error`.
  auto it = std::lower_bound(pm.levels.begin(), pm.levels.end(), error,
                             [](const ProgressiveLevel& l, float e) { return l.error > e; });
  return it == pm.levels.end() ? pm.levels.size() - 1 : size_t(it - pm.levels.begin());
}

namespace {

std::vector<uint32_t> all_instances(const ProgressiveScene& ps) {
  std::vector<uint32_t> n(ps.meshes.size(), 0);
  for (const Instance& inst : ps.scene.instances)
    if (inst.mesh < n.size()) ++n[inst.mesh];
  return n;
}

}  // namespace

uint64_t selection_triangles(const ProgressiveScene& ps, const LodSelection& sel) {
  uint64_t t = 0;
  for (size_t m = 0; m < ps.meshes.size(); ++m)
    t += uint64_t(ps.meshes[m].levels[sel.level[m]].triangles) * sel.instances[m];
  return t;
}

LodSelection select_full(const ProgressiveScene& ps) {
  LodSelection s;
  for (const ProgressiveMesh& pm : ps.meshes) s.level.push_back(pm.levels.size() - 1);
  s.instances = all_instances(ps);
  return s;
}

LodSelection select_base(const ProgressiveScene& ps) {
  LodSelection s;
  for (const ProgressiveMesh& pm : ps.meshes) {
    s.level.push_back(pm.base_level);
    s.error = std::max(s.error, pm.levels[pm.base_level].error);
  }
  s.instances = all_instances(ps);
  return s;
}

LodSelection select_error(const ProgressiveScene& ps, float error) {
  LodSelection s;
  for (const ProgressiveMesh& pm : ps.meshes) s.level.push_back(level_for_error(pm, error));
  s.instances = all_instances(ps);
  s.error = error;
  return s;
}

LodSelection select_triangles(const ProgressiveScene& ps, uint64_t max_triangles) {
  // From every submesh at its coarsest level, undo collapses across the whole scene in order
  // of decreasing error (the error each step removes), as long as the scene stays within the
  // budget; a submesh whose next step does not fit stops refining. IAS quadrics are in scene
  // units, so this hands triangles to where the error is largest.
  LodSelection s;
  s.level.assign(ps.meshes.size(), 0);
  s.instances = all_instances(ps);
  uint64_t total = selection_triangles(ps, s);
  if (total > max_triangles) {
    // Even the coarsest levels are too many: thin instances (Azim et al. §3.2). One
    // keep-fraction for every submesh with more than one instance, the largest that fits.
    std::vector<uint32_t> n = all_instances(ps);
    auto apply = [&](double f) {
      for (size_t m = 0; m < n.size(); ++m)
        s.instances[m] =
            n[m] <= 1 ? n[m] : std::max<uint32_t>(1, uint32_t(std::floor(double(n[m]) * f)));
      return selection_triangles(ps, s);
    };
    double flo = 0, fhi = 1;
    for (int it = 0; it < 40; ++it) {
      double mid = 0.5 * (flo + fhi);
      if (apply(mid) <= max_triangles)
        flo = mid;
      else
        fhi = mid;
    }
    apply(flo);
  } else {
    using Step = std::pair<float, size_t>;  // (error removed by the next step, mesh)
    auto cmp = [](const Step& a, const Step& b) {
      return a.first != b.first ? a.first < b.first : a.second > b.second;
    };
    std::vector<Step> heap;
    for (size_t m = 0; m < ps.meshes.size(); ++m)
      if (ps.meshes[m].levels.size() > 1 && s.instances[m] > 0)
        heap.push_back({ps.meshes[m].levels[0].error, m});
    std::make_heap(heap.begin(), heap.end(), cmp);
    while (!heap.empty()) {
      std::pop_heap(heap.begin(), heap.end(), cmp);
      size_t m = heap.back().second;
      heap.pop_back();
      const auto& lv = ps.meshes[m].levels;
      size_t l = s.level[m];
      uint64_t delta = uint64_t(lv[l + 1].triangles - lv[l].triangles) * s.instances[m];
      if (total + delta > max_triangles) continue;  // this submesh stops here
      total += delta;
      s.level[m] = l + 1;
      if (l + 2 < lv.size()) {
        heap.push_back({lv[l + 1].error, m});
        std::push_heap(heap.begin(), heap.end(), cmp);
      }
    }
  }
  for (size_t m = 0; m < ps.meshes.size(); ++m)
    s.error = std::max(s.error, ps.meshes[m].levels[s.level[m]].error);
  return s;
}

namespace {

// The instances a selection places, in materialize's order, each naming its submesh (of ps):
// thinned ones first (scaled up about their centres to preserve area), then the submeshes kept
// whole, in scene order. `drawn[m]`: whether submesh m has faces at its level.
std::vector<Instance> selected_instances(const ProgressiveScene& ps, const LodSelection& sel,
                                         const std::vector<bool>& drawn) {
  std::vector<Instance> out;
  std::vector<uint32_t> n = all_instances(ps);
  for (size_t m = 0; m < ps.meshes.size(); ++m) {
    if (!drawn[m]) continue;
    if (sel.instances[m] >= n[m]) continue;  // all instances: written below in scene order
    const InstanceOrder& io = ps.instance_orders[m];
    uint32_t keep = std::min<uint32_t>(sel.instances[m], uint32_t(io.order.size()));
    double s = keep > 0 ? std::sqrt(double(n[m]) / double(keep)) : 1.0;
    for (uint32_t i = 0; i < keep; ++i) {
      Instance inst = ps.scene.instances[io.order[i]];
      Vec3 c = io.centres[i];
      inst.world = Mat4::translation(c.x, c.y, c.z) * Mat4::scale(s, s, s) *
                   Mat4::translation(-c.x, -c.y, -c.z) * inst.world;
      inst.mesh = uint32_t(m);
      out.push_back(std::move(inst));
    }
  }
  for (const Instance& src : ps.scene.instances) {
    if (src.mesh >= ps.meshes.size() || !drawn[src.mesh]) continue;
    if (sel.instances[src.mesh] < n[src.mesh]) continue;
    out.push_back(src);
  }
  return out;
}

// The vertices of pm's level that its faces use (non-degenerate at that level), as a mask over
// the level's prefix: the vertices extract_level keeps.
std::vector<uint8_t> used_vertices(const ProgressiveMesh& pm, size_t level) {
  level = std::min(level, pm.levels.size() - 1);
  const ProgressiveLevel& lv = pm.levels[level];
  const uint32_t k = lv.vertex_end;
  auto map = [&](uint32_t v) {
    while (v >= k) v = pm.parent[v];
    return v;
  };
  std::vector<uint8_t> used(k, 0);
  for (uint32_t f = 0; f < lv.face_end; ++f) {
    uint32_t a = map(pm.indices[3 * f]), b = map(pm.indices[3 * f + 1]),
             c = map(pm.indices[3 * f + 2]);
    if (a == b || b == c || a == c) continue;
    used[a] = used[b] = used[c] = 1;
  }
  return used;
}

}  // namespace

Bounds selection_bounds(const ProgressiveScene& ps, const LodSelection& sel) {
  std::vector<std::vector<uint8_t>> used(ps.meshes.size());
  std::vector<bool> drawn(ps.meshes.size(), false);
  for (size_t m = 0; m < ps.meshes.size(); ++m) {
    used[m] = used_vertices(ps.meshes[m], sel.level[m]);
    drawn[m] = std::find(used[m].begin(), used[m].end(), 1) != used[m].end();
  }
  Bounds b;
  for (const Instance& inst : selected_instances(ps, sel, drawn))
    for (size_t v = 0; v < used[inst.mesh].size(); ++v)
      if (used[inst.mesh][v]) b.add(inst.world.transform_point(ps.meshes[inst.mesh].positions[v]));
  return b;
}

Scene materialize(const ProgressiveScene& ps, const LodSelection& sel, bool keep_prefix,
                  bool with_images) {
  Scene out = empty_like(ps.scene, with_images);
  std::vector<int32_t> mesh_map(ps.meshes.size(), -1);
  for (size_t m = 0; m < ps.meshes.size(); ++m) {
    Mesh mesh = extract_level(ps.meshes[m], sel.level[m], keep_prefix);
    mesh.name = ps.scene.meshes[m].name;
    if (mesh.primitives.empty()) continue;
    mesh_map[m] = int32_t(out.meshes.size());
    out.meshes.push_back(std::move(mesh));
  }
  std::vector<bool> drawn(ps.meshes.size());
  for (size_t m = 0; m < ps.meshes.size(); ++m) drawn[m] = mesh_map[m] >= 0;
  out.instances = selected_instances(ps, sel, drawn);
  for (Instance& inst : out.instances) inst.mesh = uint32_t(mesh_map[inst.mesh]);
  return out;
}

}  // namespace meshmux
