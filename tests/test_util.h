// Helpers shared by the tests: scratch folders, running the meshmux binary, the shared model
// set, and Khronos' glTF validator.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace meshmux::testing {

// A face rotated to start at its smallest corner, winding kept: faces compare up to rotation
// (meshopt's index codec may rotate corners).
template <class T>
std::array<T, 3> canonical_face(const T& a, const T& b, const T& c) {
  if (b < a && b < c) return {b, c, a};
  if (c < a && c < b) return {c, a, b};
  return {a, b, c};
}
// The faces of `indices` (3 per face) with each corner mapped through `corner`, canonical,
// degenerate ones (repeated corner indices) dropped, sorted: comparable across face orders
// and vertex numberings.
template <class F>
auto sorted_faces(const std::vector<uint32_t>& indices, F corner) {
  using T = decltype(corner(uint32_t(0)));
  std::vector<std::array<T, 3>> out;
  for (size_t i = 0; i + 2 < indices.size(); i += 3) {
    uint32_t a = indices[i], b = indices[i + 1], c = indices[i + 2];
    if (a == b || b == c || a == c) continue;
    out.push_back(canonical_face(corner(a), corner(b), corner(c)));
  }
  std::sort(out.begin(), out.end());
  return out;
}
inline std::vector<std::array<uint32_t, 3>> sorted_faces(const std::vector<uint32_t>& indices) {
  return sorted_faces(indices, [](uint32_t v) { return v; });
}

// A fresh empty folder under the system temp dir, removed when the object dies.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::string& path() const { return path_; }
  std::string file(const std::string& name) const { return path_ + "/" + name; }
  // Names of the entries in the folder, sorted.
  std::vector<std::string> list() const;

 private:
  std::string path_;
};

struct CommandResult {
  int exit_code = -1;  // the process's exit status; 128+N when killed by signal N
  std::string out;     // stdout
  std::string err;     // stderr
};

// Runs the meshmux binary with the given arguments (no shell quoting issues: args are
// passed as they are).
CommandResult run_meshmux(const std::vector<std::string>& args);

// Runs a program with arguments, capturing stdout and stderr.
CommandResult run_program(const std::string& program, const std::vector<std::string>& args);

// ../shared/models/<rel>, or "" when the shared folder is absent.
std::string shared_model(const std::string& rel);
// True when ../shared/models exists. Tests that need it call GTEST_SKIP with a message otherwise.
bool have_shared_models();

// True when offscreen OpenGL 4.5 through EGL can be had here (the renderer starts). Otherwise
// false, with the renderer's kUnavailable message in `why`: the one condition under which
// conversion skips its report and package, and tests may skip. Any other renderer failure is
// not "unavailable": it returns true so that the test goes on and fails.
bool renderer_available(std::string* why = nullptr);

// A UV sphere of `rings` × `segments` around `centre`: closed, with a uv seam along one
// meridian (the seam column repeats the first one's positions exactly, with other uvs) and
// smooth normals: 2·(rings−1)·segments triangles. The case where a careless collapse cracks.
Primitive uv_sphere(int rings, int segments, float radius = 1, Vec3 centre = {});
// A uv sphere with noise along its normals (a hash of each position, up to 0.3% of the
// radius): the rough surface a scan gives, where no collapse is free. Closed, with a uv seam.
// One mesh, one instance, not cleaned.
Scene bumpy_sphere(int rings, int segments);

// The unit square [x, x + 1] × [0, 1] at z = 0 facing +z, two triangles, its uvs spanning [0, 1]²
// (glTF's: v down the image), drawn with `material`.
Primitive unit_quad(float x, int32_t material);

// `count` unit quads side by side, quad k sampling all of its own side² texture (red 40·k, green
// and blue a gradient, so no texture is a palette and no two share texels: an atlas must bake
// them), each with its own material, one mesh placed once.
Scene quads_with_own_textures(int count, int side);

// A GoogleTest-safe name for a parameterized test over a shared model path: the model's folder
// with anything but letters and digits turned into '_' ("Duck-dae/duck.dae" → "Duck_dae").
std::string model_test_name(const std::string& relative_path);

// Every main model file in ../shared/models (one per folder), sorted.
std::vector<std::string> shared_model_files();

std::vector<uint8_t> read_file(const std::string& path);
void write_file(const std::string& path, const std::vector<uint8_t>& bytes);
void write_text(const std::string& path, const std::string& text);

// Runs Khronos' gltf-validator (node_modules/gltf-validator) on a file. Returns the number of
// errors it reports, or -1 when the validator is not installed; `report` gets its JSON report.
int gltf_validator_errors(const std::string& path, std::string* report = nullptr);

// A header-valid KTX2 (UASTC with `scheme` supercompression, or ETC1S), 16×16, sRGB, whose level
// 0 is `data_bytes` zeros: the smallest file image/ktx2_transcode.h's header check accepts, with
// data no transcoder can read. Fields per the KTX 2.0 specification §3.
std::vector<uint8_t> ktx2_shell(uint32_t scheme = 0, bool etc1s = false, size_t data_bytes = 64);

}  // namespace meshmux::testing

// A Renderer named `var` made with `opts` (multiplex/render.h), in a test body: the test is
// skipped only when offscreen OpenGL is unavailable here; any other failure fails.
#define MAKE_RENDERER(var, opts)                                                \
  auto var##_result = Renderer::create(opts);                                   \
  if (!var##_result && var##_result.status().kind() == ErrorKind::kUnavailable) \
    GTEST_SKIP() << var##_result.status().message();                            \
  ASSERT_TRUE(var##_result.ok()) << var##_result.status().message();            \
  std::unique_ptr<Renderer> var = var##_result.take()
