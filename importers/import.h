// Picks the importer for a file: .gltf/.glb (or glTF magic) → import_gltf, .dae (or a
// COLLADA root element) → import_collada. Errors name the file: unknown extension, missing
// file, empty file.
#pragma once

#include <string>

#include "importers/import_options.h"
#include "scene/scene.h"

namespace meshmux {

Result<Scene> import_scene(const std::string& path, const ImportOptions& options,
                           Warnings* warnings);

}  // namespace meshmux
