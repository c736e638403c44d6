// COLLADA 1.4/1.5 → Scene, through Assimp (Debian libassimp-dev).
//
// Contract:
// - One <geometry> used by many <instance_geometry>/<instance_node> stays ONE Mesh, with one
//   Instance per placement (world transform = the node chain's matrices). A geometry with
//   several material blocks becomes one Mesh with one Primitive per material.
// - <triangles>, <polylist>, <polygons> are triangulated (concave polygons correctly);
//   <lines>/<linestrips>/points are skipped with a warning naming the geometry.
// - up_axis and unit are applied: the scene comes out Y-up, in metres, like glTF.
// - bind_material is honoured; materials map to the glTF metallic-roughness model: diffuse
//   colour or texture → base colour, transparency → alpha (BLEND), double_sided from
//   <extra> when present. Texture paths are resolved relative to the .dae file; a texture file
//   that is missing or fails to decode gives a warning, and the material keeps its colour.
// - Errors name the file and the problem: "collada: duck.dae: malformed XML: ...".
// Complexity: linear in the file size (plus Assimp's triangulation).
#pragma once

#include <string>

#include "importers/import_options.h"
#include "scene/scene.h"

namespace meshmux {

Result<Scene> import_collada(const std::string& path, const ImportOptions& options,
                             Warnings* warnings);

}  // namespace meshmux
