// The block hierarchy of a big mesh's record as a DAG (Ponchio and Dellepiane, "Multiresolution
// and fast decompression for optimal web-based rendering", the batched multi-triangulation of
// Nexus; Hoppe, "View-dependent refinement of progressive meshes", for the idea that a vertex
// split needs only its neighbourhood as it was when it was recorded). A block's refinement (the
// vertex splits undoing its collapses, ProgressiveMesh::level_block) may be applied once the
// blocks it depends on are: then every split reads exactly the neighbourhood it read in the
// record's own order, whatever other blocks are applied and in which order, so any
// dependency-closed set of blocks, applied in any order that respects the dependencies, gives
// one mesh state: the same faces, the same corners, the same per-vertex corner lists in the
// same order (what a decoder's coding reads).
//
// What a split reads and writes (BlockReplay::apply_level, the semantics of stream/vsplit.h's
// client state): a new vertex v splits from its parent p; the corners of p whose full-mesh
// vertex now maps to v move from p's list to the head of v's, in list order; then the level's
// new faces are appended, corners mapped to the nearest present ancestor and pushed onto their
// vertices' lists (slot 0 first). The level writes the lists of p, v and every new face's
// corners, the faces whose corners move and the new faces, and the twin chain at p's position;
// it reads every face on p's and v's lists (the ring, the predictors). Dependencies: a block
// depends on the last block that wrote what it reads or writes, and a writer on every block
// that read the face since (read-after-write, write-after-read, write-after-write). Lists and
// positions have one block a level (blocks partition positions); a face may be read by up to
// three blocks of one level (one per corner), never written by two.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <vector>

#include "core/status.h"
#include "scene/progressive.h"

namespace meshmux {

// One block of the DAG.
struct BlockNode {
  std::vector<uint16_t> deps;  // blocks to apply before this one, ascending, transitively
                               // reduced (none of them reachable through another)
  Vec3 box_min{}, box_max{};   // bounds of what it refines: its vertices and the vertices
                               // whose corner lists it touches (mesh space)
  float error = 0;             // ProgressiveBlock::error
  uint32_t levels = 0;         // record levels (collapses undone) in the block
  uint32_t vertices = 0;       // vertices it adds
  uint32_t faces = 0;          // faces it adds
  uint32_t first_level = 0;    // its first level in the record (1-based level index)
};

struct BlockDag {
  std::vector<BlockNode> nodes;  // per ProgressiveMesh::blocks entry
};

// The DAG of a record with a block hierarchy (pm.blocks non-empty): one replay of every level in
// record order. Errors (kInternal) name the block when the record's own order is not a
// topological order of what it found (a cycle: blocks of one level that touched the same list).
// O(faces × the corners walked per split + levels); memory ~22 bytes per face and ~26 per vertex
// beside the record. A block's box: the positions of the vertices whose lists it touches.
Result<BlockDag> block_dag(const ProgressiveMesh& pm);

// Renumbers a record with a block hierarchy so that each block's levels are contiguous: the
// root's first, then the blocks from the coarsest level to the finest (within a level, larger
// error first, then by index), each block's levels in their record order. A block depends only on
// coarser ones (block_dag.h: its locked borders keep a level's blocks apart), so this is a
// topological order of the DAG, and every split keeps its parent, its faces and the neighbourhood
// it reads: the same progressive mesh, its vertices and faces renumbered (block_dag() of the
// result, or a stream's decoding, fails where that would not hold). The root's levels keep their
// errors; past them, a level's error becomes the largest error of the blocks not yet fully applied
// (ProgressiveBlock::error: never below the true one, never increasing with detail); the base
// level stays where it was when the root holds it, else it becomes the root's last level. The
// root (the whole-unit loop's chain) becomes pieces of a quarter more triangles each from the
// coarsest level (at least 1,024 triangles each), blocks of their own in a chain; the other blocks
// are renumbered in the order their runs come after them (coarser before finer, so every dependency
// is an earlier block), those that made no collapse dropped. A block that is a
// part of the stream is then one run of vertices and faces. Fails (kInternal)
// when the record has no block hierarchy or its level blocks do not fit it.
// O(V + F + levels log levels); memory: the new places of every vertex and face (12 bytes a
// face), then each array copied once in its new order (one at a time).
Status order_by_blocks(ProgressiveMesh& pm);

// What the stream needs of every block-built record of `ps` (pm.blocks non-empty; others are
// left as they are): order_by_blocks, then block_dag, each block's dependencies and box kept in
// pm.blocks. The pipeline calls it once the scene the record was made from is freed (at 20M
// triangles the DAG's replay beside that scene would be the conversion's peak). Errors
// (kInternal) name the mesh: a record that is not a block hierarchy the DAG can be made of.
Status order_block_records(ProgressiveScene& ps);

// A client state of a record, refined level by level in any order the caller chooses: the
// replay block_dag() makes, for tests and analysis. Starts at the coarsest level (levels[0]).
class BlockReplay {
 public:
  // `keep_corners`: hold every face's current corners (corners(), signatures); without them
  // (block_dag's replay) 12 bytes a face less.
  explicit BlockReplay(const ProgressiveMesh& pm, bool keep_corners = true);
  // Applies record level r (1 ≤ r < levels): its vertices then its faces. Fails (kInternal,
  // naming the level and vertex) when a parent is not present or a new face is degenerate:
  // what a set that is not dependency-closed gives.
  Status apply_level(size_t r);
  bool present(uint32_t v) const { return present_[v] != 0; }
  bool appeared(uint32_t f) const { return appeared_[f] != 0; }
  // Face f's corners as held (its full-mesh corners mapped as the splits moved them); needs
  // keep_corners.
  std::array<uint32_t, 3> corners(uint32_t f) const {
    return {cur_[3 * size_t(f)], cur_[3 * size_t(f) + 1], cur_[3 * size_t(f) + 2]};
  }
  // The corners (3 × face + slot) on v's list, head first.
  std::vector<uint32_t> corner_list(uint32_t v) const;
  // The nearest present ancestor of record vertex v (v itself when present).
  uint32_t mapped(uint32_t v) const;

  // What the last apply_level read and wrote (block_dag's input), each list without repeats.
  std::vector<uint32_t> lists_touched, faces_written, faces_read, parents;
  // With `signatures` on, the last apply_level's neighbourhood as its splits read it: a hash
  // over each split's parent, the parent's list before and both lists after (each corner with
  // its face's three corners, in list order) and the twins split earlier at the parent's
  // position (newest first). Equal signatures for a level in two states: its splits read the
  // same things. Off (or without keep_corners): 0.
  bool signatures = false;
  uint64_t signature = 0;

 private:
  const ProgressiveMesh& pm_;
  std::vector<uint8_t> present_, appeared_;
  std::vector<uint32_t> cur_;
  std::vector<int32_t> head_, next_;
  std::vector<uint8_t> mark_face_, mark_list_;  // scratch: met in this level
  std::vector<uint32_t> met_;                   // scratch: the faces met in this level
  bool keep_corners_ = true;
  // The split forest's ancestry as intervals: u is o or an ancestor of o exactly when
  // enter_[u] ≤ enter_[o] < enter_[u] + size_[u] (the stream encoder's test).
  std::vector<uint32_t> enter_, size_;
  // With signatures: per parent position's bits, the vertices split there, oldest first.
  std::map<std::array<uint32_t, 3>, std::vector<uint32_t>> twins_;
  std::vector<uint32_t>& twins_at(uint32_t p);
  void sign(uint64_t value) { signature = (signature ^ value) * 1099511628211ull; }
  void sign_list(uint32_t v);
};

}  // namespace meshmux
