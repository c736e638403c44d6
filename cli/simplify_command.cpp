// meshmux simplify IN -o OUT.glb (--ratio R | --triangles N | --error E): one level of detail
// of the instance-aware progressive record, written as a .glb.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "clean/clean.h"
#include "cli/args.h"
#include "cli/commands.h"
#include "core/exit_codes.h"
#include "core/file_io.h"
#include "core/stderr_progress.h"
#include "core/text.h"
#include "exporters/gltf.h"
#include "pipeline/inputs.h"
#include "simplify/lod.h"
#include "simplify/simplify.h"

namespace meshmux {

int cmd_simplify(const std::vector<std::string>& args) {
  auto p = parse_args(kSimplify, args);
  if (!p.ok()) return usage_error(kSimplify, p.status().message());
  if (p->help) return std::fputs(meshmux_usage(), stdout), kExitOk;
  if (p->positional.empty()) return usage_error(kSimplify, "no input file given");
  const std::string in = p->positional[0], out = p->text("--output");
  if (out.empty() || !has_extension(out, ".glb"))
    return usage_error(kSimplify, "-o OUT.glb is required");
  const int targets = int(p->has("--ratio")) + int(p->has("--triangles")) + int(p->has("--error"));
  if (targets != 1)
    return usage_error(kSimplify, "give exactly one of --ratio, --triangles, --error");
  const double ratio = p->number("--ratio", -1), error = p->number("--error", -1);
  const long long triangles = p->whole("--triangles", -1);
  UploadFlags u = upload_flags(*p);
  auto upload = open_command_input(in, out, false, u.upload, &u.import, u.max_memory_mb);
  if (!upload.ok()) return print_error(upload.status());
  Warnings warnings;
  StderrProgress progress(p->has("--quiet"), &warnings);
  progress.step("importing " + upload->display());
  auto scene = import_scene(upload->model(), u.import, &warnings);
  progress.flush();
  if (!scene.ok()) return print_error(scene.status());
  Scene cleaned = clean(*scene, CleanOptions{});
  progress.step("simplifying");
  SimplifyReport sr;
  ProgressiveScene ps = build_progressive(cleaned, SimplifyOptions{}, &sr, &progress);
  LodSelection sel;
  if (error >= 0)
    sel = select_error(ps, float(error));
  else if (triangles >= 0)
    sel = select_triangles(ps, uint64_t(triangles));
  else
    sel = select_triangles(ps, uint64_t(std::floor(ratio * double(sr.input_triangles))));
  Scene level = materialize(ps, sel);
  SceneStats ls = compute_stats(level);
  progress.step("level: " + std::to_string(ls.scene_triangles) + " of " +
                std::to_string(sr.input_triangles) + " scene triangles, " +
                std::to_string(ls.unique_triangles) + " unique, " + std::to_string(ls.instances) +
                " instances" + (sr.flattened ? " (flattened)" : ""));
  auto bytes = export_glb_bytes(level, GltfExportOptions{}, &warnings);
  progress.flush();
  if (!bytes.ok()) return print_error(bytes.status());
  Status s = write_file_atomic(out, *bytes);
  if (!s) return print_error(s);
  progress.step("wrote " + out + " (" + human_bytes(bytes->size()) + ")");
  return kExitOk;
}

}  // namespace meshmux
