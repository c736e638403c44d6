// Clean and normalize: Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion
// of 3D models for interactive metaverses" §4.1 ("Cleaning and Normalizing"): unreferenced data,
// duplicate and degenerate triangles removed, missing normals generated, vertex data scaled to a
// uniform size for error normalization (kept as a factor here so output keeps the author's
// units; docs/ARCHITECTURE.md "Clean").
#include "clean/clean.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "core/first_equal.h"
#include "core/key_table.h"
#include "core/parallel.h"
#include "scene/position_key.h"

namespace meshmux {

namespace {

bool finite_unit(Vec3 n) {
  float l = length(n);
  return std::isfinite(l) && l > 0.5f && l < 1.5f;
}

// A vertex's attribute bits (position, normal, uv sets, colour; −0 folded into +0), the words
// welding compares exactly, into `key` (resized to the primitive's word count).
void vertex_words(const Primitive& p, size_t v, std::vector<uint32_t>& key) {
  key.resize(3 + (p.normals.empty() ? 0 : 3) + 2 * p.uvs.size() + (p.colors.empty() ? 0 : 4));
  uint32_t* w = key.data();
  auto add = [&](float f) { *w++ = float_bits(f); };
  add(p.positions[v].x), add(p.positions[v].y), add(p.positions[v].z);
  if (!p.normals.empty()) add(p.normals[v].x), add(p.normals[v].y), add(p.normals[v].z);
  for (const auto& set : p.uvs) add(set[v].x), add(set[v].y);
  if (!p.colors.empty())
    add(p.colors[v].x), add(p.colors[v].y), add(p.colors[v].z), add(p.colors[v].w);
}

// Whether vertices a and b have the same attribute bits (vertex_words).
bool same_vertex(const Primitive& p, size_t a, size_t b) {
  auto eq2 = [](Vec2 x, Vec2 y) {
    return float_bits(x.x) == float_bits(y.x) && float_bits(x.y) == float_bits(y.y);
  };
  auto eq3 = [](Vec3 x, Vec3 y) {
    return float_bits(x.x) == float_bits(y.x) && float_bits(x.y) == float_bits(y.y) &&
           float_bits(x.z) == float_bits(y.z);
  };
  if (!eq3(p.positions[a], p.positions[b])) return false;
  if (!p.normals.empty() && !eq3(p.normals[a], p.normals[b])) return false;
  for (const auto& set : p.uvs)
    if (!eq2(set[a], set[b])) return false;
  if (!p.colors.empty()) {
    const Vec4 x = p.colors[a], y = p.colors[b];
    if (!eq2({x.x, x.y}, {y.x, y.y}) || !eq2({x.z, x.w}, {y.z, y.w})) return false;
  }
  return true;
}

// Rows in chunks on every core (each writes only its own items).
constexpr size_t kChunk = 1 << 16;

// Welds exact duplicates; returns the remapped primitive (indices rewritten). Kept vertices
// stay in first-occurrence order. The first equal vertex of each is found on every core
// (core/first_equal.h).
Primitive weld(const Primitive& p) {
  const size_t n = p.positions.size();
  std::vector<uint64_t> hash(n);
  parallel_chunks(n, kChunk, [&](size_t begin, size_t end) {
    std::vector<uint32_t> key;
    for (size_t v = begin; v < end; ++v) {
      vertex_words(p, v, key);
      hash[v] = fnv1a(key.data(), key.size());
    }
  });
  const std::vector<uint32_t> first =
      first_equal(hash, [&](uint32_t a, uint32_t b) { return same_vertex(p, a, b); });
  std::vector<uint64_t>().swap(hash);
  std::vector<uint32_t> remap(n), kept;  // kept: output vertex → its input vertex
  for (size_t v = 0; v < n; ++v) {
    if (first[v] == v) {
      remap[v] = uint32_t(kept.size());
      kept.push_back(uint32_t(v));
    } else {
      remap[v] = remap[first[v]];
    }
  }
  Primitive out;
  out.material = p.material;
  out.flat = p.flat;
  auto gather = [&](const auto& in, auto& to) {
    if (in.empty()) return;
    to.resize(kept.size());
    parallel_chunks(kept.size(), kChunk, [&](size_t begin, size_t end) {
      for (size_t k = begin; k < end; ++k) to[k] = in[kept[k]];
    });
  };
  gather(p.positions, out.positions);
  gather(p.normals, out.normals);
  out.uvs.resize(p.uvs.size());
  for (size_t s = 0; s < p.uvs.size(); ++s) gather(p.uvs[s], out.uvs[s]);
  gather(p.colors, out.colors);
  out.indices.resize(p.indices.size());
  parallel_chunks(p.indices.size(), kChunk, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) out.indices[i] = remap[p.indices[i]];
  });
  return out;
}

