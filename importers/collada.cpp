// COLLADA → Scene through Assimp. This is the first half of Terrace, Cheslack-Postava, Levis and
// Freedman, "Unsupervised conversion of 3D models for interactive metaverses" §4.1 (cleaning and
// normalizing): polygons become triangles here; welding, degenerate removal and normals are
// left to clean/clean.h.
//
// Why Assimp (Debian libassimp-dev 5.2) rather than a hand-written pugixml reader:
// - it keeps instancing: each <instance_geometry>/<instance_node> is an aiNode listing indices
//   into one shared aiScene::mMeshes, so a geometry placed 20 times is stored once;
// - aiProcess_Triangulate ear-clips polygons in their projected plane, correctly on concave and
//   "keyhole" polygons (ConcavePolygon-dae: 66 corners → 64 triangles with the polygon's area);
// - it applies <up_axis> and <unit> as a rotation and scale on the root node, so the
//   accumulated world transforms come out Y-up in metres.
// Assimp splits a <geometry> with k material blocks into k aiMeshes that its nodes reference
// together; we regroup them: nodes with identical mesh lists share one Mesh, one Primitive per
// triangle aiMesh. Assimp leaves one vertex per face corner; the clean stage welds them.
//
// Isolation: Assimp 5.2 crashes (SIGSEGV, abort) on some corrupt files, e.g. a <float_array>
// without its count, and can allocate without bound on others (a stray '"' inside <p>: 19 GB
// in 70 s). So Assimp runs in a forked child with an address-space limit and a deadline; the
// child sends the converted geometry and materials back through a pipe, and a crash becomes an
// ordinary error. Textures are read and decoded in the caller's process, after the child ends.
//
// Known Assimp 5.2 limits: <sampler2D><wrap_s>/<wrap_t> are not read (only the MAYA <extra>
// wrapU/wrapV reach aiTextureMapMode), so most textures come out REPEAT; malformed XML gives
// only "Unable to read file, malformed XML", without a line number.
#include "importers/collada.h"

#include <assimp/config.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <new>
#include <type_traits>

#include "core/file_io.h"
#include "core/sanitizers.h"
#include "core/text.h"
#include "image/color.h"
#include "image/decode.h"
#include "importers/collada_bindings.h"
#include "importers/upload.h"

namespace meshmux {
namespace {

namespace fs = std::filesystem;

// "who: reason" → "reason" (our file and image helpers prefix their messages with the name).
std::string strip_prefix(const std::string& message, const std::string& who) {
  std::string p = who + ": ";
  return message.compare(0, p.size(), p) == 0 ? message.substr(p.size()) : message;
}

// One line: Assimp's messages sometimes carry newlines.
std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  std::replace(s.begin(), s.end(), '\r', ' ');
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

Mat4 to_mat4(const aiMatrix4x4& a) {
  Mat4 m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m.at(r, c) = a[r][c];  // aiMatrix4x4 is row-major
  return m;
}

float clamp01(float x) { return std::isfinite(x) ? std::min(1.0f, std::max(0.0f, x)) : 0.0f; }
// A COLLADA colour component (a display value, sRGB-encoded) as the linear factor glTF holds.
float display_to_linear(float x) { return float(srgb_decode(double(clamp01(x)))); }

Wrap to_wrap(aiTextureMapMode m) {
  if (m == aiTextureMapMode_Clamp || m == aiTextureMapMode_Decal) return Wrap::kClampToEdge;
  return m == aiTextureMapMode_Mirror ? Wrap::kMirroredRepeat : Wrap::kRepeat;
}

// A material's diffuse texture, to be loaded by the caller's process.
// The Blinn-Phong exponent a <phong>/<blinn> effect with none (or 0) shows with in three.js
// (MeshPhongMaterial's default, which its ColladaLoader keeps for a 0).
constexpr float kDefaultShininess = 30;

struct TextureRequest {
  int32_t material = -1;
  std::string path;  // as Assimp gives it
  uint32_t uv = 0;
  Wrap wrap_s = Wrap::kRepeat, wrap_t = Wrap::kRepeat;
};

// What the Assimp side produces: a Scene without images, and what to load into it.
struct Parsed {
  Scene scene;
  std::vector<int32_t> line_materials;  // per scene.lines entry: its material (-1: none)
  std::vector<TextureRequest> textures;
  std::vector<std::string> warnings;
};

class Converter {
 public:
  Converter(const std::string& file, const aiScene& ai) : file_(file), ai_(ai) {}

  Parsed run() {
    if (ai_.mRootNode) visit(*ai_.mRootNode, Mat4::identity());
    if (out_.scene.instances.empty()) warn(prefix() + ": no triangle geometry in the scene");
    return std::move(out_);
  }

