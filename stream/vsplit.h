// Compact vertex splits: the stream package's mesh refinement coding (docs/ARCHITECTURE.md
// "Package"), the state both ends keep and the decoder. The encoder is in mesh_stream.cpp; the
// web client runs this decoder itself, compiled to WebAssembly (stream/decoder_api.h).
//
// Ideas taken from the literature on progressive mesh compression:
// - Hoppe's progressive meshes (and his "Octaviewer: spherically parameterized progressive
//   meshes"): a refinement is a vertex split; the new vertex's parent is the vertex it split from,
//   and the faces it brings are (new, parent, w).
// - Compressed progressive meshes (Pajarola & Rossignac) and valence-driven progressive coding
//   (Alliez & Desbrun): splits are sent in batches in an order both ends can derive, so a parent
//   costs a small delta instead of an absolute index; the connectivity of a split is coded
//   relative to the parent's neighbourhood (a bit per corner of the parent: which corners the new
//   vertex takes; the third vertex of each new face as a position in the parent's ring); the new
//   vertex's attributes are predicted from its ring after the split (the barycentric predictor
//   of valence-driven coding) and only the residual is sent.
// Unlike Hoppe's (vl, vr) pair, the per-corner mask needs no manifold ordering: seams, boundaries
// and non-manifold fans code the same way, and the client's adjacency is a list of corners per
// vertex, not a half-edge structure.
//
// One part (a mesh's splits from vertex a to b and faces from c to e, stream/format.h) is one
// stream of the adaptive binary range coder (stream/range_coder.h); a package's mesh chunk is its
// parts one after the other. The contexts (VsplitContexts) belong to the mesh: they start fresh
// with its base and carry over from part to part, as parts of one mesh are only ever applied in
// stream order. In decoding
// order ("uint" is RangeDecoder::get_uint, "tree" get_tree, each through the named contexts):
//   header  two direct bits: 1 when the mesh carries normals, 1 when it carries texture
//           coordinates; a block part a third: 1 when its candidates go in Morton order, 0 in
//           stream numbers (the encoder takes the order its parents cost less in). A mesh without
//           normals (its sources are flat-shaded, glTF 3.7.2.1: viewers derive face normals) gives
//           every new vertex +Z (0, 0, 127); one without texture coordinates gives (0, 0).
//   per split, with d the parent's corner count before the split:
//   Z   uint(parent): zigzag(parent - previous parent) (previous starts at 0 per part). In a
//       block part (decode_vsplit_block_part) the parent is an index into the block's list: its
//       candidates (block_parent_candidates, in Morton order or sorted by stream number as the
//       header says), C of them, then the part's own
//       vertices (C + i for its i-th); index C + splits escapes, followed by uint(escape) the
//       stream number of a held vertex (a parent outside the box's bounds). A block part's
//       splits are ordered by generation, then by that index.
//   M   bit(mode[previous split's mode]): 1 = a fan split (Hoppe's vsplit, fan()); the previous
//       mode starts at 1 per part.
//   fan:  tree5(fan_start[min(d, kFanLimit)]) the list position of vl's corner, then
//         tree5(fan_count[min(d, kFanLimit)]) the count of corners moved - 1. The corners fan()
//         walks move to v and the new faces are (v, p, vl) then (v, vr, p).
//   mask: uint(faces) the number k of new faces, then per corner of p in list order
//         bit(mask[min(position, 7)][previous bit]): 1 = the corner moves to the new vertex;
//         then per new face uint(face): i << 1 | flip: the third vertex w is entry i of the
//         ring (see ring(): v's neighbours, then p's), or i == ring size and w is the next
//         uint(escape); flip 0 makes the face (v, p, w), flip 1 (v, w, p).
//   W   when the parent's position was split from before (twins(): seam and hard-edge copies
//       split together), tree3(twin[candidates]): 0, or i ≥ 1 when the new vertex sits exactly
//       where twin candidate i - 1 does (its position is then not sent).
//   P   without a twin, 3 × uint(position[role][c]) of zigzag(position - prediction), c the
//       bit length of the largest extent of the prediction's ring (at most 15: residuals scale
//       with the local edge length). The axes go in the order plane_axes() gives: the two
//       along the new vertex's fan (roles 0 and 1, predicted by the ring's mean m), then the
//       axis closest to its normal n (role 2), predicted on the fan's plane through m:
//       m_a + round(-(n_b·(x_b - m_b) + n_c·(x_c - m_c)) / n_a) (halves up), the lift of the
//       two decoded coordinates onto the plane (the parallelogram idea of single-rate coders,
//       made from the whole ring). N (when carried): 3 × uint(normal[axis]) of zigzag(normal -
//       prediction). T (when carried): 2 × uint(uv[axis][u]) of zigzag(uv - prediction), u = 1
//       when predict_uv() applied. Predictions: the rounded mean of the new vertex's ring
//       (every other vertex of its faces after the split), or the parent's values when it has
//       none; uv from the decoded position where predict_uv() applies.
//   after the last split: uint(extra) the count x of extra faces, then 3 × uint(escape) each.
// The stream must end exactly there (RangeDecoder::consumed() == its size).
// A split on the state: append vertex v (the next index); move the masked (or walked) corners of p
// to v (each pushed to the head of v's list in the order met); append the new faces (corners pushed
// to their vertices' lists, slot 0 first); set v's attributes; add v as p's position's newest
// twin. Extra faces are appended last. Attributes are integers (stream/quantize.h): positions
// kPositionBits, normals int8, uv kUvBits.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/status.h"
#include "stream/format.h"
#include "stream/range_coder.h"