// A triangle's corners rotated so the smallest index leads; the winding is kept.
std::array<uint32_t, 3> rotated(uint32_t a, uint32_t b, uint32_t c) {
  if (b < a && b < c) return {b, c, a};
  if (c < a && c < b) return {c, a, b};
  return {a, b, c};
}

// Removes degenerate and duplicate triangles in place (a duplicate: the same corners in the same
// rotation order as an earlier kept triangle); counts them. Tests and first equals on every core.
void filter_triangles(Primitive& p, const CleanOptions& o, CleanReport& r) {
  const size_t n = p.indices.size() / 3;
  std::vector<uint8_t> degenerate(n, 0);
  std::vector<uint64_t> hash(o.remove_duplicates ? n : 0);
  parallel_chunks(n, kChunk, [&](size_t begin, size_t end) {
    for (size_t t = begin; t < end; ++t) {
      const uint32_t a = p.indices[3 * t], b = p.indices[3 * t + 1], c = p.indices[3 * t + 2];
      if (o.remove_degenerate) {
        const Vec3 pa = p.positions[a], pb = p.positions[b], pc = p.positions[c];
        const bool repeated = a == b || b == c || a == c || pa == pb || pb == pc || pa == pc;
        const Vec3 nrm = cross(pb - pa, pc - pa);
        degenerate[t] = repeated || !(dot(nrm, nrm) > 0);
      }
      if (o.remove_duplicates) {
        const std::array<uint32_t, 3> k = rotated(a, b, c);  // winding kept
        hash[t] = fnv1a(k.data(), 3);
      }
    }
  });
  std::vector<uint32_t> first;
  if (o.remove_duplicates)
    first = first_equal(hash, [&](uint32_t x, uint32_t y) {
      const uint32_t* i = &p.indices[3 * size_t(x)];
      const uint32_t* j = &p.indices[3 * size_t(y)];
      return !degenerate[x] && !degenerate[y] &&
             rotated(i[0], i[1], i[2]) == rotated(j[0], j[1], j[2]);
    });
  std::vector<uint64_t>().swap(hash);
  size_t kept = 0;
  for (size_t t = 0; t < n; ++t) {
    if (degenerate[t]) {
      ++r.degenerate_removed;
    } else if (!first.empty() && first[t] != t) {
      ++r.duplicates_removed;
    } else {
      if (kept != t) std::copy_n(&p.indices[3 * t], 3, &p.indices[3 * kept]);
      ++kept;
    }
  }
  p.indices.resize(3 * kept);
}

void drop_unreferenced(Primitive& p) {
  std::vector<uint32_t> remap(p.positions.size(), UINT32_MAX);
  uint32_t next = 0;
  std::vector<uint32_t> order;
  for (uint32_t& i : p.indices) {
    if (remap[i] == UINT32_MAX) remap[i] = next++, order.push_back(i);
    i = remap[i];
  }
  if (next == p.positions.size()) {
    bool identity = true;
    for (size_t k = 0; k < order.size() && identity; ++k) identity = order[k] == k;
    if (identity) return;
  }
  auto gather = [&](auto& arr) {
    if (arr.empty()) return;
    std::remove_reference_t<decltype(arr)> out;
    out.reserve(order.size());
    for (uint32_t v : order) out.push_back(arr[v]);
    arr.swap(out);
  };
  gather(p.positions);
  gather(p.normals);
  for (auto& set : p.uvs) gather(set);
  gather(p.colors);
}