 private:
  std::string prefix() const { return "collada: " + file_; }
  void warn(std::string message) { out_.warnings.push_back(std::move(message)); }

  void visit(const aiNode& node, const Mat4& parent) {
    Mat4 world = parent * to_mat4(node.mTransformation);
    if (node.mNumMeshes > 0 && node.mMeshes) {
      std::vector<unsigned> key(node.mMeshes, node.mMeshes + node.mNumMeshes);
      auto it = mesh_by_list_.find(key);
      int32_t mesh = it != mesh_by_list_.end() ? it->second : build_mesh(key);
      mesh_by_list_[key] = mesh;
      if (mesh >= 0) out_.scene.instances.push_back({uint32_t(mesh), world, node.mName.C_Str()});
      for (const auto& [set, material] : lines_by_list_[key]) {  // placed in the world
        LineSet placed = set;
        for (Vec3& v : placed.positions) v = world.transform_point(v);
        out_.scene.lines.push_back(std::move(placed));
        out_.line_materials.push_back(material);
      }
    }
    for (unsigned i = 0; i < node.mNumChildren; ++i)
      if (node.mChildren && node.mChildren[i]) visit(*node.mChildren[i], world);
  }

  // One Mesh from the aiMeshes a node lists; -1 when none of them has triangles.
  int32_t build_mesh(const std::vector<unsigned>& list) {
    Mesh mesh;
    for (unsigned index : list) {
      if (index >= ai_.mNumMeshes || !ai_.mMeshes[index]) continue;
      const aiMesh& am = *ai_.mMeshes[index];
      if (mesh.name.empty()) mesh.name = am.mName.C_Str();
      Primitive prim;
      if (convert_primitive(am, prim)) mesh.primitives.push_back(std::move(prim));
      LineSet set;
      if (convert_lines(am, set))
        lines_by_list_[list].push_back({std::move(set), material(am.mMaterialIndex)});
    }
    if (mesh.primitives.empty()) return -1;
    out_.scene.meshes.push_back(std::move(mesh));
    return int32_t(out_.scene.meshes.size() - 1);
  }

  // The <lines>/<linestrips> segments of one aiMesh, in mesh space, only the vertices they use;
  // false when it has none. Their colour is set once the materials are final (line_colors).
  bool convert_lines(const aiMesh& am, LineSet& set) {
    std::map<unsigned, uint32_t> vertex;  // aiMesh vertex → set vertex
    for (unsigned f = 0; am.mFaces && am.mVertices && f < am.mNumFaces; ++f) {
      const aiFace& face = am.mFaces[f];
      if (face.mNumIndices != 2 || !face.mIndices) continue;
      for (unsigned k = 0; k < 2; ++k) {
        const unsigned v = face.mIndices[k];
        if (v >= am.mNumVertices) return false;
        auto [it, added] = vertex.emplace(v, uint32_t(set.positions.size()));
        if (added)
          set.positions.push_back({am.mVertices[v].x, am.mVertices[v].y, am.mVertices[v].z});
        set.indices.push_back(it->second);
      }
    }
    set.name = am.mName.C_Str();
    return !set.indices.empty();
  }

  // Copies the triangles of one aiMesh; warns about the point faces it drops (its line faces
  // are convert_lines's).
  bool convert_primitive(const aiMesh& am, Primitive& prim) {
    size_t others = 0;
    for (unsigned f = 0; am.mFaces && f < am.mNumFaces; ++f) {
      const aiFace& face = am.mFaces[f];
      if (face.mNumIndices == 3 && face.mIndices) {
        prim.indices.insert(prim.indices.end(), face.mIndices, face.mIndices + 3);
      } else if (face.mNumIndices != 2) {
        ++others;  // points, or polygons aiProcess_Triangulate gave up on
      }
    }
    std::string geometry = prefix() + ": geometry '" + am.mName.C_Str() + "': ";
    if (others)
      warn(geometry + std::to_string(others) + " points or untriangulated polygons skipped");
    if (prim.indices.empty() || !am.mVertices) return false;

    size_t n = am.mNumVertices;
    prim.positions.resize(n);
    for (size_t v = 0; v < n; ++v)
      prim.positions[v] = {am.mVertices[v].x, am.mVertices[v].y, am.mVertices[v].z};
    // Zero or NaN normals stay as they are: the clean stage regenerates a primitive's normals
    // only when a triangle it keeps uses one (exporters write zero normals on degenerate ones).
    if (am.mNormals) {
      prim.normals.resize(n);
      for (size_t v = 0; v < n; ++v)
        prim.normals[v] = normalize({am.mNormals[v].x, am.mNormals[v].y, am.mNormals[v].z});
    }
    // uv sets in order, stopping at the first gap; COLLADA's v points up, glTF's down.
    for (unsigned k = 0; k < AI_MAX_NUMBER_OF_TEXTURECOORDS && am.mTextureCoords[k]; ++k) {
      std::vector<Vec2> uv(n);
      for (size_t v = 0; v < n; ++v)
        uv[v] = {am.mTextureCoords[k][v].x, 1.0f - am.mTextureCoords[k][v].y};
      prim.uvs.push_back(std::move(uv));
    }
    if (am.mColors[0]) {
      prim.colors.resize(n);
      for (size_t v = 0; v < n; ++v) {
        const aiColor4D& c = am.mColors[0][v];
        prim.colors[v] = {display_to_linear(c.r), display_to_linear(c.g), display_to_linear(c.b),
                          c.a};
      }
    }
    prim.material = material(am.mMaterialIndex);
    return true;
  }

