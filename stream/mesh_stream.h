// The mesh stream's encoding (the shared vertex buffer of Hoppe, "Octaviewer: spherically
// parameterized progressive meshes", made streamable; the byte layout is specified in
// stream/format.h). The multiplexer costs each mesh layer with these encoders and hands the encoded
// parts on; the package writer lays those bytes out as they are, so every part is encoded exactly
// once per conversion.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "core/encode_counts.h"
#include "scene/progressive.h"
#include "scene/scene.h"
#include "stream/format.h"
#include "stream/quantize.h"
#include "stream/vsplit.h"

namespace meshmux {

// One part of a mesh chunk: the vertices [vertex_begin, vertex_end) and faces
// [face_begin, face_end) of one mesh, coded as `bytes` bytes of compact vertex splits
// (stream/vsplit.h).
struct PackagePart {
  uint32_t mesh = 0, vertex_begin = 0, vertex_end = 0, face_begin = 0, face_end = 0;
  uint64_t bytes = 0;
  int32_t block = -1;  // a block part (stream/format.h "Blocks"): the mesh's block it is; -1 none
};
// What a part's bits code (stream/vsplit.h, in decoding order): Z, M, the fan or mask with
// the face codes, W, P, N, T, and the header with the extra faces.
enum class StreamField { kParent, kMode, kConnectivity, kTwin, kPosition, kNormal, kUv, kOther };
constexpr size_t kStreamFields = 8;
constexpr std::array<const char*, kStreamFields> kStreamFieldNames = {
    "parent", "mode", "connectivity", "twin", "position", "normal", "uv", "other"};

// A part with its coded bytes (stream/vsplit.h): a chunk's payload is its parts' bytes one
// after the other (mesh_chunk_payload).
struct EncodedMeshPart {
  PackagePart part;
  std::vector<uint8_t> data;
  uint32_t twins = 0;  // splits whose position came from a twin (stream/vsplit.h), for tests
  // Per StreamField, the information its decisions carried (RangeEncoder::count_bits): where
  // the part's bits go. Their sum is the bytes' bits less the coder's flush and rounding.
  std::array<double, kStreamFields> field_bits{};
  uint64_t bytes() const { return part.bytes; }  // its coded size (data may have moved on)
};

// One mesh of a completion chunk (stream/format.h "Completion"): its full detail single-rate,
// a Draco bitstream that decodes to `vertices` points and `faces` triangles on the mesh's
// position grid.
struct CompletionMesh {
  uint32_t mesh = 0, vertices = 0, faces = 0;
  std::vector<uint8_t> data;
};

// What the package table says of one mesh, and what its base .glb must hold.
struct MeshStreamBase {
  uint32_t vertices = 0, faces = 0;            // the full progressive mesh
  uint32_t base_vertices = 0, base_faces = 0;  // what the base holds
  Bounds bounds;                               // of every position the stream will hold
  // False when every source primitive is flat-shaded (no normals in the source, glTF 3.7.2.1):
  // the stream then carries no normals (every vertex holds +Z, an empty N stream) and the
  // base .glb has none, so a viewer shades it flat as it does model.glb.
  bool normals = true;
  PositionQuantization quantization;  // the grid positions are coded on
  // Per base vertex in stream order, its progressive-mesh vertex: the base .glb holds the
  // base vertices in this order (the order the base faces first use them).
  std::vector<uint32_t> base_order;
  // The base faces per source primitive that has any (ascending primitive index), in stream
  // vertex indices: the base .glb's primitives hold exactly these index lists, in this order,
  // and the client's base faces are their concatenation as meshopt decodes them.
  std::vector<std::vector<uint32_t>> base_primitive_faces;
  // A block hierarchy (stream/format.h "Blocks"): per block its level, error, box, dependencies
  // and stream ranges; empty for a chain.
  std::vector<StreamBlock> blocks;
};

// Encodes one progressive mesh's stream from a base level on, part by part, as compact vertex
// splits (stream/vsplit.h), simulating what the client holds (its corner lists, and each base
// face's corner rotation as meshopt's index codec decodes it) so that masks and ring positions
// address the client's state exactly. Within a part the splits are reordered (parents before
// children, then by parent) so parents cost small deltas, and the base's vertices are numbered
// in the order its vertex-cache-ordered faces first use them (what meshopt's codecs compress
// best): stream vertex i is pm vertex stream_order()[i]. Memory O(V + F); a part costs O(its splits
// × (the parent's corners + ancestry depth)). The constructor checks the mesh (counts within
// kMaxStreamElements, parents and indices in range); a failure shows in status().
class MeshStreamEncoder {
 public:
  // Each part encoded is counted in `counts` (when given).
  MeshStreamEncoder(const ProgressiveMesh& pm, const PositionQuantization& quantization,
                    uint32_t mesh, size_t base_level, EncodeCounts* counts = nullptr);
  const Status& status() const { return status_; }
  // The base faces per source primitive (MeshStreamBase::base_primitive_faces).
  const std::vector<std::vector<uint32_t>>& base_faces() const { return base_faces_; }
  // The part from the current level to `level` (≥ the current one); then `level` is current.
  // prepare(), adopt() and encode().
  Result<EncodedMeshPart> next(size_t level);
  // A part's splits in stream order and the faces each brings, worked out before they are
  // coded (ancestry walks over the record only, no client state).
  struct PartPlan {
    size_t level = 0;
    uint32_t va = 0, vb = 0, fa = 0, fb = 0;      // the part's vertices and faces
    std::vector<uint32_t> faces_start, faces_of;  // per split: its new faces (one list)
    std::vector<uint32_t> extras;                 // faces sent whole after the splits
    std::vector<uint32_t> order, ranks;           // its splits' pm vertices in stream order; per pm
                                                  // vertex of the part, its stream index
    int32_t block = -1;                           // a block part's block, else -1
    std::vector<uint32_t> candidates;             // a block part's (block_parent_candidates)
    bool morton = true;  // its parents index the candidates in Morton order, else stream numbers
  };
  // The plan of the part from the last level planned to `level`. Reads the encoder's stream
  // indices and writes nothing the encoder reads, so it may run on another thread while
  // encode() codes the part adopted before it. Plans are made in level order, each after the
  // one before it was adopted.
  Result<PartPlan> prepare(size_t level);
  // The plan's stream indices and order made the encoder's (nothing else running); the plan
  // keeps what encode() reads (its faces), its ranks and order are released (8 bytes a split,
  // held beside the client's state at a big record's peak).
  void adopt(PartPlan& plan);
  // Codes an adopted plan against the client's state; plans are encoded in the order made.
  Result<EncodedMeshPart> encode(PartPlan plan);
  // Block parts (a big mesh's block hierarchy, decode_vsplit_block_part): every part starts
  // with fresh contexts, so a client may apply it without the parts before it that it does not
  // depend on, and names its block (PackagePart::block). On from the start for a record with a
  // block hierarchy (ordered by blocks: simplify/block_dag.h order_by_blocks), where each part
  // must then be the levels of one block (prepare() fails otherwise); off gives the chain's
  // coding of the same parts (contexts carried over), for comparison.
  void set_block_parts(bool on) { block_parts_ = on; }
  bool block_parts() const { return block_parts_; }
  // The table's entry of each block (StreamBlock: level, error, box on the grid, dependencies;
  // the ranges, which the reader derives from the parts, left 0) from the record's block
  // hierarchy; empty for a chain or a base that is the whole mesh.
  std::vector<StreamBlock> stream_blocks() const;
  size_t level() const { return level_; }
  const std::vector<uint32_t>& stream_order() const { return order_; }
  // Block parts' parents sent by stream number (outside their block's candidates: stream/vsplit.h
  // "Z"), over every part encoded; 0 when each block's box holds its parents (for tests).
  uint64_t escaped_parents() const { return escaped_parents_; }
  // Whether the stream carries normals (MeshStreamBase::normals).
  bool normals() const { return normals_; }
  // The client's state as the encoder simulates it (for tests).
  const VsplitMesh& client() const { return sim_; }