// Angle-weighted normals with a crease angle; splits vertices whose corners get different
// normals. Corners are grouped by exact position so normals smooth across uv seams.
void generate_normals(Primitive& p, float crease_degrees) {
  size_t nt = p.indices.size() / 3;
  std::vector<Vec3> face_n(nt);
  std::vector<std::array<float, 3>> corner_angle(nt);
  for (size_t t = 0; t < nt; ++t) {
    Vec3 v[3] = {p.positions[p.indices[3 * t]], p.positions[p.indices[3 * t + 1]],
                 p.positions[p.indices[3 * t + 2]]};
    face_n[t] = normalize(cross(v[1] - v[0], v[2] - v[0]));
    for (int c = 0; c < 3; ++c) {
      Vec3 e1 = normalize(v[(c + 1) % 3] - v[c]), e2 = normalize(v[(c + 2) % 3] - v[c]);
      corner_angle[t][size_t(c)] = std::acos(std::clamp(dot(e1, e2), -1.0f, 1.0f));
    }
  }
  // Group corners by position (−0 folded into +0), groups numbered in corner order.
  KeyTable group_of(p.positions.size());
  std::vector<uint32_t> group_vertex;  // group → a vertex at its position
  std::vector<uint32_t> corner_group(p.indices.size());
  for (size_t i = 0; i < p.indices.size(); ++i) {
    const uint32_t v = p.indices[i];
    const PositionKey key(p.positions[v]);
    const uint64_t h = position_hash(p.positions[v]);
    uint32_t g = group_of.find(
        h, [&](uint32_t cand) { return PositionKey(p.positions[group_vertex[cand]]) == key; });
    if (g == KeyTable::kEmpty) {
      g = uint32_t(group_vertex.size());
      group_vertex.push_back(v);
      group_of.insert(h, g);
    }
    corner_group[i] = g;
  }
  const size_t groups = group_vertex.size();
  // Corners of each group, in corner order (deterministic).
  std::vector<uint32_t> start(groups + 1, 0), members(p.indices.size());
  for (uint32_t g : corner_group) ++start[g + 1];
  for (size_t g = 0; g < groups; ++g) start[g + 1] += start[g];
  std::vector<uint32_t> fill(start.begin(), start.end() - 1);
  for (size_t i = 0; i < p.indices.size(); ++i) members[fill[corner_group[i]]++] = uint32_t(i);

  float cos_crease = std::cos(crease_degrees * float(M_PI) / 180.0f);
  std::vector<Vec3> corner_n(p.indices.size());
  for (size_t i = 0; i < p.indices.size(); ++i) {
    size_t t = i / 3;
    uint32_t g = corner_group[i];
    Vec3 sum{};
    for (uint32_t k = start[g]; k < start[g + 1]; ++k) {
      uint32_t j = members[k];
      size_t u = j / 3;
      if (dot(face_n[t], face_n[u]) >= cos_crease) sum = sum + face_n[u] * corner_angle[u][j % 3];
    }
    Vec3 n = normalize(sum);
    corner_n[i] = length(n) > 0 ? n : face_n[t];
  }
  // Split: one vertex per (original vertex, normal bits) pair, in first-corner order.
  Primitive out;
  out.material = p.material;
  out.flat = p.flat;
  out.uvs.resize(p.uvs.size());
  KeyTable made(p.indices.size());
  std::vector<uint32_t> made_source;  // output vertex → its input vertex
  for (size_t i = 0; i < p.indices.size(); ++i) {
    const uint32_t v = p.indices[i];
    const Vec3 n = corner_n[i];
    const uint32_t key[4] = {v, float_bits(n.x), float_bits(n.y), float_bits(n.z)};
    const uint64_t h = fnv1a(key, 4);
    uint32_t k = made.find(h, [&](uint32_t cand) {
      const Vec3 m = out.normals[cand];
      return made_source[cand] == v && float_bits(m.x) == key[1] && float_bits(m.y) == key[2] &&
             float_bits(m.z) == key[3];
    });
    if (k == KeyTable::kEmpty) {
      k = uint32_t(out.positions.size());
      made_source.push_back(v);
      made.insert(h, k);
      out.positions.push_back(p.positions[v]);
      out.normals.push_back(n);
      for (size_t s = 0; s < p.uvs.size(); ++s) out.uvs[s].push_back(p.uvs[s][v]);
      if (!p.colors.empty()) out.colors.push_back(p.colors[v]);
    }
    out.indices.push_back(k);
  }
  p = std::move(out);
}