  int32_t material(unsigned index) {
    if (index >= ai_.mNumMaterials || !ai_.mMaterials[index]) return -1;
    auto it = material_by_ai_.find(index);
    if (it != material_by_ai_.end()) return it->second;
    int32_t id = int32_t(out_.scene.materials.size());
    out_.scene.materials.push_back(convert_material(*ai_.mMaterials[index], id));
    material_by_ai_[index] = id;
    return id;
  }

  // COLLADA common profile → metallic-roughness:
  // - colours (diffuse, emission, vertex colours) are display values, sRGB-encoded, as three.js's
  //   ColladaLoader and common viewers read them: decoded to the linear factors glTF holds;
  // - base colour = diffuse colour (its alpha is ignored: COLLADA's transparency lives in
  //   <transparent>/<transparency>, which Assimp folds into AI_MATKEY_OPACITY); a diffuse
  //   texture, once loaded, replaces the factor with (1, 1, 1, opacity);
  // - opacity < 1 → BLEND; double_sided from AI_MATKEY_TWOSIDED (read from <extra>);
  // - metallic 0 (the common profile describes dielectrics); roughness from the Blinn-Phong
  //   exponent n through the Beckmann match α = sqrt(2 / (n + 2)) and glTF's α = roughness²,
  //   i.e. roughness = (2 / (n + 2))^¼, where an exponent of 0 or none is read as 30, as
  //   three.js's ColladaLoader reads it (its MeshPhongMaterial default); lambert and constant
  //   shading (no highlight) → 1. The <specular> colour is not carried: the dielectric F0 of
  //   0.04 stands in for it, as in three.js's PBR reading of a Phong material;
  // - emissive factor = <emission> colour; an <emission> texture is not carried and leaves
  //   the emissive colour black (three.js's ColladaLoader shows it so too: emissiveMap times
  //   its black emissive colour), never Assimp's white stand-in for it.
  Material convert_material(const aiMaterial& am, int32_t id) {
    Material mat;
    aiString name;
    if (am.Get(AI_MATKEY_NAME, name) == AI_SUCCESS) mat.name = name.C_Str();

    aiColor4D diffuse(1, 1, 1, 1);
    am.Get(AI_MATKEY_COLOR_DIFFUSE, diffuse);
    float opacity = 1;
    if (am.Get(AI_MATKEY_OPACITY, opacity) != AI_SUCCESS || !std::isfinite(opacity)) opacity = 1;
    opacity = clamp01(opacity);
    if (opacity <= 0) {  // fully invisible is nearly always an exporter's inverted transparency
      warn(prefix() + ": material '" + mat.name + "': transparency makes it invisible; opaque");
      opacity = 1;
    }
    mat.base_color_factor = {display_to_linear(diffuse.r), display_to_linear(diffuse.g),
                             display_to_linear(diffuse.b), opacity};
    if (opacity < 1) mat.alpha_mode = AlphaMode::kBlend;

    int two_sided = 0;
    if (am.Get(AI_MATKEY_TWOSIDED, two_sided) == AI_SUCCESS) mat.double_sided = two_sided != 0;

    mat.metallic_factor = 0;
    mat.roughness_factor = 1;
    int shading = 0;
    float shininess = 0;
    bool has_highlight = am.Get(AI_MATKEY_SHADING_MODEL, shading) != AI_SUCCESS ||
                         shading == aiShadingMode_Phong || shading == aiShadingMode_Blinn;
    if (has_highlight) {
      if (am.Get(AI_MATKEY_SHININESS, shininess) != AI_SUCCESS || !std::isfinite(shininess) ||
          shininess <= 0)
        shininess = kDefaultShininess;
      mat.roughness_factor = clamp01(float(std::pow(2.0 / (double(shininess) + 2.0), 0.25)));
    }

    aiColor3D emissive(0, 0, 0);
    if (am.GetTextureCount(aiTextureType_EMISSIVE) == 0 &&
        am.Get(AI_MATKEY_COLOR_EMISSIVE, emissive) == AI_SUCCESS)
      mat.emissive_factor = {display_to_linear(emissive.r), display_to_linear(emissive.g),
                             display_to_linear(emissive.b)};

    aiString path;
    aiTextureMapMode modes[2] = {aiTextureMapMode_Wrap, aiTextureMapMode_Wrap};
    unsigned uv = 0;
    if (am.GetTextureCount(aiTextureType_DIFFUSE) > 0 &&
        am.GetTexture(aiTextureType_DIFFUSE, 0, &path, nullptr, &uv, nullptr, nullptr, modes) ==
            AI_SUCCESS) {
      out_.textures.push_back({id, path.C_Str(), uv, to_wrap(modes[0]), to_wrap(modes[1])});
    }
    return mat;
  }