namespace meshmux {

// A vertex's quantized attributes (stream/quantize.h).
struct QuantizedVertex {
  uint16_t p[3] = {0, 0, 0};  // position on the mesh's grid
  int8_t n[3] = {0, 0, 127};  // normal ·127
  uint16_t t[2] = {0, 0};     // uv ·kUvMax
};
inline bool operator==(const QuantizedVertex& a, const QuantizedVertex& b) {
  for (int i = 0; i < 3; ++i)
    if (a.p[i] != b.p[i] || a.n[i] != b.n[i]) return false;
  return a.t[0] == b.t[0] && a.t[1] == b.t[1];
}

constexpr uint32_t kRingLimit = 64;  // ring entries a new face's third vertex is coded against
constexpr uint32_t kTwinLimit = 4;   // twin candidates a new vertex's position is matched against
constexpr uint32_t kFanLimit = 32;   // corners a parent may have for a fan-coded split
constexpr int kExtentClasses = 16;   // position contexts per axis (ring extent's bit length)
// Attribute residuals model this many bits below the leading one (the rest are near uniform and
// go direct: fewer decisions to decode for the same bytes); other integers model three.
constexpr int kResidualModelledBits = 1;
// A part's splits and faces may be at most this many per coded byte, plus a constant: every
// split costs at least a few dozen decisions of ≥ 0.02 bits, so real parts stay far below; a
// hostile table cannot make a few bytes stand for millions of splits.
constexpr uint64_t kPartElementsPerByte = 256;
constexpr uint64_t kPartElementsConstant = 4096;

// The coder's adaptive contexts of one mesh (both ends): fresh with its base (VsplitMesh::reset),
// carried over from part to part.
struct VsplitContexts {
  UIntContext parent, faces, face, escape, extra;
  uint16_t mode[2];
  uint16_t mask[8][2];
  TreeContext<5> fan_start[kFanLimit + 1], fan_count[kFanLimit + 1];
  TreeContext<3> twin[kTwinLimit + 1];
  UIntContext position[3][kExtentClasses], normal[3], uv[2][2];
  VsplitContexts();
};

// What one end of the stream holds of one mesh: vertices with quantized attributes, faces in
// the order received (3 corners each; corner c is slot c % 3 of face c / 3), per vertex the
// list of corners naming it (head, then next per corner; -1 ends), and the coder's contexts.
class VsplitMesh {
 public:
  // Capacities bound what decoding may add (the package table's full counts); memory grows
  // with what is held, not with the capacities.
  void reset(uint32_t capacity_vertices, uint32_t capacity_faces);
  // Allocates the capacities at once, for a side that knows it will reach them (the encoder
  // holds the whole record): grown by doubling, a 4M-triangle record's corner lists held up to
  // twice their size, and both copies while moving (~170 MB over 96 MB). Never on the decoding
  // side, whose capacities come from the package. `twin_positions`: at most how many positions
  // splits will come from (the twin table is sized for them, at most three quarters full: the
  // parents' count; sized for every vertex, a scan's table held twice the slots, 67 MB more at
  // 20M triangles); more positions than that only grow it.
  void reserve_capacities(size_t twin_positions);
  uint32_t vertex_count() const { return uint32_t(vertices.size()); }
  uint32_t face_count() const { return uint32_t(indices.size() / 3); }
  uint32_t capacity_vertices() const { return capacity_vertices_; }
  uint32_t capacity_faces() const { return capacity_faces_; }

