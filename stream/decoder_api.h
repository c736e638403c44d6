// The stream decoder's C API: what the web client's worker calls once stream/ is compiled to
// WebAssembly (viewers/web/stream_decoder.js loads the module; CMake builds it as
// stream_decoder.wasm with clang --target=wasm32-wasi, docs/ARCHITECTURE.md "The web
// decoder"). One handle per package mesh holds a VsplitMesh (stream/vsplit.h); the caller
// hands bytes in through buffers it allocates here (mmx_alloc) and reads what changed straight
// from the state's arrays (pointers into the module's memory, valid until the next call on the
// handle). Every call that can fail returns 0 on success, else 1 with mmx_error() naming the
// problem ("split 12: parent 4001 of 4000 vertices"); a handle whose call failed is not used
// again but may be freed. No exceptions: errors are values (core/status.h) all the way out.
//
// The package table is not read here: the client fetches and checks it (package_reader.js),
// and each part's counts are checked again by mmx_apply_part (part_size_plausible, the mesh's
// capacity) before a byte is decoded, as decode_part does natively.
#pragma once

#include <cstddef>
#include <cstdint>

extern "C" {

// Memory for the caller's buffers (inputs: base attributes, faces, part bytes); null when the
// module's memory cannot grow.
void* mmx_alloc(size_t bytes);
void mmx_free(void* p);

// The last failure's message (UTF-8, not terminated) and its length in bytes.
const char* mmx_error();
size_t mmx_error_length();

// A mesh's decoding state with the package table's full counts as capacities (each at most
// kMaxStreamElements); null when they exceed it.
struct MmxMesh;
MmxMesh* mmx_mesh_new(uint32_t capacity_vertices, uint32_t capacity_faces);
void mmx_mesh_free(MmxMesh* mesh);

// The base's vertices, quantized (stream/quantize.h): `count` of them from p (3 per vertex),
// n (3) and t (2). Only on a fresh state.
int mmx_set_base(MmxMesh* mesh, const uint16_t* p, const int8_t* n, const uint16_t* t,
                 uint32_t count);
// Appends base faces (3 corners each, `corners` in all) to the state: whole faces, within the
// capacity, every corner naming a vertex received.
int mmx_append_faces(MmxMesh* mesh, const uint32_t* indices, uint32_t corners);
// Starts listing the corners of the faces held now that later splits move (mmx_moved): what a
// client that mirrors the index buffer must copy again.
void mmx_begin_changes(MmxMesh* mesh);
// Applies one part: `size` coded bytes at `data` standing for `splits` splits and `faces`
// faces (stream/vsplit.h decode_vsplit_part).
int mmx_apply_part(MmxMesh* mesh, const uint8_t* data, size_t size, uint32_t splits,
                   uint32_t faces);
// A block mesh's blocks (stream/format.h "Blocks"), which its block parts are decoded against:
// `count` words, per block in table order its box on the grid (6: min x, y, z, max x, y, z),
// its stream vertex range (2: begin, end, as the reader derives them from the parts), the
// number d of its dependencies, then those d block indices (ascending, each an earlier block).
// Checked as read (a box past 16 bits, a range past the capacity, a dependency on itself or a
// later block are refused); replaces any blocks set before.
int mmx_set_blocks(MmxMesh* mesh, const uint32_t* words, uint32_t count);
// Applies the part of block `block` (of those mmx_set_blocks gave; stream/vsplit.h
// decode_vsplit_block_part): fresh contexts, its `splits` vertices placed at the block's stream
// numbers, its parents read against the block's candidates (the base as mmx_set_base gave it,
// and its ancestors' vertices in its box).
int mmx_apply_block_part(MmxMesh* mesh, const uint8_t* data, size_t size, uint32_t block,
                         uint32_t splits, uint32_t faces);

uint32_t mmx_vertices(const MmxMesh* mesh);
uint32_t mmx_faces(const MmxMesh* mesh);
uint32_t mmx_solid(const MmxMesh* mesh);  // faces whose three corners differ
// The index buffer (3 per face).
const uint32_t* mmx_indices(const MmxMesh* mesh);
// The corners of faces held at mmx_begin_changes that splits moved since, in the order moved
// (one moved twice is listed twice), mmx_moved_count of them; their vertices are in mmx_indices.
const uint32_t* mmx_moved(const MmxMesh* mesh);
uint32_t mmx_moved_count(const MmxMesh* mesh);
// Float attributes of vertices [v0, vn) into position (3 per vertex), normal (3) and uv (2):
// positions as the grid's integers when `quantized` (the base .glb's nodes dequantize), else
// origin + q·step in mesh units; normals q/127; uvs q/kUvMax. vn ≤ mmx_vertices.
void mmx_dequantize(const MmxMesh* mesh, uint32_t v0, uint32_t vn, float* position, float* normal,
                    float* uv, int quantized, double ox, double oy, double oz, double step);
// stream/vsplit.h state_digest: report.json's "stream_digests".
uint32_t mmx_digest(const MmxMesh* mesh);

}  // extern "C"