  std::string file_;
  const aiScene& ai_;
  Parsed out_;
  std::map<std::vector<unsigned>, int32_t> mesh_by_list_;
  // Per node mesh list: its line sets in mesh space, each with its material.
  std::map<std::vector<unsigned>, std::vector<std::pair<LineSet, int32_t>>> lines_by_list_;
  std::map<unsigned, int32_t> material_by_ai_;
};

// Runs Assimp in this process, on the file at `path`, or on `memory` when it is not empty (a
// repaired copy of the document).
Result<Parsed> parse(const std::string& path, const std::string& stage, const std::string& memory) {
  try {
    Assimp::Importer importer;
    importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, false);
    // <unit> is always applied: 5.2 has no IGNORE_UNIT_SIZE switch (later versions do).
    importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_USE_COLLADA_NAMES, true);
    // Triangulate + sort by primitive type only: nothing that merges meshes, pre-transforms
    // vertices or flattens the node graph, so instancing survives.
    const unsigned flags = aiProcess_Triangulate | aiProcess_SortByPType;
    const aiScene* ai =
        memory.empty() ? importer.ReadFile(path, flags)
                       : importer.ReadFileFromMemory(memory.data(), memory.size(), flags, "dae");
    if (!ai) {
      std::string reason = one_line(importer.GetErrorString());
      if (reason == "std::bad_alloc") reason = "Assimp ran out of memory on it";
      return Status::error(stage + ": malformed file: " + (reason.empty() ? "unreadable" : reason),
                           ErrorKind::kInput);
    }
    return Converter(base_name(path), *ai).run();
  } catch (const std::bad_alloc&) {
    return Status::error(stage + ": malformed file: out of memory while parsing",
                         ErrorKind::kInput);
  } catch (const std::exception& e) {
    return Status::error(stage + ": malformed file: " + one_line(e.what()), ErrorKind::kInput);
  } catch (...) {
    return Status::error(stage + ": unknown failure in Assimp", ErrorKind::kInternal);
  }
}

// ---- passing Parsed from the child to the parent -------------------------------------------
// Writer and Reader share one description of the data (transfer), so the two cannot drift.
struct Writer {
  std::string out;
  void bytes(void* p, size_t n) { out.append(static_cast<const char*>(p), n); }
  bool count(size_t& n, size_t) {
    uint64_t v = n;
    return bytes(&v, sizeof v), true;
  }
};

struct Reader {
  const std::string& in;
  size_t pos = 1;  // after the 'K'
  bool ok = true;
  void bytes(void* p, size_t n) {
    ok = ok && n <= in.size() - pos;
    if (ok && n) std::memcpy(p, in.data() + pos, n);
    pos += ok ? n : 0;
  }
  bool count(size_t& n, size_t element_bytes) {
    uint64_t v = 0;
    bytes(&v, sizeof v);
    if (!ok || v > (in.size() - pos) / std::max<size_t>(element_bytes, 1)) return ok = false;
    n = size_t(v);
    return true;
  }
};

template <class S, class T>
void pod(S& s, T& v) {
  static_assert(std::is_trivially_copyable<T>::value, "raw bytes only");
  s.bytes(&v, sizeof v);
}
template <class S, class C>  // C: std::string, or std::vector of a trivially copyable type
void array(S& s, C& v) {
  using T = typename C::value_type;
  static_assert(std::is_trivially_copyable<T>::value, "raw bytes only");
  size_t n = v.size();
  if (!s.count(n, sizeof(T))) return;
  v.resize(n);
  s.bytes(v.data(), n * sizeof(T));
}
template <class S, class T, class F>
void list(S& s, std::vector<T>& v, F each) {
  size_t n = v.size();
  if (!s.count(n, 1)) return;
  v.resize(n);
  for (T& x : v) each(x);
}