  uint32_t add_vertex(const QuantizedVertex& q);  // returns its index
  // Block parts (decode_vsplit_block_part): vertex `index` placed where the stream numbers it,
  // the indices between the last one and it left as holes until their blocks arrive. Needs
  // index ≥ vertex_count() or a hole there.
  void add_vertex_at(uint32_t index, const QuantizedVertex& q);
  // Whether vertex v is held (below vertex_count() and not a hole).
  bool has_vertex(uint32_t v) const {
    return v < vertices.size() && (holes_.empty() || !holes_[v]);
  }
  void add_face(uint32_t a, uint32_t b, uint32_t c);
  // Moves corner `corner` (in p's list, after `previous`, or at its head when previous < 0) to
  // the head of v's list.
  void move_corner(uint32_t p, int32_t previous, int32_t corner, uint32_t v);
  // The vertices of the faces around v then p (the other two corners of each face in list
  // order), without p, v or repeats, at most `limit`: after the corner moves, a new face's
  // third vertex bounds v's fan, so it comes early. O(corners of p and v).
  void ring(uint32_t p, uint32_t v, uint32_t limit, std::vector<uint32_t>& out);
  // Hoppe's vertex split on a manifold fan: p's corners in list order (at most kFanLimit, every
  // face non-degenerate, the vertex following p in each face, n1, distinct); walking from the
  // corner at list position `start` (n1 = vl) to the corner whose n1 is the previous one's
  // following-following vertex (n2), `count` corners. Marks them in `moved` (per list position)
  // and sets vl and the last corner's n2, vr. False when p's fan does not allow it. O(count ·
  // kFanLimit).
  bool fan(uint32_t p, uint32_t start, uint32_t count, std::vector<uint8_t>& moved, uint32_t& vl,
           uint32_t& vr) const;
  // v's uv predicted from its position (parallelogram-style, as Draco predicts texture
  // coordinates): w is the third vertex of v's newest face with p, x the third vertex of p's
  // first face with w but not v; v's offset along and off the edge p→w in 3D, relative to its
  // length, is carried to uv space on the side of that edge away from x. Overwrites uv and
  // returns true when those faces exist and the edge has length. O(corners of v and p).
  bool predict_uv(uint32_t v, uint32_t p, const uint16_t position[3], uint16_t uv[2]) const;
  // v's predicted attributes: the rounded mean over its ring (all of it), or p's values; and
  // the position context: the bit length of the ring's largest extent along an axis (max -
  // min), at most kExtentClasses - 1 (0 without a ring).
  QuantizedVertex predict(uint32_t v, uint32_t p, uint32_t* extent_class);
  // The normal of v's fan seen from `centre` (its predicted position): the sum over v's faces
  // (v, b, c) of (b - centre) × (c - centre), exact in integers, then halved (floor) all three
  // together until each is below 2^31 in magnitude. O(corners of v).
  void fan_normal(uint32_t v, const uint16_t centre[3], int64_t normal[3]) const;
  // The vertices split so far from parents at p's position, newest first, at most kTwinLimit,
  // into out; returns how many. O(kTwinLimit).
  uint32_t twins(uint32_t p, uint32_t* out) const;
  // Records v (split from p, attributes set) as the newest twin at p's position.
  void add_twin(uint32_t p, uint32_t v);

  std::vector<QuantizedVertex> vertices;
  std::vector<uint32_t> indices;
  std::vector<int32_t> head, next;
  uint64_t solid = 0;  // faces whose three corners differ
  // Corners below moved_floor that move_corner moves are appended to `moved` (a client that
  // mirrors the index buffer copies only those again; the web worker's changes). 0: none.
  uint32_t moved_floor = 0;
  std::vector<uint32_t> moved;
  VsplitContexts contexts;  // the coder's, fresh at reset(), carried from part to part

