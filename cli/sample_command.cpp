// meshmux sample -o FILE.glb: the built-in demo scene (scene/sample.h), uncompressed so any
// glTF reader takes it as an input.
#include <cstdio>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "core/exit_codes.h"
#include "core/file_io.h"
#include "core/text.h"
#include "exporters/gltf.h"
#include "scene/sample.h"

namespace meshmux {

int cmd_sample(const std::vector<std::string>& args) {
  auto p = parse_args(kSample, args, /*max_positional=*/0);
  if (!p.ok()) return usage_error(kSample, p.status().message());
  if (p->help) return std::fputs(meshmux_usage(), stdout), kExitOk;
  const std::string out = p->text("--output");
  const bool quiet = p->has("--quiet");
  if (out.empty()) return usage_error(kSample, "no output given (-o FILE.glb)");
  if (!has_extension(out, ".glb")) return usage_error(kSample, "output must end in .glb");
  Warnings warnings;
  Scene scene = make_sample_scene();
  GltfExportOptions gopts;
  gopts.draco = false;  // the sample is an input: keep it exact and readable by anything
  auto bytes = export_glb_bytes(scene, gopts, &warnings);
  if (!bytes.ok()) return print_error(bytes.status());
  Status s = write_file_atomic(out, *bytes);
  if (!s) return print_error(s);
  if (!quiet) {
    SceneStats st = compute_stats(scene);
    std::fprintf(stderr, "meshmux: wrote %s (%zu meshes, %zu instances, %llu triangles, %s)\n",
                 out.c_str(), st.meshes, st.instances,
                 static_cast<unsigned long long>(st.scene_triangles),
                 human_bytes(bytes->size()).c_str());
  }
  return kExitOk;
}

}  // namespace meshmux
