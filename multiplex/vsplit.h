// Compact vertex splits: the stream package's mesh refinement coding (DESIGN.md "Package",
// "Encoding"), the state both ends keep and the decoder. The encoder is in mesh_stream.cpp; the
// web client (viewers/web/meshmux.js, VsplitMesh) mirrors this file operation for operation.
//
// Ideas taken from the literature on progressive mesh compression:
// - Hoppe's progressive meshes / paper 002: a refinement is a vertex split; the new vertex's
//   parent is the vertex it split from, and the faces it brings are (new, parent, w).
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
// One part (a mesh's splits from vertex a to b and faces from c to e, package.h) is ten
// varint-counted byte streams, each field in its own so deflate's codes fit its values; a
// package's mesh chunk is its parts one after the other in one raw deflate stream (browsers
// inflate it with DecompressionStream("deflate-raw")), so small parts share its code tables:
//   varint |Z| |K| |F| |M| |E| |W| |P| |N| |T| |A|, then Z K F M E W P N T A
//   Z  per split: zigzag(parent - previous parent) (previous starts at 0 per part).
//   M  per split, a mode bit, then for a mask split one bit per corner in the parent's corner
//      list (in list order, before the split): 1 = the corner moves to the new vertex. Bits LSB
//      first, no padding between splits.
//   A  per fan split (mode bit 1; Hoppe's vsplit, fan()): one byte, the list position of vl's
//      corner (< kFanLimit) << 3 | min(the count of corners moved - 1, 7), and when that is 7,
//      a varint: the count - 8. One symbol, so deflate codes the pair's joint frequencies. The
//      corners fan() walks move to v and the new faces are (v, p, vl) then (v, vr, p).
//   K  per mask split: the number k of new faces; after the last split, the count x of extra
//      faces.
//   F  per new face of a mask split (i << 1 | flip): the third vertex w is entry i of the ring
//      (see ring(): v's neighbours, then p's), or i == ring size and w is the next varint of E;
//      flip 0 makes the face (v, p, w), flip 1 (v, w, p).
//   E  escaped third vertices (varint vertex indices), then the x extra faces (3 varints each).
//   W  per split whose parent's position was split from before (twins(): seam and hard-edge
//      copies split together): 0, or i ≥ 1 when the new vertex sits exactly where twin
//      candidate i - 1 does (its position is then not sent).
//   P  per split without a twin, 3 × zigzag(position - prediction); N: 3 × zigzag(normal -
//   prediction); T: 2 × zigzag(uv - prediction). Predictions: the rounded mean of the new
//      vertex's ring (every other vertex of its faces after the split), or the parent's values
//      when it has none; uv from the decoded position where predict_uv() applies.
//      N is empty when the mesh carries no normals (its sources are flat-shaded, glTF 3.7.2.1:
//      viewers derive face normals): every new vertex's normal is then +Z (0, 0, 127).
// A split on the state: append vertex v (the next index); move the masked (or walked) corners of p
// to v (each pushed to the head of v's list in the order met); append the new faces (corners pushed
// to their vertices' lists, slot 0 first); set v's attributes; add v as p's position's newest
// twin. Extra faces are appended last. Attributes are integers (scene/quantize.h): positions
// kPositionBits, normals int8, uv kUvBits.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "scene/status.h"

namespace meshmux {

// A vertex's quantized attributes (scene/quantize.h).
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
constexpr int kVsplitStreams = 10;   // byte streams in a part
constexpr uint32_t kFanLimit = 32;   // corners a parent may have for a fan-coded split
// Inflated bytes a part may hold: per split and face, and a constant (zlib bombs are refused).
constexpr uint64_t kPartBytesPerElement = 256;
constexpr uint64_t kPartBytesConstant = 1 << 16;

// What one end of the stream holds of one mesh: vertices with quantized attributes, faces in
// the order received (3 corners each; corner c is slot c % 3 of face c / 3) and, per vertex,
// the list of corners naming it (head, then next per corner; -1 ends).
class VsplitMesh {
 public:
  // Capacities bound what decoding may add (the package table's full counts); memory grows
  // with what is held, not with the capacities.
  void reset(uint32_t capacity_vertices, uint32_t capacity_faces);
  uint32_t vertex_count() const { return uint32_t(vertices.size()); }
  uint32_t face_count() const { return uint32_t(indices.size() / 3); }