 private:
  // Parent position → newest split there: open addressing with linear probing over a
  // power-of-two table at most three quarters full. A slot holds (rep + 1) << 32 | latest, where
  // rep is a vertex at the slot's position (vertices never move, so it stands for the key: 8
  // bytes a slot where the position itself took 12) and latest the newest split there; 0 marks
  // an empty slot. At 20M triangles the table is the client state's largest after the corners.
  std::vector<uint64_t> twin_slots_ = std::vector<uint64_t>(16, 0);
  size_t twin_count_ = 0;
  std::vector<int32_t> twin_previous_;  // per vertex: the twin before it, or -1
  // The slot of the position of vertex p, or the empty one where it would go.
  size_t twin_slot(const QuantizedVertex& at) const;
  void twin_table_resize(size_t slots);  // rehashes into `slots` (a power of two)
  // The vertices one ring() or predict() call has met, where a stamp per vertex cost 4 bytes of
  // every client's state (40 MB at 20M triangles): a short list searched in turn (a ring has a
  // dozen), and past kSeenListed an open-addressing set (a power of two of slots, at most half
  // full, emptied through the slots it used) for the rare vertex of high valence.
  static constexpr size_t kSeenListed = 24;
  std::vector<uint32_t> seen_list_;
  bool seen_hashed_ = false;
  std::vector<uint32_t> seen_slots_ = std::vector<uint32_t>(64, UINT32_MAX);
  std::vector<uint32_t> seen_used_;  // slots filled in this call
  bool first_sight(uint32_t w);      // adds w; false when it was there already
  bool hash_sight(uint32_t w);       // first_sight in the set
  void forget_seen();
  uint32_t capacity_vertices_ = 0, capacity_faces_ = 0;
  std::vector<uint8_t> holes_;  // per vertex: 1 where a block's vertex has not arrived; empty:
                                // none ever (parts applied in stream order)
  friend Status decode_vsplit(VsplitMesh&, const uint8_t*, size_t, uint32_t, uint32_t, uint32_t,
                              const std::vector<uint32_t>*);
};

// The order a new vertex's position axes are coded in (stream/vsplit.h "P"): the two axes
// other than a in increasing order, then a, the axis of the normal's largest magnitude (the
// lowest on ties); returns false (order 0, 1, 2, no plane prediction) for a zero normal.
bool plane_axes(const int64_t normal[3], int order[3]);
// The plane prediction of axis order[2]: m_a + round(-(n_b·(x_b - m_b) + n_c·(x_c - m_c)) / n_a),
// halves up (|n| < 2^31 and coordinates < 2^16 keep every step exact, in doubles too).
int64_t plane_predict(const int64_t normal[3], const int order[3], const uint16_t mean[3],
                      int64_t xb, int64_t xc);

// Whether `bytes` coded bytes may stand for `splits` splits and `faces` faces: at least the
// coder's kRangeCoderFlushBytes, and splits + faces ≤ kPartElementsPerByte·bytes +
// kPartElementsConstant.
bool part_size_plausible(uint64_t bytes, uint64_t splits, uint64_t faces);

// Appends one part to `mesh`: decodes `data` (the part's coded bytes), applies `splits` splits
// and checks that exactly `faces` faces were appended and every byte was used. Every count,
// index and length is checked before use; errors name the problem ("split 12: parent 4001 of
// 4000 vertices"). Work is O(splits × the parents' corners + faces), the counts bounded by
// part_size_plausible. On error the mesh is left in an unspecified but valid state.
Status decode_vsplit_part(VsplitMesh& mesh, const uint8_t* data, size_t size, uint32_t splits,
                          uint32_t faces);

// The vertices a part of block `block` may split, as its parents are coded (stream/format.h
// "Blocks", "Z" of a block part): the base's [0, base_vertices), then the vertex ranges of the
// block's ancestors (its dependencies, theirs, and so on) whose boxes meet its box, keeping those
// whose position lies in its box (bounds included), in Morton order of their position within the
// box (block_candidate_key; ties by stream number): a block's parents lie in its own part of
// the box, so they come in runs and cost what a chain's do, where in stream numbers they were
// spread among the box's other vertices. Every ancestor is applied before the block, so each
// vertex of those ranges must be held (a hole means a dependency is missing: an error naming
// both blocks). `blocks` carries the ranges (the reader derives them from the parts). Into `out`
// (cleared). O(blocks + dependencies + the vertices of the ranges scanned + c log c for the c
// listed).
Status block_parent_candidates(const VsplitMesh& mesh, const std::vector<StreamBlock>& blocks,
                               uint32_t base_vertices, uint32_t block, std::vector<uint32_t>& out);

// The same list where the positions are not held in a VsplitMesh (the encoder plans a part while
// its client is busy): `held(v)` whether stream vertex v is held, `position(v)` its position on
// the grid (std::array<uint16_t, 3>).
template <class Held, class Position>
Status collect_block_candidates(const std::vector<StreamBlock>& blocks, uint32_t base_vertices,
                                uint32_t block, Held held, Position position,
                                std::vector<uint32_t>& out);

// The Morton order key of grid position p within `box` (min x, y, z, max x, y, z): the bits of
// p - min interleaved, x lowest. p inside the box.
inline uint64_t block_candidate_key(const uint16_t p[3], const uint16_t box[6]) {
  auto spread = [](uint64_t x) {  // 16 bits to every third of 48
    x = (x | x << 16) & 0x0000FF0000FFull;
    x = (x | x << 8) & 0x00F00F00F00Full;
    x = (x | x << 4) & 0x0C30C30C30C3ull;
    return (x | x << 2) & 0x249249249249ull;
  };
  return spread(uint16_t(p[0] - box[0])) | spread(uint16_t(p[1] - box[1])) << 1 |
         spread(uint16_t(p[2] - box[2])) << 2;
}

template <class Held, class Position>
Status collect_block_candidates(const std::vector<StreamBlock>& blocks, uint32_t base_vertices,
                                uint32_t block, Held held, Position position,
                                std::vector<uint32_t>& out) {
  out.clear();
  if (block >= blocks.size())
    return Status::error("block " + std::to_string(block) + " of " + std::to_string(blocks.size()),
                         ErrorKind::kInput);
  const uint16_t* box = blocks[block].box;
  auto meets = [&](const uint16_t* b) {
    for (int i = 0; i < 3; ++i)
      if (b[i] > box[3 + i] || box[i] > b[3 + i]) return false;
    return true;
  };
  std::vector<std::pair<uint64_t, uint32_t>> keyed;  // (Morton key, stream number)
  auto scan = [&](uint32_t begin, uint32_t end, int64_t from) -> Status {
    for (uint32_t v = begin; v < end; ++v) {
      if (!held(v))
        return Status::error("block " + std::to_string(block) + ": vertex " + std::to_string(v) +
                                 (from < 0 ? " of the base" : " of block " + std::to_string(from)) +
                                 " (a dependency) is not held",
                             ErrorKind::kInput);
      const std::array<uint16_t, 3> p = position(v);
      if (p[0] >= box[0] && p[0] <= box[3] && p[1] >= box[1] && p[1] <= box[4] && p[2] >= box[2] &&
          p[2] <= box[5])
        keyed.emplace_back(block_candidate_key(p.data(), box), v);
    }
    return Status::ok();
  };
  if (Status s = scan(0, base_vertices, -1); !s) return s;
  // Ancestors: every dependency is an earlier block, so one pass down from the block marks them.
  std::vector<uint8_t> ancestor(size_t(block) + 1, 0);
  ancestor[block] = 1;
  for (size_t j = block + 1; j-- > 0;) {
    if (!ancestor[j]) continue;
    for (uint32_t d : blocks[j].deps)
      if (d < j) ancestor[d] = 1;
  }
  for (uint32_t j = 0; j < block; ++j) {
    const StreamBlock& b = blocks[j];
    if (!ancestor[j] || b.vertex_end <= b.vertex_begin || !meets(b.box)) continue;
    if (b.vertex_begin < base_vertices)
      return Status::error("block " + std::to_string(j) + " begins inside the base",
                           ErrorKind::kInput);
    if (Status s = scan(b.vertex_begin, b.vertex_end, j); !s) return s;
  }
  std::sort(keyed.begin(), keyed.end());
  out.resize(keyed.size());
  for (size_t i = 0; i < keyed.size(); ++i) out[i] = keyed[i].second;
  return Status::ok();
}

// A block part (the stream of a big mesh's block hierarchy, simplify/block_dag.h): the splits
// of block `block`, which a client applies once the blocks it depends on are, in any order
// among the others. Its coding is decode_vsplit_part's with three differences: the contexts
// start fresh with the part (they do not carry over from whatever part came before); its
// vertices are placed at their stream numbers [vertex_begin, vertex_begin + splits) of the
// block rather than appended, so a face's vertex or an extra face names a vertex by the
// stream's number whatever blocks the client holds (each must be held: one missing means a
// dependency was not applied); and a parent is coded as its index in the block's candidates
// (block_parent_candidates, then the part's own vertices) rather than its stream number. Faces
// are appended. Errors as decode_vsplit_part's, and block_parent_candidates'.
Status decode_vsplit_block_part(VsplitMesh& mesh, const uint8_t* data, size_t size,
                                const std::vector<StreamBlock>& blocks, uint32_t base_vertices,
                                uint32_t block, uint32_t splits, uint32_t faces);

// FNV-1a (32-bit) over a client state: per vertex its position (3 little-endian u16), normal
// (3 i8) and uv (2 little-endian u16), then every index (little-endian u32). What a client that
// decoded the whole stream must hold; report.json carries it per mesh ("stream_digests") and
// the browser test checks the web client against it.
uint32_t state_digest(const VsplitMesh& mesh);

inline uint32_t zigzag(int32_t v) { return (uint32_t(v) << 1) ^ uint32_t(v >> 31); }
inline int32_t unzigzag(uint32_t v) { return int32_t(v >> 1) ^ -int32_t(v & 1); }

}  // namespace meshmux
