// meshmux render IN -o OUT.png: IN drawn offscreen as the web viewer draws it (exit 5 without
// offscreen OpenGL). Output: PNG (RGBA, background transparent) or Netpbm
// PAM (P7, TUPLTYPE RGB_ALPHA: a header a few lines long and the raw top-to-bottom RGBA rows,
// trivial for test harnesses to read), chosen by the extension. Written through a temporary
// name and renamed when complete.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "clean/clean.h"
#include "cli/args.h"
#include "cli/commands.h"
#include "core/exit_codes.h"
#include "core/file_io.h"
#include "image/decode.h"
#include "image/encode.h"
#include "importers/import.h"
#include "multiplex/render.h"
#include "multiplex/viewpoints.h"

namespace meshmux {

namespace {

const char* kRenderUsage =
    "usage: meshmux render IN -o OUT.png|OUT.pam [options]\n"
    "  Renders IN offscreen as the web viewer draws it: perspective camera, mipmapped anisotropic\n"
    "  textures, glTF metal-roughness shading as three.js's MeshStandardMaterial (normal,\n"
    "  occlusion-roughness-metallic and emissive maps) under a uniform environment and a light\n"
    "  following the camera, sRGB output, transparent background. Each primitive shows its own\n"
    "  material's textures (with the uv set its base colour names) and factors.\n"
    "  --shading physical|lambert  lambert: colour x (0.35 + 0.65 Lambert), texels as stored\n"
    "                      (how packages before physically based shading were measured)\n"
    "  --size WxH          image size in pixels (default 512x512)\n"
    "  --eye X,Y,Z         camera position (default: framed like the viewer's first view)\n"
    "  --target X,Y,Z      looked-at point (default: the centre of the model's bounds)\n"
    "  --up X,Y,Z          up vector (default 0,1,0)\n"
    "  --fov DEGREES       vertical field of view (default 45)\n"
    "  --near N --far F    clip planes (default: from the model's bounds)\n"
    "  -q, --quiet         no messages on stderr\n";

int fail(const Status& s) { return print_error(s.with_prefix("render")); }

bool parse_number(const std::string& text, double* out) {
  if (text.empty()) return false;
  char* end = nullptr;
  double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

bool parse_vec3(const std::string& text, Vec3* out) {
  double v[3];
  size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    size_t comma = text.find(',', start);
    if ((i < 2) != (comma != std::string::npos)) return false;
    std::string part = text.substr(start, i < 2 ? comma - start : std::string::npos);
    if (!parse_number(part, &v[i])) return false;
    start = comma + 1;
  }
  *out = Vec3{float(v[0]), float(v[1]), float(v[2])};
  return true;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

int cmd_render(const std::vector<std::string>& args) {
  auto p = parse_args(kRender, args);
  if (!p.ok()) return usage_error(kRender, p.status().message());
  if (p->help) return std::fputs(kRenderUsage, stdout), kExitOk;
  const std::string in = p->positional.empty() ? "" : p->positional[0];
  const std::string out = p->text("--output");
  const bool quiet = p->has("--quiet");
  const std::string shading_name = p->text("--shading", "physical");
  if (shading_name != "physical" && shading_name != "lambert")
    return usage_error(kRender, "--shading expects physical or lambert");
  const Shading shading = shading_name == "physical" ? Shading::kPhysical : Shading::kLambert;
  int width = 512, height = 512;
  if (p->has("--size") && !parse_size(p->text("--size"), &width, &height))
    return usage_error(kRender, "--size expects WxH between 1 and 8192, e.g. 512x512");
  Vec3 eye, target, up{0, 1, 0};
  const bool have_eye = p->has("--eye"), have_target = p->has("--target");
  for (auto [flag, point] :
       {std::pair<const char*, Vec3*>{"--eye", &eye}, {"--target", &target}, {"--up", &up}})
    if (p->has(flag) && !parse_vec3(p->text(flag), point))
      return usage_error(kRender, std::string(flag) + " expects X,Y,Z numbers");
  const double fov = p->number("--fov", 45);
  const bool have_near = p->has("--near"), have_far = p->has("--far");
  const double near_plane = p->number("--near", 0), far_plane = p->number("--far", 0);
  if (in.empty()) return usage_error(kRender, "no input given (meshmux render IN -o OUT.png)");
  if (out.empty()) return usage_error(kRender, "no output given (-o OUT.png or OUT.pam)");
  if (!ends_with(out, ".png") && !ends_with(out, ".pam"))
    return usage_error(kRender, out + ": the output must end in .png or .pam");

  Warnings warnings;
  auto scene = import_scene(in, ImportOptions{}, &warnings);
  if (!scene.ok()) return fail(scene.status());
  Scene s = clean(*scene, CleanOptions{});  // generates missing normals
  for (Image& image : s.images)             // every primitive draws its own material's texture
    if (!image.encoded.empty() && !image.decoded())
      if (Status st = decode_image(image); !st) return fail(st.with_prefix(in));

  Bounds bounds = scene_bounds(s);
  float aspect = float(width) / float(height);
  ViewOptions vo;
  vo.fov_y_degrees = float(fov);
  // The viewer's first view (the package table carries ViewOptions to viewers/web/viewer.js).
  Camera cam = camera_for(normalize(vo.direction), bounds, aspect, vo);
  if (have_eye) cam.eye = eye;
  if (have_target) cam.target = target;
  if (p->has("--up")) cam.up = up;
  cam.fov_y_degrees = float(fov);
  if (have_eye || have_target) {  // planes around the model as seen from the given eye
    double r = 0.5 * double(bounds.diagonal()), d = double(length(bounds.center() - cam.eye));
    if (!(r > 0)) r = 1;
    double margin = double(vo.clip_margin);
    cam.near_plane = float(std::max(d - margin * r, d * 1e-3));
    cam.far_plane = float(d + margin * r);
  }
  if (have_near) cam.near_plane = float(near_plane);
  if (have_far) cam.far_plane = float(far_plane);
  if (!(cam.far_plane > cam.near_plane)) return usage_error(kRender, "--far must exceed --near");

  RenderOptions ro = physical_shading();
  ro.shading = shading;
  ro.width = width, ro.height = height;
  auto renderer = Renderer::create(ro);
  if (!renderer.ok()) return fail(renderer.status());
  int g = (*renderer)->add_geometry(s, /*with_textures=*/true);
  RenderImage img = (*renderer)->render(g, -1, cam);

  std::vector<uint8_t> bytes;
  if (ends_with(out, ".pam")) {
    std::string header = "P7\nWIDTH " + std::to_string(img.width) + "\nHEIGHT " +
                         std::to_string(img.height) +
                         "\nDEPTH 4\nMAXVAL 255\nTUPLTYPE RGB_ALPHA\nENDHDR\n";
    bytes.assign(header.begin(), header.end());
    bytes.insert(bytes.end(), img.rgba.begin(), img.rgba.end());
  } else {
    Image png;
    png.name = out;
    png.width = img.width, png.height = img.height;
    png.rgba = img.rgba;
    auto encoded = encode_png(png);
    if (!encoded.ok()) return fail(encoded.status());
    bytes = encoded.take();
  }
  if (Status st = write_file_atomic(out, bytes); !st) return fail(st);
  size_t covered = 0;
  for (uint8_t c : img.coverage) covered += c;
  if (!quiet)
    std::fprintf(stderr,
                 "meshmux: render: wrote %s (%dx%d, %zu pixels covered; eye %g,%g,%g target "
                 "%g,%g,%g fov %g near %g far %g)\n",
                 out.c_str(), img.width, img.height, covered, cam.eye.x, cam.eye.y, cam.eye.z,
                 cam.target.x, cam.target.y, cam.target.z, double(cam.fov_y_degrees),
                 double(cam.near_plane), double(cam.far_plane));
  return kExitOk;
}

}  // namespace meshmux
