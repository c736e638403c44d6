// The progressive mesh (Hoppe, "Octaviewer: spherically parameterized progressive meshes": "levels
// of detail sharing a read-only vertex buffer") and the progressive scene built from it. Plain
// data: written by simplify/simplify, read by the exporters, the multiplexer and the tests.
//
// One ProgressiveMesh per simplified submesh (a Scene Mesh). Its vertices are stored in the
// order they appear (base vertices first, then each refinement's vertices); each vertex has a
// `parent`, the vertex it split from (itself for base vertices, and parent[v] < v otherwise).
// Its faces are the full mesh's faces in the order they appear. The level with the first k
// vertices is: the faces that have appeared by then, each corner mapped through `parent` until
// its index is < k, with faces whose mapped corners repeat dropped. A refinement step is a
// contiguous range of vertices and a contiguous range of faces; the vertex buffer is only ever
// appended to. All vertices of one position (seam duplicates, hard-edge splits) split in the
// same step, so no crack opens at any level.
#pragma once

#include <cstdint>
#include <vector>

#include "scene/scene.h"

namespace meshmux {

// One level of a progressive mesh: the prefix [0, vertex_end) of the vertices and
// [0, face_end) of the faces, and its geometric error.
struct ProgressiveLevel {
  uint32_t vertex_end = 0;  // vertices in this level
  uint32_t face_end = 0;    // faces that have appeared by this level (some may be degenerate
                            // only at coarser levels; none are at this one)
  uint32_t triangles = 0;   // non-degenerate faces at this level
  float error = 0;          // geometric error of this level: the largest collapse error not yet
                            // undone, in units of the scene's bounding-box diagonal; 0 = full
};

// One block of a big mesh's block hierarchy (simplify's block levels, after Ponchio and
// Dellepiane's Nexus and Kapoulkine's clusterlod): the collapses one spatial block of one level
// made with its border locked, or (blocks[0], the root) those of the whole-unit loop that
// finished the record. Undoing a block's collapses refines its region from its coarser state.
struct ProgressiveBlock {
  uint16_t level = 0;  // block level: 0 the finest (the first run), then coarser; the root's is
                       // one past the last block level
  uint32_t block = 0;  // the block's index in its level (the levels' spatial order); 0 for the root
  float error = 0;     // the largest error of its collapses (units of the scene's diagonal)
  // Once the record is ordered by blocks (simplify/block_dag.h): the blocks to apply first
  // (ascending, each an earlier block) and the mesh-space bounds of what it refines.
  std::vector<uint16_t> deps;
  Vec3 box_min{}, box_max{};
};

struct ProgressiveMesh {
  uint32_t source_mesh = 0;              // index of the Mesh in the conditioned Scene
  std::vector<Vec3> positions;           // per vertex, appearance order, mesh space
  std::vector<Vec3> normals;             // per vertex or empty
  std::vector<std::vector<Vec2>> uvs;    // uv sets, per vertex
  std::vector<Vec4> colors;              // per vertex or empty
  std::vector<uint32_t> parent;          // per vertex: the vertex it split from; itself in the base
  std::vector<uint32_t> indices;         // 3 per face, appearance order, full-mesh corners
  std::vector<uint32_t> face_primitive;  // per face: the source primitive it belongs to; empty
                                         // when the mesh has one (primitive 0: 80 MB at 20M)
  std::vector<int32_t> primitive_material;    // per source primitive: its material
  std::vector<uint8_t> primitive_flat;        // per source primitive: Primitive::flat
  std::vector<uint8_t> primitive_uv_sets;     // per source primitive: how many uv sets it had
  std::vector<uint8_t> primitive_has_colors;  // per source primitive: 1 if it had COLOR_0
  // Levels from the coarsest (levels[0], no collapse left to make) to the full mesh
  // (levels.back(), error 0). Errors never increase from one level to the next.
  std::vector<ProgressiveLevel> levels;
  size_t base_level = 0;  // the level chosen by the stopping rule (Terrace et al. formula 1)
  // The block hierarchy, when the mesh took the block levels (simplify.h block_above); both empty
  // otherwise (one block). level_block[r - 1] is the block of the collapse level r undoes (r ≥ 1),
  // an index into blocks; blocks[0] is the root (the whole-unit loop). At most 65,535 blocks: a
  // level that would pass it is one block (simplify/block_levels.cpp).
  std::vector<uint16_t> level_block;
  std::vector<ProgressiveBlock> blocks;

  size_t face_count() const { return indices.size() / 3; }
  size_t vertex_count() const { return positions.size(); }
};

// Instances of one submesh in the order they return during refinement, for instance thinning
// (Azim, Cheslack-Postava and Levis, "Instance-aware simplification of 3D polygonal meshes"
// §3.2): the level with m instances shows order[0..m), each scaled by sqrt(n/m)
// about its own centre so the total surface area stays that of all n.
struct InstanceOrder {
  uint32_t mesh = 0;            // the Scene mesh
  std::vector<uint32_t> order;  // indices into Scene::instances, refinement order
  std::vector<Vec3> centres;    // per entry of `order`: the world-space centre it scales about
};

struct ProgressiveScene {
  Scene scene;  // the conditioned scene the record refers to (after flattening, when that
                // path was taken): materials, images, instances, lines and mesh names; its
                // primitives keep their material and flags but no vertex or index data (the
                // record below holds the geometry)
  std::vector<ProgressiveMesh> meshes;         // one per Scene mesh, same index
  std::vector<InstanceOrder> instance_orders;  // one per Scene mesh, same index
  bool flattened = false;                      // true when instances per submesh < 1.75 led to
                                               // flatten-then-simplify (Azim et al. §4)
};

}  // namespace meshmux
