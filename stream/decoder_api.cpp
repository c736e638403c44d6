// The stream decoder's C API (stream/decoder_api.h) over VsplitMesh (stream/vsplit.h). Built
// into the native library too, so the tests call it as the web client's module does.
#include "stream/decoder_api.h"

#include <cstdlib>
#include <new>
#include <string>
#include <vector>

#include "stream/format.h"
#include "stream/quantize.h"
#include "stream/vsplit.h"

// A definition the WebAssembly module exports under its own name (the native build exports
// nothing special).
#if defined(__wasm__)
#define MMX_EXPORT(name) __attribute__((export_name(#name)))
#else
#define MMX_EXPORT(name)
#endif

struct MmxMesh {
  meshmux::VsplitMesh state;
  uint32_t base_vertices = 0;                // mmx_set_base's count
  std::vector<meshmux::StreamBlock> blocks;  // mmx_set_blocks: boxes, ranges, dependencies
};

namespace {

std::string& last_error() {
  static std::string message;
  return message;
}

int fail(const std::string& message) {
  last_error() = message;
  return 1;
}

}  // namespace

extern "C" {

MMX_EXPORT(mmx_alloc) void* mmx_alloc(size_t bytes) { return std::malloc(bytes ? bytes : 1); }
MMX_EXPORT(mmx_free) void mmx_free(void* p) { std::free(p); }

MMX_EXPORT(mmx_error) const char* mmx_error() { return last_error().data(); }
MMX_EXPORT(mmx_error_length) size_t mmx_error_length() { return last_error().size(); }

MMX_EXPORT(mmx_mesh_new)
MmxMesh* mmx_mesh_new(uint32_t capacity_vertices, uint32_t capacity_faces) {
  if (capacity_vertices > meshmux::kMaxStreamElements ||
      capacity_faces > meshmux::kMaxStreamElements) {
    fail("capacity past the format's " + std::to_string(meshmux::kMaxStreamElements));
    return nullptr;
  }
  MmxMesh* mesh = new (std::nothrow) MmxMesh();
  if (!mesh) return nullptr;
  mesh->state.reset(capacity_vertices, capacity_faces);
  return mesh;
}

MMX_EXPORT(mmx_mesh_free) void mmx_mesh_free(MmxMesh* mesh) { delete mesh; }

MMX_EXPORT(mmx_set_base)
int mmx_set_base(MmxMesh* mesh, const uint16_t* p, const int8_t* n, const uint16_t* t,
                 uint32_t count) {
  meshmux::VsplitMesh& s = mesh->state;
  if (s.vertex_count() != 0) return fail("the base is set already");
  if (count > s.capacity_vertices())
    return fail(std::to_string(count) + " base vertices exceed its capacity " +
                std::to_string(s.capacity_vertices()));
  s.vertices.reserve(count);
  mesh->base_vertices = count;
  for (uint32_t i = 0; i < count; ++i) {
    meshmux::QuantizedVertex q;
    for (int k = 0; k < 3; ++k) q.p[k] = p[3 * i + k], q.n[k] = n[3 * i + k];
    q.t[0] = t[2 * i], q.t[1] = t[2 * i + 1];
    s.add_vertex(q);
  }
  return 0;
}

MMX_EXPORT(mmx_append_faces)
int mmx_append_faces(MmxMesh* mesh, const uint32_t* indices, uint32_t corners) {
  meshmux::VsplitMesh& s = mesh->state;
  if (corners % 3 != 0) return fail(std::to_string(corners) + " base indices are not whole faces");
  const uint64_t faces = uint64_t(s.face_count()) + corners / 3;
  if (faces > s.capacity_faces())
    return fail(std::to_string(faces) + " faces exceed its capacity " +
                std::to_string(s.capacity_faces()));
  const uint32_t vertices = s.vertex_count();
  for (uint32_t i = 0; i < corners; i += 3) {
    const uint32_t a = indices[i], b = indices[i + 1], c = indices[i + 2];
    if (a >= vertices || b >= vertices || c >= vertices)
      return fail("base face " + std::to_string(s.face_count()) + " names vertex " +
                  std::to_string(a >= vertices   ? a
                                 : b >= vertices ? b
                                                 : c) +
                  ", only " + std::to_string(vertices) + " are received");
    s.add_face(a, b, c);
  }
  return 0;
}

MMX_EXPORT(mmx_begin_changes) void mmx_begin_changes(MmxMesh* mesh) {
  mesh->state.moved_floor = uint32_t(mesh->state.indices.size());
  mesh->state.moved.clear();
}

MMX_EXPORT(mmx_apply_part)
int mmx_apply_part(MmxMesh* mesh, const uint8_t* data, size_t size, uint32_t splits,
                   uint32_t faces) {
  meshmux::Status s = meshmux::decode_vsplit_part(mesh->state, data, size, splits, faces);
  return s ? 0 : fail(s.message());
}

MMX_EXPORT(mmx_set_blocks)
int mmx_set_blocks(MmxMesh* mesh, const uint32_t* words, uint32_t count) {
  std::vector<meshmux::StreamBlock> blocks;
  for (uint32_t at = 0; at < count;) {
    const std::string where = "block " + std::to_string(blocks.size());
    if (count - at < 9) return fail(where + ": the table ends inside it");
    meshmux::StreamBlock b;
    for (int i = 0; i < 6; ++i) {
      if (words[at + i] > 65535) return fail(where + ": box past the grid");
      b.box[i] = uint16_t(words[at + i]);
    }
    b.vertex_begin = words[at + 6], b.vertex_end = words[at + 7];
    const uint32_t deps = words[at + 8];
    at += 9;
    if (b.vertex_end < b.vertex_begin || b.vertex_end > mesh->state.capacity_vertices())
      return fail(where + ": vertex range outside the mesh");
    if (deps > count - at) return fail(where + ": the table ends inside its dependencies");
    for (uint32_t i = 0; i < deps; ++i) {
      const uint32_t d = words[at + i];
      if (d >= blocks.size() || (i > 0 && d <= b.deps.back()))
        return fail(where + ": dependency " + std::to_string(d) + " is not an earlier block");
      b.deps.push_back(d);
    }
    at += deps;
    blocks.push_back(std::move(b));
  }
  mesh->blocks = std::move(blocks);
  return 0;
}

MMX_EXPORT(mmx_apply_block_part)
int mmx_apply_block_part(MmxMesh* mesh, const uint8_t* data, size_t size, uint32_t block,
                         uint32_t splits, uint32_t faces) {
  if (block >= mesh->blocks.size())
    return fail("block " + std::to_string(block) + " of " + std::to_string(mesh->blocks.size()) +
                " set");
  meshmux::Status s = meshmux::decode_vsplit_block_part(mesh->state, data, size, mesh->blocks,
                                                        mesh->base_vertices, block, splits, faces);
  return s ? 0 : fail(s.message());
}

MMX_EXPORT(mmx_vertices) uint32_t mmx_vertices(const MmxMesh* mesh) {
  return mesh->state.vertex_count();
}
MMX_EXPORT(mmx_faces) uint32_t mmx_faces(const MmxMesh* mesh) { return mesh->state.face_count(); }
MMX_EXPORT(mmx_solid) uint32_t mmx_solid(const MmxMesh* mesh) {
  return uint32_t(mesh->state.solid);
}
MMX_EXPORT(mmx_indices) const uint32_t* mmx_indices(const MmxMesh* mesh) {
  return mesh->state.indices.data();
}
MMX_EXPORT(mmx_moved) const uint32_t* mmx_moved(const MmxMesh* mesh) {
  return mesh->state.moved.data();
}
MMX_EXPORT(mmx_moved_count) uint32_t mmx_moved_count(const MmxMesh* mesh) {
  return uint32_t(mesh->state.moved.size());
}

MMX_EXPORT(mmx_dequantize)
void mmx_dequantize(const MmxMesh* mesh, uint32_t v0, uint32_t vn, float* position, float* normal,
                    float* uv, int quantized, double ox, double oy, double oz, double step) {
  const double origin[3] = {ox, oy, oz};
  const auto& vertices = mesh->state.vertices;
  for (uint32_t v = v0, i = 0; v < vn && v < vertices.size(); ++v, ++i) {
    const meshmux::QuantizedVertex& q = vertices[v];
    for (int k = 0; k < 3; ++k) {
      // Doubles rounded once to float, as the JavaScript client computed them.
      position[3 * i + k] = quantized ? float(q.p[k]) : float(origin[k] + double(q.p[k]) * step);
      normal[3 * i + k] = float(double(q.n[k]) / 127.0);
    }
    for (int k = 0; k < 2; ++k) uv[2 * i + k] = float(double(q.t[k]) / double(meshmux::kUvMax));
  }
}

MMX_EXPORT(mmx_digest) uint32_t mmx_digest(const MmxMesh* mesh) {
  return meshmux::state_digest(mesh->state);
}

}  // extern "C"