  uint32_t add_vertex(const QuantizedVertex& q);  // returns its index
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
  // v's predicted attributes: the rounded mean over its ring (all of it), or p's values.
  QuantizedVertex predict(uint32_t v, uint32_t p);
  // The vertices split so far from parents at p's position, newest first, at most kTwinLimit,
  // into out; returns how many. O(kTwinLimit).
  uint32_t twins(uint32_t p, uint32_t* out) const;
  // Records v (split from p, attributes set) as the newest twin at p's position.
  void add_twin(uint32_t p, uint32_t v);

  std::vector<QuantizedVertex> vertices;
  std::vector<uint32_t> indices;
  std::vector<int32_t> head, next;
  uint64_t solid = 0;  // faces whose three corners differ

 private:
  std::unordered_map<uint64_t, uint32_t> twin_latest_;  // parent position → newest split
  std::vector<int32_t> twin_previous_;                  // per vertex: the twin before it, or -1
  std::vector<uint32_t> stamp_;
  uint32_t stamp_value_ = 0;
  uint32_t capacity_vertices_ = 0, capacity_faces_ = 0;
  friend Status decode_vsplit_part(VsplitMesh&, const uint8_t*, size_t, uint32_t, uint32_t);
  uint32_t new_stamp();
};

// The most bytes a part of `splits` splits and `faces` faces may hold (zlib bombs are refused):
// kPartBytesPerElement·(splits + faces) + kPartBytesConstant.
uint64_t part_byte_limit(uint64_t splits, uint64_t faces);

// Appends one part to `mesh`: decodes `data` (the part's bytes, inflated), applies `splits`
// splits and checks that exactly `faces` faces were appended. Every count, index and length is
// checked before use; errors name the problem ("split 12: parent 4001 of 4000 vertices"). Work
// is bounded by the size, itself at most part_byte_limit(splits, faces). On error the mesh is
// left in an unspecified but valid state.
Status decode_vsplit_part(VsplitMesh& mesh, const uint8_t* data, size_t size, uint32_t splits,
                          uint32_t faces);

// FNV-1a (32-bit) over a client state: per vertex its position (3 little-endian u16), normal
// (3 i8) and uv (2 little-endian u16), then every index (little-endian u32). What a client that
// decoded the whole stream must hold; report.json carries it per mesh ("stream_digests") and
// the browser test checks the web client against it.
uint32_t state_digest(const VsplitMesh& mesh);

// Byte-stream helpers shared with the encoder.
void put_varint(std::vector<uint8_t>& out, uint32_t v);
inline uint32_t zigzag(int32_t v) { return (uint32_t(v) << 1) ^ uint32_t(v >> 31); }
inline int32_t unzigzag(uint32_t v) { return int32_t(v >> 1) ^ -int32_t(v & 1); }
// zlib-compresses (level 9) / inflates at most `limit` bytes (an error past it).
std::vector<uint8_t> deflate_bytes(const std::vector<uint8_t>& in);
Result<std::vector<uint8_t>> inflate_bytes(const uint8_t* data, size_t size, uint64_t limit);
// The same as raw deflate (RFC 1951, no zlib header or checksum): mesh chunks. An empty result
// from deflate_raw is a zlib failure.
std::vector<uint8_t> deflate_raw(const std::vector<uint8_t>& in);
Result<std::vector<uint8_t>> inflate_raw(const uint8_t* data, size_t size, uint64_t limit);

}  // namespace meshmux
