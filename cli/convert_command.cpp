// meshmux convert IN -o OUT: the upload opened, the pipeline run (pipeline/convert.h), the
// outputs written as one transaction (pipeline/outputs.h).
#include <filesystem>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "core/exit_codes.h"
#include "core/stderr_progress.h"
#include "pipeline/convert.h"
#include "pipeline/inputs.h"
#include "pipeline/outputs.h"
#include "simplify/memory_fit.h"

namespace meshmux {

namespace {

// convert's own flags into the pipeline's options.
ConvertOptions convert_options(const ParsedArgs& p) {
  ConvertOptions o;
  o.gltf.position_bits = int(p.whole("--position-bits", o.gltf.position_bits));
  o.gltf.normal_bits = int(p.whole("--normal-bits", o.gltf.normal_bits));
  o.gltf.uv_bits = int(p.whole("--uv-bits", o.gltf.uv_bits));
  o.textures.jpeg_quality = int(p.whole("--jpeg-quality", o.textures.jpeg_quality));
  if (p.has("--crease")) o.clean.crease_angle_degrees = float(p.whole("--crease", 60));
  if (p.has("--no-draco")) o.gltf.draco = false;
  if (p.has("--no-atlas")) o.atlas = false;
  if (p.has("--no-report")) o.report = false;
  if (p.has("--blocks-above")) {  // 0: never (unless the memory cap needs blocks)
    const long long n = p.whole("--blocks-above", 0);
    o.simplify.block_above = n == 0 ? UINT64_MAX : uint64_t(n);
  }
  o.max_package_ratio = p.number("--max-package-ratio", o.max_package_ratio);
  return o;
}

}  // namespace

int cmd_convert(const std::vector<std::string>& args) {
  auto p = parse_args(kConvert, args);
  if (!p.ok()) return usage_error(kConvert, p.status().message());
  if (p->help) return std::fputs(meshmux_usage(), stdout), kExitOk;
  if (p->positional.empty()) return usage_error(kConvert, "no input file given");
  const std::string in = p->positional[0], out = p->text("--output");
  if (out.empty()) return usage_error(kConvert, "no output given (-o OUT.glb or -o FOLDER)");
  ConvertOptions o = convert_options(*p);
  // A big mesh's first block level spills beside the output (on its disk, not in memory).
  o.simplify.spill_dir = std::filesystem::path(out).parent_path().string();
  if (o.simplify.spill_dir.empty()) o.simplify.spill_dir = ".";
  if (p->has("--display") &&
      !parse_size(p->text("--display"), &o.multiplex.display_width, &o.multiplex.display_height))
    return usage_error(kConvert, "--display needs WxH device pixels, each 1..8192 (got '" +
                                     p->text("--display") + "')");
  UploadFlags u = upload_flags(*p);
  o.stream = !has_extension(out, ".glb");
  if (p->has("--textures")) {
    const std::string t = p->text("--textures");
    if (t != "ktx2" && t != "ktx2-uastc" && t != "default")
      return usage_error(kConvert,
                         "--textures needs ktx2, ktx2-uastc or default (got '" + t + "')");
    // Every texture level (atlas, kept maps) KTX2 as made by the levels, every other image by
    // the exporter; model.glb and base.glb carry the same files.
    o.textures.ktx2 = o.gltf.ktx2 = t != "default";
    o.textures.ktx2_options.colour_uastc = o.gltf.ktx2_options.colour_uastc = t == "ktx2-uastc";
  }
  auto upload = open_command_input(in, out, o.stream, u.upload, &u.import, u.max_memory_mb);
  if (!upload.ok()) return print_error(upload.status());
  // The memory cap (--max-memory, or the input's default) chooses when and how small blocks are.
  o.simplify = fit_simplify_to_memory(o.simplify, memory_limit_mb());
  Warnings warnings;
  StderrProgress progress(p->has("--quiet"), &warnings);
  progress.step("importing " + upload->display());
  auto scene = import_scene(upload->model(), u.import, &warnings);
  if (!scene.ok()) return progress.flush(), print_error(scene.status());
  auto r = convert(scene.take(), o, &warnings, &progress);
  progress.flush();
  if (!r.ok()) return print_error(r.status());
  if (Status s = write_outputs(out, o.stream, *r, progress); !s) return print_error(s);
  progress.step("wrote " + out + " (" + std::to_string(r->output.scene_triangles) + " triangles, " +
                std::to_string(r->output.draw_calls) + " draw calls)");
  return kExitOk;
}

}  // namespace meshmux
