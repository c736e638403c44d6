// Helpers shared by the tests: scratch folders, running the meshmux binary, the shared model
// set, and Khronos' glTF validator.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "scene/scene.h"

namespace meshmux::testing {

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

}  // namespace meshmux::testing
