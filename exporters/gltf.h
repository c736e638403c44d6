// Scene → binary glTF (.glb) with KHR_draco_mesh_compression.
//
// Contract:
// - Each Mesh becomes one glTF mesh with one primitive per Primitive, Draco-compressed
//   (quantization bits settable); accessors carry count, min/max as the spec requires.
// - Meshes shared by several instances stay shared: nodes reference the same mesh; a mesh
//   with at least `min_gpu_instances` instances becomes one node with EXT_mesh_gpu_instancing
//   (TRANSLATION/ROTATION/SCALE), except instances whose transform has shear, which keep
//   their own node with a matrix.
// - Materials are written in full (factors, textures with samplers, KHR_texture_transform,
//   alpha mode and cutoff, double-sided, unlit). Images are embedded in their original
//   encoding when that is PNG or JPEG (or WebP); anything else (TGA, BMP, ...) is re-encoded
//   to PNG from the decoded pixels. Images that cannot be embedded are dropped with a warning.
// - The output is validator-clean (Khronos gltf-validator: 0 errors) and deterministic:
//   the same scene and options give the same bytes.
// - export_glb writes through write_file_atomic: no partial file on failure.
// - With `meshopt` (the stream package's base), meshes are written instead with
//   EXT_meshopt_compression over KHR_mesh_quantization attributes (exporters/gltf_meshopt.h),
//   vertex order and face order kept exactly, values as stream/quantize.h gives them; positions
//   are integers on each mesh's grid and every node that draws the mesh (plain, instanced,
//   sheared child) has its transform multiplied on the right by translate(origin)·scale(step).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/encode_counts.h"
#include "image/ktx2_encode.h"
#include "scene/scene.h"
#include "stream/quantize.h"

namespace meshmux {

struct GltfExportOptions {
  bool draco = true;                   // compress meshes with KHR_draco_mesh_compression
  int position_bits = 14;              // Draco quantization bits for positions (1-30)
  int normal_bits = 10;                // for normals
  int uv_bits = 12;                    // for texture coordinates
  int color_bits = 8;                  // for vertex colours
  int draco_speed = 3;                 // Draco encoder speed 0 (smallest) .. 10 (fastest)
  size_t split_draco_above = 1000000;  // Draco: a primitive with more triangles is written as
                                       // spatial parts of at most this many, one glTF
                                       // primitive each, encoded on every core; 0 = never
  size_t min_gpu_instances = kMinGpuInstances;  // instances per mesh for EXT_mesh_gpu_instancing
  std::string generator = "meshmux";            // asset.generator
  bool tag_meshes = false;  // mesh.extras = {"meshmux_mesh": Scene mesh index} and image.extras
                            // = {"meshmux_image": Scene image index} (stream package base)
  bool meshopt = false;     // EXT_meshopt_compression + KHR_mesh_quantization, vertex order kept
                            // (stream package base); takes precedence over `draco`
  bool ktx2 = false;        // images as KTX2 (KHR_texture_basisu, required): ETC1S for colour maps,
                            // UASTC for normal and data maps (exporters/ktx2_images.h)
  Ktx2EncodeOptions ktx2_options;  // the encoder's quality settings when `ktx2`
  EncodeCounts* counts = nullptr;  // observer: images encoded here (undecodable-as-is sources)
  std::vector<PositionQuantization>
      position_quantization;  // meshopt: grid per Scene mesh; missing entries are computed
                              // from the bounds of the mesh's positions over all its primitives
};

Result<std::vector<uint8_t>> export_glb_bytes(const Scene& scene, const GltfExportOptions& options,
                                              Warnings* warnings);

Status export_glb(const Scene& scene, const std::string& path, const GltfExportOptions& options,
                  Warnings* warnings);

}  // namespace meshmux
