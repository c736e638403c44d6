#include "stream/package_base.h"

#include <string>

namespace meshmux {

namespace {

// Puts a primitive's vertices in the order `order` (new vertex i = old vertex order[i]), its
// faces following them.
Status permute_vertices(Primitive& p, const std::vector<uint32_t>& order) {
  const size_t n = p.positions.size();
  if (order.size() != n)
    return Status::error("package: base order of " + std::to_string(order.size()) +
                             " vertices for a primitive of " + std::to_string(n),
                         ErrorKind::kInternal);
  std::vector<uint32_t> inverse(n, UINT32_MAX);
  for (uint32_t i = 0; i < n; ++i) {
    if (order[i] >= n || inverse[order[i]] != UINT32_MAX)
      return Status::error("package: base order is not a permutation", ErrorKind::kInternal);
    inverse[order[i]] = i;
  }
  auto apply = [&](auto& values) {
    if (values.size() != n) return;
    auto old = values;
    for (size_t i = 0; i < n; ++i) values[i] = old[order[i]];
  };
  apply(p.positions);
  apply(p.normals);
  apply(p.colors);
  for (auto& set : p.uvs) apply(set);
  for (uint32_t& i : p.indices) i = inverse[i];
  return Status::ok();
}

}  // namespace

Status order_base_scene(Scene& base_scene, const std::vector<MeshStreamBase>& streams) {
  // A mesh whose stream carries normals (the client appends to the base's) keeps them in every
  // base primitive, flat-shaded or not; a mesh whose sources are all flat has none in either,
  // so viewers shade the base and the stream flat, as they shade model.glb.
  for (size_t m = 0; m < base_scene.meshes.size() && m < streams.size(); ++m)
    for (Primitive& p : base_scene.meshes[m].primitives) p.flat = !streams[m].normals;
  // Its vertices in the stream's base order (every primitive holds the whole prefix), and its
  // primitives' faces exactly as the stream's client takes them (MeshStreamBase).
  for (size_t m = 0; m < base_scene.meshes.size() && m < streams.size(); ++m) {
    const MeshStreamBase& stream = streams[m];
    std::vector<Primitive>& prims = base_scene.meshes[m].primitives;
    if (prims.size() != stream.base_primitive_faces.size())
      return Status::error("package: mesh " + std::to_string(m) + ": " +
                               std::to_string(prims.size()) + " base primitives, the stream has " +
                               std::to_string(stream.base_primitive_faces.size()),
                           ErrorKind::kInternal);
    for (size_t k = 0; k < prims.size(); ++k) {
      if (Status s = permute_vertices(prims[k], stream.base_order); !s) return s;
      if (prims[k].indices.size() != stream.base_primitive_faces[k].size())
        return Status::error("package: mesh " + std::to_string(m) + " primitive " +
                                 std::to_string(k) + ": base faces differ from the stream's",
                             ErrorKind::kInternal);
      prims[k].indices = stream.base_primitive_faces[k];
    }
  }
  return Status::ok();
}

}  // namespace meshmux
