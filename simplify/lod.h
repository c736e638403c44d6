// Levels of detail from a progressive record: extracting one submesh level (the parent mapping
// of Hoppe, "Octaviewer: spherically parameterized progressive meshes"), choosing per-submesh
// levels and instance counts for a scene-wide target, and turning a choice into a plain Scene
// for export.
#pragma once

#include <cstdint>
#include <vector>

#include "scene/progressive.h"
#include "scene/scene.h"

namespace meshmux {

// The submesh at `level` (index into pm.levels) as a Mesh with one primitive per source
// primitive that still has faces. Vertices are the level's prefix, compacted per primitive;
// with `keep_prefix` every primitive holds the whole prefix uncompacted, so vertex i is the
// stream's vertex i (what the stream package's base needs; meant for one-primitive meshes).
// O(V + F) of the level.
Mesh extract_level(const ProgressiveMesh& pm, size_t level, bool keep_prefix = false);

// The corners of the faces alive at `level`, mapped through `parent`, in the shared
// (uncompacted) vertex numbering: the form a streaming client holds. Degenerate faces dropped.
std::vector<uint32_t> level_indices(const ProgressiveMesh& pm, size_t level);

// Level lookups. Each returns an index into pm.levels.
size_t level_for_vertices(const ProgressiveMesh& pm, uint32_t vertices);    // largest ≤ vertices
size_t level_for_triangles(const ProgressiveMesh& pm, uint32_t triangles);  // largest ≤ triangles
size_t level_for_error(const ProgressiveMesh& pm, float error);  // smallest with ≤ error

// A scene-wide choice: per submesh, a level and how many of its instances to show.
struct LodSelection {
  std::vector<size_t> level;        // per Scene mesh: index into its ProgressiveMesh::levels
  std::vector<uint32_t> instances;  // per Scene mesh: instances shown (≤ its instance count)
  float error = 0;                  // the shared error threshold the levels were chosen by
};

uint64_t selection_triangles(const ProgressiveScene& ps, const LodSelection& sel);

// Every submesh at full detail with all instances.
LodSelection select_full(const ProgressiveScene& ps);
// Every submesh at its base level (the stopping rule), all instances.
LodSelection select_base(const ProgressiveScene& ps);
// The finest selection with at most `max_triangles` scene triangles: one error threshold for
// every submesh (so detail goes where the error is), then, if even the coarsest levels are too
// many, instance thinning (Azim, Cheslack-Postava and Levis, "Instance-aware simplification of
// 3D polygonal meshes" §3.2) on the submeshes with the most instances.
LodSelection select_triangles(const ProgressiveScene& ps, uint64_t max_triangles);
// Every submesh at the smallest level with error ≤ `error`, all instances.
LodSelection select_error(const ProgressiveScene& ps, float error);

// A plain Scene for a selection: extracted meshes, instances (thinned ones scaled up about their
// centres to preserve area), materials and images as in ps.scene.
// `keep_prefix` as in extract_level. Without `with_images` the images are left out (geometry
// drawn without its textures, or a box: a scene's decoded images are its largest part).
Scene materialize(const ProgressiveScene& ps, const LodSelection& sel, bool keep_prefix = false,
                  bool with_images = true);

// The world-space box of what materialize(ps, sel) draws (scene_bounds of it), without making
// the scene: the level's used vertices through the selection's instances. O(faces at the level
// + used vertices × instances); a byte per vertex of the level's prefix besides.
Bounds selection_bounds(const ProgressiveScene& ps, const LodSelection& sel);

}  // namespace meshmux