template <class S>
void transfer(S& s, Parsed& p) {
  list(s, p.scene.meshes, [&](Mesh& m) {
    array(s, m.name);
    list(s, m.primitives, [&](Primitive& q) {
      array(s, q.positions);
      array(s, q.normals);
      list(s, q.uvs, [&](std::vector<Vec2>& uv) { array(s, uv); });
      array(s, q.colors);
      array(s, q.indices);
      pod(s, q.material);
    });
  });
  list(s, p.scene.materials, [&](Material& m) {
    array(s, m.name);
    pod(s, m.base_color_factor), pod(s, m.metallic_factor), pod(s, m.roughness_factor);
    pod(s, m.emissive_factor), pod(s, m.alpha_mode), pod(s, m.double_sided);
  });
  list(s, p.scene.lines,
       [&](LineSet& l) { array(s, l.name), array(s, l.positions), array(s, l.indices); });
  array(s, p.line_materials);
  list(s, p.scene.instances,
       [&](Instance& i) { pod(s, i.mesh), pod(s, i.world), array(s, i.name); });
  list(s, p.textures, [&](TextureRequest& t) {
    pod(s, t.material), array(s, t.path);
    pod(s, t.uv), pod(s, t.wrap_s), pod(s, t.wrap_t);
  });
  list(s, p.warnings, [&](std::string& w) { array(s, w); });
}

