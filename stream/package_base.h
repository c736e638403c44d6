// The package's base .glb when refinements follow (stream/format.h, "The mesh stream"): the
// base scene's meshes put in the stream's vertex order and given exactly the faces the stream's
// client starts from, so that base vertex i is stream vertex i and a client appends the
// refinements to what the .glb decodes. The glTF exporter then codes it with meshoptimizer's
// order-keeping codecs over the stream's quantization (MeshStreamBase::quantization).
#pragma once

#include <vector>

#include "core/status.h"
#include "scene/scene.h"
#include "stream/mesh_stream.h"

namespace meshmux {

// Reorders `base_scene` (the progressive record's base level, mesh m of it coded by
// streams[m]) in place: every primitive's vertices in the order streams[m].base_order, its
// faces streams[m].base_primitive_faces, and flat shading where the stream carries no normals.
// Errors (kInternal): primitive counts, orders or faces that do not match the stream's.
// O(vertices + faces).
Status order_base_scene(Scene& base_scene, const std::vector<MeshStreamBase>& streams);

}  // namespace meshmux
