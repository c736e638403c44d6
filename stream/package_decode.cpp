// The stream package's part decoder and base (stream/package.h), over a Package read_package
// made: decode_part repeats the checks it relies on (the Package may not come from these bytes)
// and the vertex-split decoder (stream/vsplit.h) checks everything it decodes.
#include <string>

#include "stream/deflate.h"
#include "stream/package.h"
#include "stream/vsplit.h"

namespace meshmux {

namespace {

Status fail(const std::string& message) {
  return Status::error("package: " + message, ErrorKind::kInput);
}

}  // namespace

Status check_part(const PackagePart& p, const std::vector<PackageMesh>& meshes,
                  const std::string& where) {
  if (p.mesh >= meshes.size())
    return fail(where + ": mesh " + std::to_string(p.mesh) + " out of range");
  const PackageMesh& m = meshes[p.mesh];
  if (m.vertices > kMaxStreamElements || m.faces > kMaxStreamElements)
    return fail(where + ": mesh has more than 2^28 vertices or faces");
  if (p.vertex_begin > p.vertex_end || p.vertex_end > m.vertices)
    return fail(where + ": vertex range [" + std::to_string(p.vertex_begin) + ", " +
                std::to_string(p.vertex_end) + ") outside the mesh's " +
                std::to_string(m.vertices) + " vertices");
  if (p.face_begin > p.face_end || p.face_end > m.faces)
    return fail(where + ": face range [" + std::to_string(p.face_begin) + ", " +
                std::to_string(p.face_end) + ") outside the mesh's " + std::to_string(m.faces) +
                " faces");
  // A part's coded bytes can stand for only so many splits and faces (stream/vsplit.h).
  uint64_t nv = p.vertex_end - p.vertex_begin, nf = p.face_end - p.face_begin;
  if (!part_size_plausible(p.bytes, nv, nf))
    return fail(where + ": " + std::to_string(p.bytes) + " bytes cannot hold " +
                std::to_string(nv) + " splits and " + std::to_string(nf) + " faces");
  return Status::ok();
}

Result<std::vector<uint8_t>> package_base_glb(const std::vector<uint8_t>& bytes,
                                              const Package& pkg) {
  if (pkg.base_offset > bytes.size() || pkg.base_size > bytes.size() - pkg.base_offset)
    return fail("base: range past the end of the file");
  const uint8_t* at = bytes.data() + pkg.base_offset;
  if (!pkg.base_deflated) return std::vector<uint8_t>(at, at + pkg.base_size);
  auto glb = inflate_bytes(at, size_t(pkg.base_size), pkg.base_glb_size);
  if (!glb.ok()) return fail("base: " + glb.status().message());
  if (glb->size() != pkg.base_glb_size)
    return fail("base: inflates to " + std::to_string(glb->size()) + " bytes, the table says " +
                std::to_string(pkg.base_glb_size));
  return glb.take();
}

Status decode_part(const std::vector<uint8_t>& bytes, const Package& package,
                   const PackageChunk& chunk, size_t part, VsplitMesh& mesh) {
  std::string where = "chunk at offset " + std::to_string(chunk.offset);
  const PackageChunk* first = package.chunks.data();
  if (!package.chunks.empty() && !std::less<const PackageChunk*>()(&chunk, first) &&
      std::less<const PackageChunk*>()(&chunk, first + package.chunks.size()))
    where = "chunk " + std::to_string(&chunk - first);
  if (chunk.kind != StreamStep::kMesh) return fail(where + ": not a mesh chunk");
  if (part >= chunk.parts.size())
    return fail(where + ": part " + std::to_string(part) + " out of range");
  uint64_t size = bytes.size();
  if (chunk.offset > size || chunk.size > size - chunk.offset)
    return fail(where + ": range past the end of the file");
  // The part is a slice of the chunk: its bytes after those of the parts before it.
  uint64_t total = 0, offset = 0;
  for (size_t i = 0; i < chunk.parts.size(); ++i) {
    if (i == part) offset = total;
    total += chunk.parts[i].bytes;
    if (total > chunk.size)
      return fail(where + ": parts hold more bytes than the chunk's " + std::to_string(chunk.size));
  }
  where += " part " + std::to_string(part);
  const PackagePart& p = chunk.parts[part];
  if (Status s = check_part(p, package.meshes, where); !s) return s;
  if (p.block >= 0) {  // a block part: its dependencies held, its own vertices not yet
    const std::vector<StreamBlock>& blocks = package.meshes[p.mesh].blocks;
    if (size_t(p.block) >= blocks.size())
      return fail(where + ": block " + std::to_string(p.block) + " out of range");
    for (uint32_t d : blocks[size_t(p.block)].deps)
      if (d < blocks.size() && blocks[d].vertex_end > blocks[d].vertex_begin &&
          !mesh.has_vertex(blocks[d].vertex_begin))
        return fail(where + ": block " + std::to_string(p.block) + " needs block " +
                    std::to_string(d) + ", not applied");
    Status s =
        decode_vsplit_block_part(mesh, bytes.data() + chunk.offset + offset, size_t(p.bytes),
                                 blocks, package.meshes[p.mesh].base_vertices, uint32_t(p.block),
                                 p.vertex_end - p.vertex_begin, p.face_end - p.face_begin);
    if (!s) return fail(where + ": " + s.message());
    return Status::ok();
  }
  if (p.vertex_begin != mesh.vertex_count() || p.face_begin != mesh.face_count())
    return fail(where + ": starts at vertex " + std::to_string(p.vertex_begin) + ", face " +
                std::to_string(p.face_begin) + "; " + std::to_string(mesh.vertex_count()) +
                " vertices and " + std::to_string(mesh.face_count()) + " faces are held");
  Status s = decode_vsplit_part(mesh, bytes.data() + chunk.offset + offset, size_t(p.bytes),
                                p.vertex_end - p.vertex_begin, p.face_end - p.face_begin);
  if (!s) return fail(where + ": " + s.message());
  return Status::ok();
}

Result<VsplitMesh> decode_base(const Package& package, size_t mesh,
                               const std::vector<QuantizedVertex>& base_vertices,
                               const std::vector<uint32_t>& base_faces) {
  std::string where = "mesh " + std::to_string(mesh);
  if (mesh >= package.meshes.size()) return fail(where + ": no such mesh");
  const PackageMesh& m = package.meshes[mesh];
  if (base_vertices.size() != m.base_vertices)
    return fail(where + ": " + std::to_string(base_vertices.size()) +
                " base vertices given, the table says " + std::to_string(m.base_vertices));
  if (base_faces.size() != size_t(m.base_faces) * 3)
    return fail(where + ": " + std::to_string(base_faces.size() / 3) +
                " base faces given, the table says " + std::to_string(m.base_faces));
  VsplitMesh out;
  out.reset(m.vertices, m.faces);
  for (const QuantizedVertex& q : base_vertices) out.add_vertex(q);
  for (size_t i = 0; i + 2 < base_faces.size(); i += 3) {
    for (size_t k = 0; k < 3; ++k)
      if (base_faces[i + k] >= m.base_vertices)
        return fail(where + ": base face " + std::to_string(i / 3) + " names vertex " +
                    std::to_string(base_faces[i + k]) + " of " + std::to_string(m.base_vertices));
    out.add_face(base_faces[i], base_faces[i + 1], base_faces[i + 2]);
  }
  return out;
}

}  // namespace meshmux