// Whether a triangle that stays (one with area) uses a zero, NaN or far-from-unit normal. The
// normals only degenerate triangles use do not count: exporters give those zero normals (a
// table's four zero normals once cost all 1566 of its authored ones, its bevels smoothed by the
// generated normals, lit 26 dB), and the triangles go in filter_triangles.
bool has_broken_normals(const Primitive& p, bool degenerate_removed) {
  if (p.normals.empty()) return false;
  const size_t n = p.indices.size() / 3;
  std::vector<uint8_t> broken((n + kChunk - 1) / kChunk, 0);  // per chunk
  parallel_chunks(n, kChunk, [&](size_t begin, size_t end) {
    for (size_t t = begin; t < end && !broken[begin / kChunk]; ++t) {
      const uint32_t a = p.indices[3 * t], b = p.indices[3 * t + 1], c = p.indices[3 * t + 2];
      const Vec3 nrm = cross(p.positions[b] - p.positions[a], p.positions[c] - p.positions[a]);
      if (degenerate_removed && !(dot(nrm, nrm) > 0)) continue;
      if (!finite_unit(p.normals[a]) || !finite_unit(p.normals[b]) || !finite_unit(p.normals[c]))
        broken[begin / kChunk] = 1;
    }
  });
  return std::find(broken.begin(), broken.end(), 1) != broken.end();
}

void sanitize(Primitive& p) {
  for (auto& set : p.uvs)
    parallel_chunks(set.size(), kChunk, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        if (!std::isfinite(set[i].x)) set[i].x = 0;
        if (!std::isfinite(set[i].y)) set[i].y = 0;
      }
    });
  auto clamp01 = [](float f) { return std::isfinite(f) ? std::clamp(f, 0.0f, 1.0f) : 1.0f; };
  parallel_chunks(p.colors.size(), kChunk, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      Vec4& c = p.colors[i];
      c = {clamp01(c.x), clamp01(c.y), clamp01(c.z), clamp01(c.w)};
    }
  });
}

}  // namespace

Scene clean(Scene in, const CleanOptions& o, CleanReport* report) {
  CleanReport r;
  Scene out;
  out.materials = in.materials;
  out.images = std::move(in.images);
  out.lines = in.lines;
  out.source = in.source;
  std::vector<int32_t> mesh_map(in.meshes.size(), -1);
  for (size_t m = 0; m < in.meshes.size(); ++m) {
    Mesh mesh;
    mesh.name = in.meshes[m].name;
    for (Primitive& src : in.meshes[m].primitives) {
      r.vertices_in += src.vertex_count();
      r.triangles_in += src.triangle_count();
      Primitive p = std::move(src);  // `in` is ours
      sanitize(p);
      if (o.generate_normals && has_broken_normals(p, o.remove_degenerate)) p.normals.clear();
      if (o.weld) p = weld(p);
      filter_triangles(p, o, r);
      if (p.indices.empty()) {
        ++r.primitives_dropped;
        continue;
      }
      drop_unreferenced(p);
      if (p.normals.empty() && o.generate_normals) {
        generate_normals(p, o.crease_angle_degrees);
        ++r.primitives_with_generated_normals;
      }
      r.vertices_out += p.vertex_count();
      r.triangles_out += p.triangle_count();
      mesh.primitives.push_back(std::move(p));
    }
    if (mesh.primitives.empty()) {
      ++r.meshes_dropped;
      continue;
    }
    mesh_map[m] = int32_t(out.meshes.size());
    out.meshes.push_back(std::move(mesh));
  }
  for (const Instance& inst : in.instances) {
    if (inst.mesh >= mesh_map.size() || mesh_map[inst.mesh] < 0) continue;
    Instance copy = inst;
    copy.mesh = uint32_t(mesh_map[inst.mesh]);
    out.instances.push_back(std::move(copy));
  }
  float diag = scene_bounds(out).diagonal();
  out.normalization_scale = diag > 0 && std::isfinite(diag) ? 1.0 / double(diag) : 1.0;
  if (report) *report = r;
  return out;
}

}  // namespace meshmux