 private:
  const ProgressiveMesh& pm_;
  PositionQuantization quantization_;
  uint32_t mesh_ = 0;
  size_t level_ = 0;           // the last level encoded
  size_t planned_level_ = 0;   // the last level planned (prepare)
  size_t level_at_start_ = 0;  // the base level
  EncodeCounts* counts_ = nullptr;
  bool normals_ = true;
  bool uvs_ = true;           // the mesh has texture coordinates (else the stream carries none)
  bool block_parts_ = false;  // set_block_parts
  QuantizedVertex quantize(uint32_t pm_vertex) const;  // quantize_vertex, +Z when !normals_
  VsplitMesh sim_;
  // Per client face: the record's face it is, << 2 | the rotation it was added in (its slot s
  // holds the record face's corner (s + rotation) % 3): 4 bytes a face where the full vertex
  // behind each corner took 12 (240 MB at 20M triangles).
  std::vector<uint32_t> face_source_;
  // The full mesh's vertex behind client corner c, as its depth-first position (enter_).
  uint32_t corner_enter(int32_t c) const {
    const uint32_t source = face_source_[size_t(c) / 3];
    const uint32_t slot = (uint32_t(c) % 3 + (source & 3)) % 3;
    return enter_[pm_.indices[size_t(source >> 2) * 3 + slot]];
  }
  std::vector<uint32_t> rank_;   // per pm vertex: its stream index (identity past the parts sent)
  std::vector<uint32_t> order_;  // per stream vertex: its pm vertex
  // The split forest's ancestry as intervals (pm vertices numbered in depth-first order):
  // u is o or an ancestor of o exactly when enter_[u] ≤ enter_[o] < enter_[u] + size_[u].
  std::vector<uint32_t> enter_, size_;
  Status status_;
  std::vector<std::vector<uint32_t>> base_faces_;
  uint32_t rep(uint32_t pm_vertex, uint32_t prefix) const;  // its vertex in the first `prefix`
  // Block parts: the table's blocks (stream_blocks) with the ranges of the parts adopted so far,
  // and the parents sent by stream number.
  std::vector<StreamBlock> blocks_;
  uint64_t escaped_parents_ = 0;
  // The candidates of block `block`'s parents (collect_block_candidates over the stream vertices
  // adopted so far, their positions from the record: the client may be busy coding the part
  // before).
  Status block_candidates(uint32_t block, std::vector<uint32_t>& out);
};

// A mesh chunk's payload: its parts' bytes in order (empty without parts). O(total bytes).
std::vector<uint8_t> mesh_chunk_payload(const std::vector<EncodedMeshPart>& parts);
// The same payload, each part's bytes freed (their pages handed back at once) as they are
// copied: the chunk is made beside one part, not beside all of them (a 20M-triangle record's
// last layer: 12 MB). The parts are left with no data.
std::vector<uint8_t> take_chunk_payload(std::vector<EncodedMeshPart>& parts);

// Whether `pm`'s stream carries normals: false when every source primitive is flat.
bool stream_carries_normals(const ProgressiveMesh& pm);
// Vertex v of `pm` quantized as the stream codes it (stream/quantize.h): position on the grid,
// unit normal ·127 (+Z when absent or zero), first uv set on kUvBits bits.
QuantizedVertex quantize_vertex(const ProgressiveMesh& pm, const PositionQuantization& q,
                                uint32_t v);
// The bounds the stream quantizes `pm`'s positions over: min/max of every finite position
// (all zero for a mesh without any), and the grid over them.
Bounds package_bounds(const ProgressiveMesh& pm);
PositionQuantization package_quantization(const ProgressiveMesh& pm);

}  // namespace meshmux
