// glTF 2.0 (.gltf with external or data-URI buffers and images, .glb) → Scene, through
// tinygltf (Debian libtinygltf-dev).
//
// Contract:
// - Every accessor component type, byte stride, normalized and sparse accessors are read;
//   KHR_mesh_quantization's integer positions/normals/uvs are converted to float.
// - The node hierarchy is flattened to Instances with world transforms; a mesh used by
//   several nodes stays one Mesh. EXT_mesh_gpu_instancing adds one Instance per instance.
// - KHR_texture_transform is read into TextureRef::transform; KHR_draco_mesh_compression
//   primitives are decoded with Draco.
// - Triangle strips and fans become triangle lists; points and lines are skipped with a
//   warning. Skins and animations are dropped with a warning (the bind pose is kept).
// - An extension in extensionsRequired that meshmux cannot honour is an error naming it.
// - Every index, offset and length is checked before use; errors look like
//   "gltf: scene.glb: mesh 3 primitive 1: accessor 7 out of bounds".
// - An image that is missing or fails to decode gives a warning; the material keeps its
//   factors and the texture reference is dropped.
#pragma once

#include <string>

#include "importers/import_options.h"
#include "scene/scene.h"

namespace meshmux {

Result<Scene> import_gltf(const std::string& path, const ImportOptions& options,
                          Warnings* warnings);

}  // namespace meshmux
