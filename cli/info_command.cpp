// meshmux info FILE [--json]: what an upload holds (meshes, instances, triangles, materials,
// textures, draw calls, bytes served), or what a world.json places (stream/world_format.h) with
// each package file checked, as text or JSON on stdout.
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "core/exit_codes.h"
#include "core/file_io.h"
#include "core/text.h"
#include "pipeline/inputs.h"
#include "stream/world_format.h"

namespace meshmux {

namespace {

bool ends_with_json(const std::string& path) {
  if (path.size() < 5) return false;
  std::string tail = path.substr(path.size() - 5);
  for (char& c : tail) c = char(std::tolower(static_cast<unsigned char>(c)));
  return tail == ".json";
}

// A world.json: validated as the browser validates it, then every package's file looked for
// beside it (present, and of the size the world says). Problems go to stderr, one line each,
// and make the exit code kExitInput.
int info_world(const std::string& path, bool json) {
  const std::string file = base_name(path);
  auto bytes = read_whole_file(path, kWorldMaxBytes);
  if (!bytes.ok()) return print_error(bytes.status());
  auto world = parse_world(std::string(bytes->begin(), bytes->end()), file);
  if (!world.ok()) return print_error(world.status());
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::vector<std::string> problems;
  uint64_t total = 0;
  for (size_t i = 0; i < world->packages.size(); ++i) {
    const WorldPackage& p = world->packages[i];
    const std::string where = file + ": packages[" + std::to_string(i) + "] '" + p.name + "': ";
    std::error_code ec;
    const std::filesystem::path on_disk = folder / percent_decode(p.url);
    const bool present = std::filesystem::is_regular_file(on_disk, ec);
    const uintmax_t size = present ? std::filesystem::file_size(on_disk, ec) : 0;
    if (!present || ec)
      problems.push_back(where + p.url + ": no such file");
    else if (p.bytes > 0 && size != p.bytes)
      problems.push_back(where + p.url + ": " + std::to_string(size) + " bytes, the world says " +
                         std::to_string(p.bytes));
    total += p.bytes;
  }
  if (json) {
    nlohmann::ordered_json j;
    j["file"] = path;
    j["world_version"] = kWorldVersion;
    j["packages"] = world->packages.size();
    j["placements"] = world->placements.size();
    j["package_bytes"] = total;
    j["problems"] = problems;
    std::printf("%s\n", j.dump(1).c_str());
  } else {
    std::printf("file              %s\n", path.c_str());
    std::printf("world version     %d\n", kWorldVersion);
    std::printf("packages          %zu (%s in all)\n", world->packages.size(),
                human_bytes(total).c_str());
    std::printf("placements        %zu\n", world->placements.size());
    std::printf("package files     %s\n",
                problems.empty() ? "all present"
                                 : (std::to_string(problems.size()) + " with problems").c_str());
  }
  for (const std::string& p : problems) std::fprintf(stderr, "meshmux: %s\n", p.c_str());
  return problems.empty() ? kExitOk : kExitInput;
}

}  // namespace

int cmd_info(const std::vector<std::string>& args) {
  auto p = parse_args(kInfo, args);
  if (!p.ok()) return usage_error(kInfo, p.status().message());
  if (p->help) return std::fputs(meshmux_usage(), stdout), kExitOk;
  if (p->positional.empty()) return usage_error(kInfo, "no file given");
  if (ends_with_json(p->positional[0])) return info_world(p->positional[0], p->has("--json"));
  UploadFlags u = upload_flags(*p);
  auto upload = open_input(p->positional[0], u.upload, "", &u.import);
  if (!upload.ok()) return print_error(upload.status());
  const std::string file = upload->model();
  apply_memory_limit(file, u.import, u.max_memory_mb);
  Warnings warnings;
  auto scene = import_scene(file, u.import, &warnings);
  if (!scene.ok()) return print_error(scene.status());
  SceneStats s = compute_stats(*scene);
  uint64_t bytes = asset_bytes(file, u.import);
  Bounds b = scene_bounds(*scene);
  if (p->has("--json")) {
    nlohmann::ordered_json j;
    j["file"] = upload->display();
    j["meshes"] = s.meshes;
    j["primitives"] = s.primitives;
    j["instances"] = s.instances;
    j["scene_triangles"] = s.scene_triangles;
    j["unique_triangles"] = s.unique_triangles;
    j["vertices"] = s.vertices;
    j["materials"] = s.materials;
    j["textures"] = s.textures;
    j["texture_pixels"] = s.texture_pixels;
    j["draw_calls"] = s.draw_calls;
    j["bytes"] = bytes;
    if (!b.empty()) {
      j["bounds"] = {{"min", {b.min.x, b.min.y, b.min.z}}, {"max", {b.max.x, b.max.y, b.max.z}}};
    }
    j["warnings"] = warnings.items();
    std::printf("%s\n", j.dump(1).c_str());
  } else {
    for (const auto& w : warnings.items())
      std::fprintf(stderr, "meshmux: warning: %s\n", w.c_str());
    std::printf("file              %s\n", upload->display().c_str());
    std::printf("bytes             %llu (%s)\n", static_cast<unsigned long long>(bytes),
                human_bytes(bytes).c_str());
    std::printf("meshes            %zu (%zu primitives)\n", s.meshes, s.primitives);
    std::printf("instances         %zu\n", s.instances);
    std::printf("scene triangles   %llu\n", static_cast<unsigned long long>(s.scene_triangles));
    std::printf("unique triangles  %llu\n", static_cast<unsigned long long>(s.unique_triangles));
    std::printf("vertices          %llu\n", static_cast<unsigned long long>(s.vertices));
    std::printf("materials         %zu\n", s.materials);
    std::printf("textures          %zu (%.1f Mpx)\n", s.textures, double(s.texture_pixels) / 1e6);
    std::printf("draw calls        %llu\n", static_cast<unsigned long long>(s.draw_calls));
    if (!b.empty())
      std::printf("bounds            [%g %g %g] .. [%g %g %g]\n", b.min.x, b.min.y, b.min.z,
                  b.max.x, b.max.y, b.max.z);
  }
  return kExitOk;
}

}  // namespace meshmux