bool write_all(int fd, const std::string& data) {
  for (size_t done = 0; done < data.size();) {
    ssize_t n = write(fd, data.data() + done, data.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += size_t(n);
  }
  return true;
}

// Our address-space size now, from /proc/self/statm; 0 when unknown.
uint64_t current_address_space() {
  std::ifstream statm("/proc/self/statm");
  uint64_t pages = 0;
  statm >> pages;
  return pages * uint64_t(sysconf(_SC_PAGESIZE));
}

constexpr bool kLimitAddressSpace = !MESHMUX_SANITIZED;  // sanitizers reserve terabytes

// The last line of the child's stderr (ai_assert says there why Assimp aborted).
std::string last_line(FILE* f) {
  std::string text(4096, '\0');
  if (fseek(f, -long(text.size()), SEEK_END) != 0) rewind(f);
  text.resize(fread(&text[0], 1, text.size(), f));
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  size_t cut = text.find_last_of('\n');
  return cut == std::string::npos ? text : text.substr(cut + 1);
}

// Runs parse() in a forked child: Assimp gets 1 GiB + 32 bytes per input byte of address
// space, and 60 s + 10 s per MB of input. A crash, a kill or a timeout becomes an error.
Result<Parsed> parse_isolated(const std::string& path, uint64_t file_bytes,
                              const std::string& stage, const std::string& memory) {
  std::unique_ptr<FILE, int (*)(FILE*)> err(tmpfile(), fclose);
  int fds[2];
  if (!err || pipe(fds) != 0) return parse(path, stage, memory);
  uint64_t limit = current_address_space() + (uint64_t(1) << 30) + 32 * file_bytes;
  pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    return parse(path, stage, memory);  // no process to spare: run unprotected
  }
  if (pid == 0) {  // the child: parse, write the answer, leave without running destructors
    close(fds[0]);
    dup2(fileno(err.get()), 2);
    rlimit rl{rlim_t(limit), rlim_t(limit)};
    if (kLimitAddressSpace) setrlimit(RLIMIT_AS, &rl);
    int code = 2;
    try {
      Result<Parsed> r = parse(path, stage, memory);
      Writer w;
      w.out = r ? "K" : "E" + r.status().message();
      if (r) transfer(w, r.value());
      code = write_all(fds[1], w.out) ? 0 : 1;
    } catch (...) {
    }
    _exit(code);
  }
  close(fds[1]);
  auto start = std::chrono::steady_clock::now();
  const double seconds = 60 + 10 * double(file_bytes) / 1e6;
  std::string data;
  bool timed_out = false;
  for (char buf[1 << 16];;) {
    double left =
        seconds - std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (left <= 0) {
      timed_out = true;
      kill(pid, SIGKILL);
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    int ready = poll(&p, 1, int(std::min(left * 1000, 1e9)) + 1);
    if (ready < 0 && errno != EINTR) break;
    if (ready <= 0) continue;
    ssize_t n = read(fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    data.append(buf, size_t(n));
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  std::string why = last_line(err.get());
  why = why.empty() ? "" : ": " + why.substr(0, 300);
  if (timed_out)
    return Status::error(
        stage + ": malformed file: Assimp gave no answer in " + std::to_string(int(seconds)) + " s",
        ErrorKind::kInput);
  if (WIFSIGNALED(status))
    return Status::error(stage + ": malformed file: Assimp crashed on it (" +
                             strsignal(WTERMSIG(status)) + why + ")",
                         ErrorKind::kInput);
  if (data.empty())  // e.g. a sanitizer caught the crash and exited
    return Status::error(stage + ": malformed file: Assimp failed on it (exit status " +
                             std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + why +
                             ")",
                         ErrorKind::kInput);
  if (data[0] == 'E') return Status::error(data.substr(1), ErrorKind::kInput);
  Parsed parsed;
  Reader reader{data};
  if (data[0] == 'K') transfer(reader, parsed);
  if (data[0] != 'K' || !reader.ok || reader.pos != data.size())
    return Status::error(stage + ": garbled answer from the Assimp process", ErrorKind::kInternal);
  return parsed;
}

// ---- textures, in the caller's process -----------------------------------------------------
class TextureLoader {
 public:
  TextureLoader(const std::string& path, const InputScope& scope, Scene& scene,
                const ImportOptions& options, Warnings* warnings)
      : file_(base_name(path)),
        dir_(fs::path(path).parent_path()),
        scope_(scope),
        scene_(scene),
        options_(options),
        warnings_(warnings) {}

  // The first texture path that named an existing file outside the model's folder (absolute,
  // "../" or "file://"), with no file of that name inside it: the import fails with it.
  const std::string& refusal() const { return refusal_; }

  void attach(const TextureRequest& t) {
    if (t.material < 0 || size_t(t.material) >= scene_.materials.size()) return;
    Material& mat = scene_.materials[size_t(t.material)];
    std::string where =
        "collada: " + file_ + ": material '" + mat.name + "': texture '" + t.path + "'";
    int32_t image = load(t, where);
    if (image < 0) return;  // warned; the material keeps its colour
    mat.base_color.image = image;
    mat.base_color.tex_coord = t.uv;
    mat.base_color.sampler.wrap_s = t.wrap_s;
    mat.base_color.sampler.wrap_t = t.wrap_t;
    mat.base_color_factor = {1, 1, 1, mat.base_color_factor.w};
  }

 private:
  // Index of the image, loaded on first use; -1 (with a warning) when missing or undecodable.
  int32_t load(const TextureRequest& t, const std::string& where) {
    // Resolved once per path: a missing file's search of the upload is not repeated for every
    // material naming it.
    auto known = resolved_.find(t.path);
    if (known == resolved_.end()) known = resolved_.emplace(t.path, resolve(t.path)).first;
    const std::string& key = known->second;
    for (std::string& note : notes_) warn(warnings_, std::move(note));
    notes_.clear();
    auto it = loaded_.find(key);
    if (it == loaded_.end()) it = loaded_.emplace(key, read(t, key)).first;
    if (it->second.first < 0) warn(warnings_, where + ": " + it->second.second);
    return it->second.first;
  }

  // Reads and decodes an image file: {index, ""} or {-1, reason}.
  std::pair<int32_t, std::string> read(const TextureRequest& t, const std::string& file) {
    Image image;
    image.name = t.path;
    if (t.path.empty()) return {-1, "empty path"};
    if (t.path[0] == '*') return {-1, "embedded images are not supported"};  // Assimp's "*N"
    auto bytes = read_whole_file(file, options_.max_file_bytes);
    if (!bytes) return {-1, strip_prefix(bytes.status().message(), file)};
    image.encoded = bytes.take();
    if (options_.decode_images) {
      // The decoded texels of all images share one budget (ImportOptions::max_texels).
      bool over = false;
      Status s = decode_image(image, std::min(options_.max_image_pixels, texels_left_), &over);
      if (!s && over && texels_left_ < options_.max_image_pixels && refusal_.empty())
        refusal_ = "decoding it would take the model's images over " +
                   std::to_string(options_.max_texels) +
                   " texels in all (the limit from the input's size; --max-texels raises it)";
      if (!s) return {-1, strip_prefix(s.message(), image.name)};
      texels_left_ -= uint64_t(image.width) * uint64_t(image.height);
    }
    if (image.mime_type.empty()) image.mime_type = sniff_image_mime(image.encoded, t.path);
    if (image.mime_type.empty()) return {-1, "unknown image format"};
    scene_.images.push_back(std::move(image));
    return {int32_t(scene_.images.size() - 1), ""};
  }

  // The file a texture path names: relative to the .dae's folder, "file://" stripped, "%20"
  // decoded (Assimp usually did both already), and as a last resort the bare file name beside
  // the .dae (absolute paths from the author's machine are common).
  std::string resolve(const std::string& raw) const {
    std::string p = raw;
    std::replace(p.begin(), p.end(), '\\', '/');
    std::string q = p.compare(0, 7, "file://") == 0 ? p.substr(7) : p;
    if (q.size() > 3 && q[0] == '/' && q[2] == ':') q = q.substr(1);  // "/C:/x.png"
    q = percent_decode(q);
    std::vector<std::string> full;
    std::string outside;
    for (const std::string& c : {p, q, fs::path(q).filename().string()}) {
      if (c.empty()) continue;
      fs::path f = fs::path(c).is_absolute() ? fs::path(c) : dir_ / c;
      full.push_back(f.lexically_normal().string());
      std::error_code ec;
      if (!fs::exists(full.back(), ec)) continue;
      // Only inside the model's folder (links and ".." resolved), unless --allow-outside.
      auto inside = resolve_in_scope(scope_, full.back());
      if (inside.ok()) return *inside;
      if (outside.empty()) outside = inside.status().message();
    }
    // Not where it says: the one file of that name anywhere in the upload (model databases
    // name a bare file that lives in materials/textures/; authors' folders get renamed).
    const std::string leaf = fs::path(q).filename().string();
    std::vector<std::string> found = find_by_file_name(scope_.root, leaf);
    if (found.size() == 1) {
      auto inside = resolve_in_scope(scope_, found.front());
      if (inside.ok()) {
        notes_.push_back("collada: " + file_ + ": texture '" + raw +
                         "' is not where it says; using " + *inside +
                         " (the only file of that name in the upload)");
        return *inside;
      }
    }
    if (!outside.empty() && refusal_.empty()) refusal_ = outside;
    return full.size() > 1 ? full[1] : (full.empty() ? p : full[0]);
  }

  std::string file_;
  fs::path dir_;
  InputScope scope_;
  mutable std::string refusal_;             // set by the const resolve()
  mutable std::vector<std::string> notes_;  // warnings of resolve(), passed on by load()
  Scene& scene_;
  const ImportOptions& options_;
  uint64_t texels_left_ = options_.max_texels;  // declared after options_: initialized from it
  Warnings* warnings_;
  std::map<std::string, std::pair<int32_t, std::string>> loaded_;  // by resolved path
  std::map<std::string, std::string> resolved_;  // texture path as written → resolved path
};

// The colours three.js's ColladaLoader (the judge of appearance) shows where the document gives
// none, where Assimp 5.2 gives 0.6 grey: an effect without <diffuse> keeps its three.js
// material's default colour, white; a primitive bound to no material gets a default
// MeshPhongMaterial, white with exponent 30 (ColladaComposer.buildObjects). Assimp's stand-in for
// the latter is named AI_DEFAULT_MATERIAL_NAME (a document's own material of that name is not).
void default_colors(const std::map<std::string, ColladaMaterialInfo>& info, Scene& scene) {
  for (Material& m : scene.materials) {
    auto it = info.find(m.name);
    const bool stand_in = it == info.end() && m.name == AI_DEFAULT_MATERIAL_NAME;
    if (!stand_in && (it == info.end() || it->second.diffuse)) continue;
    m.base_color_factor = {1, 1, 1, m.base_color_factor.w};
    if (stand_in) m.roughness_factor = float(std::pow(2.0 / (kDefaultShininess + 2.0), 0.25));
  }
}

// A texture bound (bind_vertex_input) to a TEXCOORD set that no mesh drawn with its material
// has — 3ds Max writes input_set="1" for its first map channel, while the mesh's one TEXCOORD
// input carries no set — reads the first set instead, as COLLADA viewers show it (three.js's
// ColladaLoader reads the first set whatever the binding), said once per material. Left
// alone, the texture had no coordinates: nothing of it could be sampled (an atlas sized such
// charts by area alone: a 3 kB image became a 4096² atlas at 3% use).
void first_uv_set_where_missing(Scene& scene, const std::string& stage, Warnings* warnings) {
  std::vector<uint32_t> most(scene.materials.size(), 0);  // per material: its meshes' most sets
  std::vector<char> drawn(scene.materials.size(), 0);
  for (const Mesh& mesh : scene.meshes)
    for (const Primitive& p : mesh.primitives)
      if (p.material >= 0 && size_t(p.material) < most.size()) {
        most[size_t(p.material)] = std::max(most[size_t(p.material)], uint32_t(p.uvs.size()));
        drawn[size_t(p.material)] = 1;
      }
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    TextureRef& t = scene.materials[i].base_color;
    if (!t.present() || !drawn[i] || most[i] == 0 || t.tex_coord < most[i]) continue;
    warn(warnings, stage + ": material '" + scene.materials[i].name +
                       "': its texture is bound to uv set " + std::to_string(t.tex_coord) +
                       ", which its meshes lack; the first set is used");
    t.tex_coord = 0;
  }
}

// COLLADA <lines> as three.js's ColladaLoader draws them (the judge of appearance): one pixel
// wide, unlit, in their material's colour and opacity (a Lambert or Phong material becomes a
// LineBasicMaterial of its colour, a constant one stays a MeshBasicMaterial; a material without
// <diffuse> is white, see default_colors), textures aside; white without a material. Sets of
// one colour become one (they are in world space): a SketchUp wall's 22 edge geometries are one
// draw call, not 22.
void line_colors(const std::vector<int32_t>& materials, Scene& scene) {
  std::vector<LineSet> merged;
  for (size_t l = 0; l < scene.lines.size() && l < materials.size(); ++l) {
    const int32_t m = materials[l];
    LineSet& set = scene.lines[l];
    set.color = m >= 0 && size_t(m) < scene.materials.size()
                    ? scene.materials[size_t(m)].base_color_factor
                    : Vec4{1, 1, 1, 1};
    auto same = std::find_if(merged.begin(), merged.end(),
                             [&](const LineSet& x) { return x.color == set.color; });
    if (same == merged.end()) {
      merged.push_back(std::move(set));
      continue;
    }
    const uint32_t base = uint32_t(same->positions.size());
    same->positions.insert(same->positions.end(), set.positions.begin(), set.positions.end());
    for (uint32_t i : set.indices) same->indices.push_back(base + i);
  }
  scene.lines = std::move(merged);
}

}  // namespace

Result<Scene> import_collada(const std::string& path, const ImportOptions& options,
                             Warnings* warnings) {
  const std::string stage = "collada: " + base_name(path);
  try {
    // Our own checks first, for our own messages; Assimp then reads the file by path so that
    // it knows the folder textures are relative to.
    uint64_t file_bytes = 0;
    std::map<std::string, ColladaMaterialInfo> info;  // what Assimp loses, by material
    std::string repaired;  // the document with its file-less <image>s named, or "" (as it is)
    {
      auto bytes = read_whole_file(path, options.max_file_bytes);
      if (!bytes)
        return Status::error(stage + ": " + strip_prefix(bytes.status().message(), path),
                             ErrorKind::kInput);
      if (bytes->empty()) return Status::error(stage + ": file is empty", ErrorKind::kInput);
      file_bytes = bytes->size();
      info = collada_material_info(*bytes);
      std::vector<std::string> ids;
      repaired = repair_collada_images(*bytes, &ids);
      for (const std::string& id : ids)
        warn(warnings, stage + ": image '" + id +
                           "' names no file (no <init_from> or <data>); its texture is dropped");
    }
    Result<Parsed> parsed = parse_isolated(path, file_bytes, stage, repaired);
    if (!parsed) return parsed.status();
    for (std::string& w : parsed->warnings) warn(warnings, std::move(w));
    Scene scene = std::move(parsed->scene);
    scene.source = path;
    const ImportOptions limits = resolved_limits(options, file_bytes);
    if (scene.instances.size() > limits.max_instances)
      return Status::error(stage + ": the node graph expands to " +
                               std::to_string(scene.instances.size()) + " instances, over " +
                               std::to_string(limits.max_instances) +
                               " (the limit from the input's size; --max-instances raises it)",
                           ErrorKind::kInput);
    // Assimp 5.2 reports every <shininess> as 0: the document's own exponent of a <phong> or
    // <blinn> effect gives the roughness as convert_material maps it (0 read as 30).
    for (Material& m : scene.materials)
      if (auto it = info.find(m.name);
          it != info.end() && it->second.shininess >= 0 && std::isfinite(it->second.shininess)) {
        const double n = it->second.shininess > 0 ? it->second.shininess : kDefaultShininess;
        m.roughness_factor = clamp01(float(std::pow(2.0 / (n + 2.0), 0.25)));
      }
    default_colors(info, scene);
    auto scope = input_scope(path, options.allow_outside, options.root);
    if (!scope.ok())
      return Status::error(stage + ": " + scope.status().message(), ErrorKind::kInput);
    TextureLoader loader(path, *scope, scene, limits, warnings);
    for (TextureRequest& t : parsed->textures) {
      const Material& m = scene.materials[size_t(std::max(0, t.material))];
      if (auto it = info.find(m.name);
          it != info.end() && it->second.uv_set >= 0 && t.material >= 0)
        t.uv = unsigned(it->second.uv_set);
      loader.attach(t);
      if (!loader.refusal().empty())
        return Status::error(stage + ": texture '" + t.path + "': " + loader.refusal(),
                             ErrorKind::kInput);
    }
    line_colors(parsed->line_materials, scene);
    first_uv_set_where_missing(scene, stage, warnings);
    Status valid = validate(scene, stage);
    if (!valid) return valid;
    return scene;
  } catch (const std::bad_alloc&) {
    throw;  // the caller knows the memory limit and the option that raises it
  } catch (const std::exception& e) {
    return Status::error(stage + ": " + one_line(e.what()), ErrorKind::kInternal);
  }
}

}  // namespace meshmux
