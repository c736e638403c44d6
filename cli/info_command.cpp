// meshmux info FILE [--json]: what an upload holds (meshes, instances, triangles, materials,
// textures, draw calls, bytes served), as text or JSON on stdout.
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "core/exit_codes.h"
#include "core/text.h"
#include "pipeline/inputs.h"

namespace meshmux {

int cmd_info(const std::vector<std::string>& args) {
  auto p = parse_args(kInfo, args);
  if (!p.ok()) return usage_error(kInfo, p.status().message());
  if (p->help) return std::fputs(meshmux_usage(), stdout), kExitOk;
  if (p->positional.empty()) return usage_error(kInfo, "no file given");
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
