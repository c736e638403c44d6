// Offscreen renderer for the rate-distortion multiplexer (see render.h).
//
// Context: EGL on Mesa's surfaceless platform (EGL_MESA_platform_surfaceless), an OpenGL 4.5
// core context made current without any surface, and a framebuffer object of its own (RGBA8
// colour + DEPTH24 renderbuffers, single-sampled: no MSAA, so llvmpipe's output is
// bit-for-bit deterministic). When the surfaceless platform is missing, the default EGL display
// is tried with EGL_KHR_surfaceless_context (again no pbuffer).
//
// Drawing: one program, and a depth-only one for the pre-pass (RenderOptions::depth_prepass:
// when a call draws several texture sets, they share one depth pass and shade only the nearest
// surface);
// one draw call per (instance, primitive) with the instance's model-view-projection matrix
// (computed in double on the CPU, so large world coordinates keep their bits) and world-space
// normal matrix as uniforms. No culling; two-sided lighting flips the normal of back faces
// (gl_FrontFacing; instances with mirroring transforms get glFrontFace(CW) so "front" still
// means counter-clockwise in mesh space). Two shadings (RenderOptions::shading; the shaders are
// multiplex/render_shaders.cpp):
//   Lambert:  rgb = base.rgb * (ambient + diffuse * max(dot(N, L), 0)), texels used as stored
//             sRGB bytes (what packages before physically based shading were measured with);
//   physical: glTF metal-roughness as three.js's MeshStandardMaterial shades it (normal,
//             occlusion-roughness-metallic, emissive and sheen maps; a uniform environment and a
//             directional light), in linear light with sRGB decode of colour textures and an
//             sRGB-encoded output, as three.js's default renderer writes it.
// base = texture(uv0) * base_color_factor (the factor alone when untextured). Alpha modes are
// ignored (everything is drawn opaque).
//
// Textures: a render call draws every primitive with the texture set it is given (the
// multiplexer's texture levels of the atlas), or, for geometry added with its textures, each
// primitive with its own material's. Rows are uploaded top row first, so
// GL's t = 0 is the image's top row, which is exactly glTF's v = 0: uvs are used unflipped.
// Trilinear mipmapping + anisotropic filtering, each texture wrapped as add_texture was told
// (clamp-to-edge unless its material's sampler repeats). llvmpipe's anisotropic filter
// (Mesa 22.3) also kicks in under magnification, where it blurs and jitters texels (a 2x2
// texture magnified 64x comes out noisy); GPUs filter magnified texels bilinearly. So the texture
// is bound twice, with an anisotropic and a plain trilinear sampler object, and the shader uses
// the anisotropic one only where a pixel's footprint spans more than one texel.
//
// Readback: glReadPixels (bottom row first) is flipped so row 0 is the top of the image.

#define GL_GLEXT_PROTOTYPES 1
#include "multiplex/render.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/glcorearb.h>
#include <meshoptimizer.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <tuple>

#include "image/texture_levels.h"
#include "multiplex/dfg_lut.h"
#include "multiplex/render_shaders.h"
#include "scene/dvec3.h"

#ifndef GL_MAX_TEXTURE_MAX_ANISOTROPY
#define GL_MAX_TEXTURE_MAX_ANISOTROPY 0x84FF
#endif
#ifndef GL_TEXTURE_MAX_ANISOTROPY
#define GL_TEXTURE_MAX_ANISOTROPY 0x84FE
#endif

namespace meshmux {
namespace {

// Texels per display pixel (RenderOptions::display_scale) beyond which a texture's finer mip
// levels are not uploaded (add_texture).
constexpr int kUploadPerPixel = 4;

// The GL wrap modes (glTF's sampler values are the GL enums), and a Wrap's index among them.
constexpr GLenum kWraps[3] = {GL_CLAMP_TO_EDGE, GL_REPEAT, GL_MIRRORED_REPEAT};
int wrap_index(Wrap w) { return w == Wrap::kRepeat ? 1 : w == Wrap::kMirroredRepeat ? 2 : 0; }

// ---- EGL helpers -------------------------------------------------------------------------

std::string egl_error_name() {
  char buf[32];
  std::snprintf(buf, sizeof buf, "EGL error 0x%04X", unsigned(eglGetError()));
  return buf;
}

bool has_extension(const char* list, const char* name) {
  if (!list) return false;
  size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n)
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

Status egl_failure(const std::string& what) {
  return Status::error("render: EGL: " + what, ErrorKind::kUnavailable);
}

// EGL displays are process-wide; several Renderers share one and count their uses. The display
// is never terminated (see ~Renderer).
std::mutex& display_mutex() {
  static std::mutex m;
  return m;
}
std::map<EGLDisplay, int>& display_uses() {
  static std::map<EGLDisplay, int> uses;
  return uses;
}

// ---- Matrices (double, column-major like Mat4) ---------------------------------------------

// Look-at view matrix; `rows` receives the camera's right, up and backward axes in world space.
Mat4 look_at(const Camera& c, DVec3 rows[3]) {
  DVec3 eye = to_dvec3(c.eye);
  DVec3 f = normalize(sub(to_dvec3(c.target), eye));
  if (dot(f, f) == 0) f = {0, 0, -1};
  DVec3 up = normalize(to_dvec3(c.up));
  DVec3 s = normalize(cross(f, up));
  if (dot(s, s) < 1e-12) {  // up parallel to the view direction: pick another up
    up = std::abs(f.y) < 0.9 ? DVec3{0, 1, 0} : DVec3{1, 0, 0};
    s = normalize(cross(f, up));
  }
  DVec3 u = cross(s, f);
  DVec3 b{-f.x, -f.y, -f.z};
  rows[0] = s;
  rows[1] = u;
  rows[2] = b;
  Mat4 v;
  for (int i = 0; i < 3; ++i) {
    v.at(i, 0) = rows[i].x;
    v.at(i, 1) = rows[i].y;
    v.at(i, 2) = rows[i].z;
    v.at(i, 3) = -dot(rows[i], eye);
  }
  return v;
}

Mat4 perspective(double fov_y_degrees, double aspect, double n, double f) {
  double t = 1.0 / std::tan(fov_y_degrees * 3.14159265358979323846 / 360.0);
  Mat4 p;
  p.m.fill(0);
  p.at(0, 0) = t / aspect;
  p.at(1, 1) = t;
  p.at(2, 2) = (f + n) / (n - f);
  p.at(2, 3) = 2 * f * n / (n - f);
  p.at(3, 2) = -1;
  return p;
}

Result<GLuint> compile(GLenum type, const char* source) {
  GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048] = {0};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    return Status::error(std::string("render: shader compile failed: ") + log,
                         ErrorKind::kInternal);
  }
  return s;
}

struct Vertex {
  float position[3];
  float normal[3];
  float uv[2];
};

struct GpuPrimitive {
  GLuint vao = 0, vbo = 0, ibo = 0;
  GLsizei index_count = 0;
  Vec4 factor{1, 1, 1, 1};
  float metallic = 1, roughness = 1, occlusion_strength = 1, normal_scale = 1;
  Vec3 emissive{0, 0, 0};
  Vec3 sheen{0, 0, 0};  // sheen colour factor (0: no sheen layer)
  float sheen_roughness = 0;
  TextureSet textures;  // its material's own textures (add_geometry with_textures), or none
  // add_geometry streamed_material: a primitive of a material kept beside the atlas, drawn with its
  // own images (per TextureSet slot: base colour, normal, orm, emissive, sheen; -1 none) through
  // an explicit set's `kept` handles.
  bool keeps_own = false;
  std::array<int32_t, 5> images{-1, -1, -1, -1, -1};
};

struct GpuInstance {
  uint32_t mesh = 0;
  Mat4 world;
};

struct GpuGeometry {
  bool live = false;
  std::vector<std::vector<GpuPrimitive>> meshes;  // per mesh, its primitives
  std::vector<GpuInstance> instances;
};

// One camera of a render call: its view, projection × view, and the direction towards the
// light in world space (Lambert) and in view space (physical shading).
struct CameraFrame {
  Mat4 view;
  Mat4 view_proj;
  DVec3 light;
  DVec3 light_view;
};

}  // namespace

struct Renderer::Impl {
  RenderOptions options;
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  GLuint fbo = 0, color_rb = 0, depth_rb = 0;
  GLuint program = 0;
  GLuint depth_program = 0;  // the depth pre-pass: same vertex shader, empty fragment shader
  GLint d_mvp = -1;
  GLint u_mvp = -1, u_normal = -1, u_texture = -1, u_texture_plain = -1, u_texture_size = -1,
        u_textured = -1, u_factor = -1, u_light = -1, u_ambient = -1, u_diffuse = -1;
  GLint u_model_view = -1, u_normal_view = -1, u_physical = -1, u_normal_map = -1, u_orm_map = -1,
        u_emissive_map = -1, u_dfg = -1, u_has_normal_map = -1, u_has_orm_map = -1,
        u_has_emissive_map = -1, u_metallic = -1, u_roughness = -1, u_occlusion_strength = -1,
        u_normal_scale = -1, u_emissive = -1, u_environment = -1, u_light_intensity = -1,
        u_sheen_map = -1, u_has_sheen_map = -1, u_sheen = -1, u_sheen_roughness = -1,
        u_display_scale = -1;
  // Texture units: 0 base colour (anisotropic), 1 base colour (plain), 2 normal, 3
  // occlusion-roughness-metallic, 4 emissive, 6 sheen colour (anisotropic sampler), 5 the DFG
  // table.
  // samplers[a][s][t]: anisotropic (a = 1) or plain, wrap s and t by wrap_index.
  GLuint samplers[2][3][3] = {}, sampler_table = 0;
  GLuint dfg_texture = 0;
  float max_anisotropy = 1;
  // Whether the samplers filter anisotropically: not with a display scale (RenderOptions::
  // display_scale ≠ 1), as llvmpipe's anisotropic filter takes its level of detail from the
  // pixel's own derivatives, ignoring a bias and explicit gradients alike; there the samplers are
  // trilinear, the level biased to the display's (isotropic: the footprint's major axis).
  bool anisotropic() const { return options.display_scale == 1.0f; }
  std::vector<GpuGeometry> geometries;
  struct Texture {
    GLuint id = 0;  // 0 = freed
    int width = 0, height = 0;
    Wrap wrap_s = Wrap::kClampToEdge, wrap_t = Wrap::kClampToEdge;
  };
  std::vector<Texture> textures;

  void make_current() {
    if (eglGetCurrentContext() != context)
      eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context);
  }
  Status init_egl();
  Status init_gl();

  // The phases of render() with sets and cameras (defined beside it).
  bool live(int k) const;
  void draw_depth(const GpuGeometry& geo, const CameraFrame& frame);
  void draw_shaded(const GpuGeometry& geo, const CameraFrame& frame, const TextureSet& t);
  void use_shading_program(const CameraFrame& frame);
  void set_instance(const CameraFrame& frame, const GpuInstance& inst);
  void set_primitive(const GpuPrimitive& p, bool explicit_set);
  void bind_set(const TextureSet& set, TextureSet& bound);
  static TextureSet kept_set(const GpuPrimitive& p, const TextureSet& t);
  void bind_map(int want, int have, GLint flag, GLenum unit);
  void bind_unit(GLenum unit, int k);
};

Status Renderer::Impl::init_egl() {
  const char* client_ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  bool surfaceless = false;
  if (has_extension(client_ext, "EGL_MESA_platform_surfaceless")) {
    auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (get_platform_display) {
      display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA,
                                     reinterpret_cast<void*>(EGL_DEFAULT_DISPLAY), nullptr);
      surfaceless = display != EGL_NO_DISPLAY;
    }
  }
  std::string missing = "no surfaceless platform (install libegl-mesa0 libgl1-mesa-dri)";
  if (!surfaceless) display = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  if (display == EGL_NO_DISPLAY) return egl_failure(missing + "; no default display either");
  {
    std::lock_guard<std::mutex> lock(display_mutex());
    EGLint major = 0, minor = 0;
    if (!eglInitialize(display, &major, &minor)) {
      std::string why = egl_error_name();
      display = EGL_NO_DISPLAY;
      return egl_failure((surfaceless ? std::string("eglInitialize failed on the surfaceless "
                                                    "platform")
                                      : missing + "; eglInitialize on the default display "
                                                  "failed") +
                         " (" + why + ")");
    }
    ++display_uses()[display];
  }
  const char* ext = eglQueryString(display, EGL_EXTENSIONS);
  if (!surfaceless && !has_extension(ext, "EGL_KHR_surfaceless_context"))
    return egl_failure(missing + "; the default display lacks EGL_KHR_surfaceless_context");
  if (!eglBindAPI(EGL_OPENGL_API)) return egl_failure("no desktop OpenGL API (eglBindAPI)");

  EGLConfig config = EGL_NO_CONFIG_KHR;
  if (!has_extension(ext, "EGL_KHR_no_config_context") &&
      !has_extension(ext, "EGL_MESA_configless_context")) {
    const EGLint attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, 0, EGL_NONE};
    EGLint count = 0;
    if (!eglChooseConfig(display, attribs, &config, 1, &count) || count < 1)
      return egl_failure("no OpenGL-renderable config (" + egl_error_name() + ")");
  }
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                    4,
                                    EGL_CONTEXT_MINOR_VERSION,
                                    5,
                                    EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                    EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                    EGL_NONE};
  context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attribs);
  if (context == EGL_NO_CONTEXT)
    return egl_failure("cannot create an OpenGL 4.5 core context (" + egl_error_name() + ")");
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context))
    return egl_failure("cannot make the context current without a surface (" + egl_error_name() +
                       ")");
  return Status::ok();
}

Status Renderer::Impl::init_gl() {
  auto fail = [](const std::string& what) {
    return Status::error("render: GL: " + what, ErrorKind::kInternal);
  };
  GLint major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  if (major * 10 + minor < 45)
    return Status::error(
        "render: GL: OpenGL 4.5 needed, got " + std::to_string(major) + "." + std::to_string(minor),
        ErrorKind::kUnavailable);
  GLint max_rb = 0;
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
  if (options.width < 1 || options.height < 1 || options.width > max_rb || options.height > max_rb)
    return Status::error("render: image size " + std::to_string(options.width) + "x" +
                             std::to_string(options.height) + " outside 1.." +
                             std::to_string(max_rb),
                         ErrorKind::kInput);
  glGetFloatv(GL_MAX_TEXTURE_MAX_ANISOTROPY, &max_anisotropy);
  if (!(max_anisotropy >= 1)) max_anisotropy = 1;
  glGetError();  // anisotropy is core in 4.6 only; ignore an error from the query above

  glGenRenderbuffers(1, &color_rb);
  glBindRenderbuffer(GL_RENDERBUFFER, color_rb);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, options.width, options.height);
  glGenRenderbuffers(1, &depth_rb);
  glBindRenderbuffer(GL_RENDERBUFFER, depth_rb);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, options.width, options.height);
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_rb);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_rb);
  GLenum fb = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  if (fb != GL_FRAMEBUFFER_COMPLETE) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "0x%04X", unsigned(fb));
    return fail(std::string("framebuffer incomplete (") + buf + ")");
  }

  // Links the vertex shader with a fragment shader into `out`.
  auto link = [&](const char* fragment, GLuint& out) -> Status {
    auto vs = compile(GL_VERTEX_SHADER, kRenderVertexShader);
    if (!vs) return vs.status();
    auto fs = compile(GL_FRAGMENT_SHADER, fragment);
    if (!fs) {
      glDeleteShader(*vs);
      return fs.status();
    }
    out = glCreateProgram();
    glAttachShader(out, *vs);
    glAttachShader(out, *fs);
    glLinkProgram(out);
    glDeleteShader(*vs);
    glDeleteShader(*fs);
    GLint linked = 0;
    glGetProgramiv(out, GL_LINK_STATUS, &linked);
    if (!linked) {
      char log[2048] = {0};
      glGetProgramInfoLog(out, sizeof log, nullptr, log);
      return fail(std::string("program link failed: ") + log);
    }
    return Status::ok();
  };
  if (Status s = link(kRenderFragmentShader, program); !s) return s;
  if (Status s = link(kRenderDepthFragmentShader, depth_program); !s) return s;
  d_mvp = glGetUniformLocation(depth_program, "u_mvp");
  u_mvp = glGetUniformLocation(program, "u_mvp");
  u_normal = glGetUniformLocation(program, "u_normal");
  u_texture = glGetUniformLocation(program, "u_texture");
  u_texture_plain = glGetUniformLocation(program, "u_texture_plain");
  u_texture_size = glGetUniformLocation(program, "u_texture_size");
  u_textured = glGetUniformLocation(program, "u_textured");
  u_factor = glGetUniformLocation(program, "u_factor");
  u_light = glGetUniformLocation(program, "u_light");
  u_ambient = glGetUniformLocation(program, "u_ambient");
  u_diffuse = glGetUniformLocation(program, "u_diffuse");
  u_model_view = glGetUniformLocation(program, "u_model_view");
  u_normal_view = glGetUniformLocation(program, "u_normal_view");
  u_physical = glGetUniformLocation(program, "u_physical");
  u_normal_map = glGetUniformLocation(program, "u_normal_map");
  u_orm_map = glGetUniformLocation(program, "u_orm_map");
  u_emissive_map = glGetUniformLocation(program, "u_emissive_map");
  u_dfg = glGetUniformLocation(program, "u_dfg");
  u_has_normal_map = glGetUniformLocation(program, "u_has_normal_map");
  u_has_orm_map = glGetUniformLocation(program, "u_has_orm_map");
  u_has_emissive_map = glGetUniformLocation(program, "u_has_emissive_map");
  u_metallic = glGetUniformLocation(program, "u_metallic");
  u_roughness = glGetUniformLocation(program, "u_roughness");
  u_occlusion_strength = glGetUniformLocation(program, "u_occlusion_strength");
  u_normal_scale = glGetUniformLocation(program, "u_normal_scale");
  u_emissive = glGetUniformLocation(program, "u_emissive");
  u_environment = glGetUniformLocation(program, "u_environment");
  u_light_intensity = glGetUniformLocation(program, "u_light_intensity");
  u_display_scale = glGetUniformLocation(program, "u_display_scale");
  u_sheen_map = glGetUniformLocation(program, "u_sheen_map");
  u_has_sheen_map = glGetUniformLocation(program, "u_has_sheen_map");
  u_sheen = glGetUniformLocation(program, "u_sheen");
  u_sheen_roughness = glGetUniformLocation(program, "u_sheen_roughness");

  // Sampling state lives in sampler objects (they override the textures' own parameters), one
  // per filtering and wrap pair; bind_unit binds the one its texture asks for.
  for (int a = 0; a < 2; ++a)
    for (int ws = 0; ws < 3; ++ws)
      for (int wt = 0; wt < 3; ++wt) {
        GLuint& smp = samplers[a][ws][wt];
        glGenSamplers(1, &smp);
        glSamplerParameteri(smp, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
        glSamplerParameteri(smp, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glSamplerParameteri(smp, GL_TEXTURE_WRAP_S, GLint(kWraps[ws]));
        glSamplerParameteri(smp, GL_TEXTURE_WRAP_T, GLint(kWraps[wt]));
        if (a == 1)
          glSamplerParameterf(smp, GL_TEXTURE_MAX_ANISOTROPY,
                              std::clamp(options.anisotropy, 1.0f, max_anisotropy));
        glGetError();  // tolerate a driver without anisotropic filtering
      }
  for (GLuint unit : {0u, 1u, 2u, 3u, 4u, 6u})
    glBindSampler(unit, samplers[unit != 1 && anisotropic()][0][0]);
  // The DFG table: 16×16 RG floats, bilinear, clamped (as three.js samples its own).
  glGenSamplers(1, &sampler_table);
  glSamplerParameteri(sampler_table, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glSamplerParameteri(sampler_table, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glSamplerParameteri(sampler_table, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glSamplerParameteri(sampler_table, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glBindSampler(5, sampler_table);
  if (options.shading == Shading::kPhysical) {
    const std::vector<float> table = dfg_lut();
    glGenTextures(1, &dfg_texture);
    glActiveTexture(GL_TEXTURE5);
    glBindTexture(GL_TEXTURE_2D, dfg_texture);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RG32F, kDfgLutSize, kDfgLutSize, 0, GL_RG, GL_FLOAT,
                 table.data());
    glActiveTexture(GL_TEXTURE0);
  }

  // Fixed state: depth test, no culling, no blending, no dithering, no sRGB conversion.
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  glDisable(GL_DITHER);
  glDisable(GL_MULTISAMPLE);
  glDisable(GL_FRAMEBUFFER_SRGB);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  GLenum err = glGetError();
  if (err != GL_NO_ERROR) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "0x%04X", unsigned(err));
    return fail(std::string("setup failed (error ") + buf + ")");
  }
  return Status::ok();
}

Renderer::Renderer() : impl_(new Impl) {}

namespace {

// Mesa's llvmpipe does not survive running out of memory: under a tight RLIMIT_DATA (meshmux
// --max-memory) it was seen to crash (SIGSEGV), abort ("LLVM ERROR: out of memory") or hang
// in a thread that never started. So the renderer starts only when the limit leaves it room:
// its JIT, framebuffers and bins (~128 MB measured with margin) and one 8 MB stack per
// rasterizer thread (LP_NUM_THREADS, else one per core, at most 16; thread stacks count as
// data). Returns "" when there is room, else the reason.
std::string memory_headroom_problem() {
  rlimit rl{};
  if (getrlimit(RLIMIT_DATA, &rl) != 0 || rl.rlim_cur == RLIM_INFINITY) return "";
  uint64_t used_kb = 0;
  if (FILE* f = std::fopen("/proc/self/status", "r")) {
    char line[256];
    while (std::fgets(line, sizeof line, f))
      if (std::strncmp(line, "VmData:", 7) == 0) used_kb = std::strtoull(line + 7, nullptr, 10);
    std::fclose(f);
  }
  long threads = sysconf(_SC_NPROCESSORS_ONLN);
  if (const char* e = std::getenv("LP_NUM_THREADS")) threads = std::atol(e);
  threads = std::clamp(threads, 0L, 16L);
  const uint64_t need_mb = 128 + 8 * uint64_t(threads);
  const uint64_t limit_mb = uint64_t(rl.rlim_cur) >> 20, used_mb = used_kb >> 10;
  const uint64_t left_mb = limit_mb > used_mb ? limit_mb - used_mb : 0;
  if (left_mb >= need_mb) return "";
  return "the memory limit of " + std::to_string(limit_mb) + " MB leaves " +
         std::to_string(left_mb) + " MB for the offscreen renderer, which needs about " +
         std::to_string(need_mb) + " MB (--max-memory raises the limit)";
}

}  // namespace

Result<std::unique_ptr<Renderer>> Renderer::create(const RenderOptions& options) {
  if (std::string why = memory_headroom_problem(); !why.empty())
    return Status::error("render: " + why, ErrorKind::kInput);
  std::unique_ptr<Renderer> r(new Renderer());
  r->impl_->options = options;
  Status s = r->impl_->init_egl();
  if (s) s = r->impl_->init_gl();
  if (!s) return s;  // ~Renderer releases whatever was created
  return r;
}

Renderer::~Renderer() {
  Impl& m = *impl_;
  if (m.display == EGL_NO_DISPLAY) return;
  if (m.context != EGL_NO_CONTEXT) {
    m.make_current();
    for (size_t g = 0; g < m.geometries.size(); ++g) remove_geometry(int(g));
    for (size_t t = 0; t < m.textures.size(); ++t) remove_texture(int(t));
    if (m.program) glDeleteProgram(m.program);
    if (m.depth_program) glDeleteProgram(m.depth_program);
    for (auto& by_s : m.samplers)
      for (auto& by_t : by_s)
        for (GLuint& smp : by_t)
          if (smp) glDeleteSamplers(1, &smp);
    if (m.sampler_table) glDeleteSamplers(1, &m.sampler_table);
    if (m.dfg_texture) glDeleteTextures(1, &m.dfg_texture);
    if (m.fbo) glDeleteFramebuffers(1, &m.fbo);
    if (m.color_rb) glDeleteRenderbuffers(1, &m.color_rb);
    if (m.depth_rb) glDeleteRenderbuffers(1, &m.depth_rb);
    eglMakeCurrent(m.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(m.display, m.context);
  }
  // The display stays initialized for the life of the process: eglTerminate would unload the
  // Mesa driver, whose few process-lifetime allocations then show as leaks (LeakSanitizer),
  // and the next Renderer would pay the driver start-up again.
  std::lock_guard<std::mutex> lock(display_mutex());
  auto it = display_uses().find(m.display);
  if (it != display_uses().end()) --it->second;
}

const RenderOptions& Renderer::options() const { return impl_->options; }

int Renderer::add_geometry(const Scene& scene, bool with_textures, int32_t streamed_material) {
  Impl& m = *impl_;
  m.make_current();
  // Each material's decoded images, uploaded once per use (as colour or as data, with the
  // sampler's wraps).
  std::map<std::tuple<int32_t, bool, Wrap, Wrap>, int> uploaded;
  auto upload = [&](const TextureRef& ref, bool color) {
    const int32_t i = ref.image;
    if (!with_textures || i < 0 || size_t(i) >= scene.images.size()) return -1;
    const Sampler& smp = ref.sampler;
    auto [at, added] = uploaded.try_emplace({i, color, smp.wrap_s, smp.wrap_t}, -1);
    if (added) at->second = add_texture(scene.images[size_t(i)], color, smp.wrap_s, smp.wrap_t);
    return at->second;
  };
  m.make_current();
  GpuGeometry geo;
  geo.live = true;
  geo.meshes.resize(scene.meshes.size());
  std::vector<Vertex> vertices;
  std::vector<uint32_t> indices;
  for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    for (const Primitive& p : scene.meshes[mi].primitives) {
      size_t n = p.positions.size();
      if (n == 0) continue;
      bool has_normals = p.normals.size() == n;
      const Material* material = p.material >= 0 && size_t(p.material) < scene.materials.size()
                                     ? &scene.materials[size_t(p.material)]
                                     : nullptr;
      TextureSet own;
      size_t uv_set = 0;  // the set the primitive's own texture reads (set 0 without one)
      auto image_of = [](const Material* mat) {
        return mat && mat->base_color.present() ? mat->base_color.image : -1;
      };
      const bool keeps_own =
          material && streamed_material >= 0 &&
          size_t(streamed_material) < scene.materials.size() &&
          image_of(material) != image_of(&scene.materials[size_t(streamed_material)]);
      if (keeps_own && material->base_color.present() &&
          material->base_color.tex_coord < p.uvs.size())
        uv_set = material->base_color.tex_coord;
      if (with_textures && material) {
        own.base_color = upload(material->base_color, true);
        own.normal = upload(material->normal, false);
        own.orm = upload(material->metallic_roughness, false);
        own.emissive = upload(material->emissive, true);
        own.sheen = upload(material->sheen_color, true);
        if (material->base_color.present() && material->base_color.tex_coord < p.uvs.size())
          uv_set = material->base_color.tex_coord;
      }
      bool has_uvs = uv_set < p.uvs.size() && p.uvs[uv_set].size() == n;
      vertices.resize(n);
      for (size_t i = 0; i < n; ++i) {
        Vertex& v = vertices[i];
        Vec3 pos = p.positions[i];
        // A flat primitive is drawn with face normals (zero here: the shader derives them).
        Vec3 nor = p.flat ? Vec3{0, 0, 0} : has_normals ? p.normals[i] : Vec3{0, 0, 1};
        Vec2 uv = has_uvs ? p.uvs[uv_set][i] : Vec2{0, 0};
        v = Vertex{{pos.x, pos.y, pos.z}, {nor.x, nor.y, nor.z}, {uv.x, uv.y}};
      }
      // Whole triangles with in-range indices only (out-of-range indices would make the
      // driver read outside the buffer); no indices at all means a plain triangle list.
      indices.clear();
      if (p.indices.empty()) {
        for (uint32_t i = 0; i + 2 < n; i += 3) indices.insert(indices.end(), {i, i + 1, i + 2});
      } else {
        for (size_t i = 0; i + 2 < p.indices.size(); i += 3) {
          uint32_t a = p.indices[i], b = p.indices[i + 1], c = p.indices[i + 2];
          if (a < n && b < n && c < n) indices.insert(indices.end(), {a, b, c});
        }
      }
      if (indices.empty()) continue;
      // Triangles in vertex-cache order (meshoptimizer's FIFO variant, 16 entries): llvmpipe
      // shades vertices through a small cache, and the progressive record's face order (by
      // collapse) missed it so often that a 1M-triangle level drew 5x slower per triangle than
      // the level below it. Only ties between coplanar overlapping faces depend on the order.
      meshopt_optimizeVertexCacheFifo(indices.data(), indices.data(), indices.size(), n, 16);
      GpuPrimitive gp;
      gp.index_count = GLsizei(indices.size());
      if (material) {
        gp.factor = material->base_color_factor;
        gp.metallic = material->metallic_factor;
        gp.roughness = material->roughness_factor;
        gp.emissive = material->emissive_factor;
        gp.sheen = material->sheen_color_factor;
        gp.sheen_roughness = material->sheen_roughness_factor;
        gp.normal_scale = std::isfinite(material->normal.scale) ? material->normal.scale : 1.0f;
        // glTF packs occlusion into the metallic-roughness image's R when both name it.
        gp.occlusion_strength = material->occlusion.image == material->metallic_roughness.image &&
                                        material->occlusion.present()
                                    ? material->occlusion.scale
                                    : 0.0f;
      }
      gp.textures = own;
      gp.keeps_own = keeps_own;
      if (keeps_own) {
        const TextureRef* refs[5] = {&material->base_color, &material->normal,
                                     &material->metallic_roughness, &material->emissive,
                                     &material->sheen_color};
        for (size_t k = 0; k < 5; ++k) gp.images[k] = refs[k]->present() ? refs[k]->image : -1;
      }
      glGenVertexArrays(1, &gp.vao);
      glBindVertexArray(gp.vao);
      glGenBuffers(1, &gp.vbo);
      glBindBuffer(GL_ARRAY_BUFFER, gp.vbo);
      glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(n * sizeof(Vertex)), vertices.data(),
                   GL_STATIC_DRAW);
      glGenBuffers(1, &gp.ibo);
      glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, gp.ibo);
      glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(indices.size() * sizeof(uint32_t)),
                   indices.data(), GL_STATIC_DRAW);
      glEnableVertexAttribArray(0);
      glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex),
                            reinterpret_cast<void*>(offsetof(Vertex, position)));
      glEnableVertexAttribArray(1);
      glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex),
                            reinterpret_cast<void*>(offsetof(Vertex, normal)));
      glEnableVertexAttribArray(2);
      glVertexAttribPointer(2, 2, GL_FLOAT, GL_FALSE, sizeof(Vertex),
                            reinterpret_cast<void*>(offsetof(Vertex, uv)));
      glBindVertexArray(0);
      geo.meshes[mi].push_back(gp);
    }
  }
  for (const Instance& inst : scene.instances)
    if (inst.mesh < scene.meshes.size()) geo.instances.push_back({inst.mesh, inst.world});
  m.geometries.push_back(std::move(geo));
  return int(m.geometries.size() - 1);
}

int Renderer::add_texture(const Image& image, bool color, Wrap wrap_s, Wrap wrap_t) {
  Impl& m = *impl_;
  if (!image.decoded() || image.rgba.size() < size_t(image.width) * image.height * 4) return -1;
  m.make_current();
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  if (image.width > max_size || image.height > max_size) return -1;
  // Mip levels finer than kUploadPerPixel texels per view pixel are never sampled at these
  // image sizes (even 16× anisotropic filtering picks a coarser level unless a surface is
  // almost edge-on), so they are not uploaded: a 4096² atlas's four channels would otherwise
  // hold 350 MB of driver memory for renders of 256² pixels.
  const int most = int(std::ceil(double(kUploadPerPixel) * std::max(1.0f, m.options.display_scale) *
                                 double(std::max(m.options.width, m.options.height))));
  std::optional<Image> reduced;
  while ((reduced ? *reduced : image).width > most || (reduced ? *reduced : image).height > most)
    reduced = downsample_half(reduced ? *reduced : image,
                              color ? TexelFilter::kSrgb : TexelFilter::kData);
  const Image& up = reduced ? *reduced : image;
  GLuint tex = 0;
  glGenTextures(1, &tex);
  glBindTexture(GL_TEXTURE_2D, tex);
  // Top row first: GL's t = 0 is the image's top row, i.e. glTF's v = 0.
  // Physical shading decodes colour textures (mip levels then average in linear light, as
  // WebGL's SRGB8_ALPHA8 textures do); Lambert shading uses every texel as stored.
  const bool decode = color && m.options.shading == Shading::kPhysical;
  glTexImage2D(GL_TEXTURE_2D, 0, decode ? GL_SRGB8_ALPHA8 : GL_RGBA8, up.width, up.height, 0,
               GL_RGBA, GL_UNSIGNED_BYTE, up.rgba.data());
  glGenerateMipmap(GL_TEXTURE_2D);
  // Filtering and wrapping come from the sampler objects made in init_gl().
  glBindTexture(GL_TEXTURE_2D, 0);
  m.textures.push_back({tex, image.width, image.height, wrap_s, wrap_t});
  return int(m.textures.size() - 1);
}

void Renderer::remove_geometry(int handle) {
  Impl& m = *impl_;
  if (handle < 0 || size_t(handle) >= m.geometries.size() || !m.geometries[handle].live) return;
  m.make_current();
  GpuGeometry& geo = m.geometries[handle];
  for (auto& prims : geo.meshes)
    for (GpuPrimitive& p : prims) {
      glDeleteVertexArrays(1, &p.vao);
      glDeleteBuffers(1, &p.vbo);
      glDeleteBuffers(1, &p.ibo);
    }
  geo = GpuGeometry{};  // handles are not reused: a stale handle draws nothing
}

void Renderer::remove_texture(int handle) {
  Impl& m = *impl_;
  if (handle < 0 || size_t(handle) >= m.textures.size() || m.textures[handle].id == 0) return;
  m.make_current();
  glDeleteTextures(1, &m.textures[handle].id);
  m.textures[handle] = {};
}

RenderImage Renderer::render(int g, int t, const Camera& camera) {
  TextureSet set;
  set.base_color = t;
  return render(g, set, camera);
}

RenderImage Renderer::render(int g, const TextureSet& t, const Camera& camera) {
  std::vector<RenderImage> images =
      render(g, std::vector<TextureSet>{t}, std::vector<Camera>{camera});
  return std::move(images.front());
}

namespace {

bool empty_set(const TextureSet& t) {
  return t.base_color < 0 && t.normal < 0 && t.orm < 0 && t.emissive < 0 && t.sheen < 0;
}

// The camera's view, projection and light.
CameraFrame camera_frame(const Camera& camera, const RenderOptions& o, int w, int h) {
  DVec3 axes[3];
  Mat4 view = look_at(camera, axes);
  Mat4 view_proj =
      perspective(camera.fov_y_degrees, double(w) / h, camera.near_plane, camera.far_plane) * view;
  DVec3 l = normalize(to_dvec3(o.light_direction));
  DVec3 l_view = l;              // physical shading works in view space
  if (o.light_follows_camera) {  // camera space → world: inverse (= transposed) view rotation
    l = normalize(DVec3{axes[0].x * l.x + axes[1].x * l.y + axes[2].x * l.z,
                        axes[0].y * l.x + axes[1].y * l.y + axes[2].y * l.z,
                        axes[0].z * l.x + axes[1].z * l.y + axes[2].z * l.z});
  } else {
    l_view = normalize(DVec3{dot(axes[0], l), dot(axes[1], l), dot(axes[2], l)});
  }
  return {view, view_proj, l, l_view};
}

// An instance's model-view-projection matrix, as floats.
void mvp_of(const CameraFrame& frame, const GpuInstance& inst, float out[16]) {
  Mat4 mvp = frame.view_proj * inst.world;
  for (int i = 0; i < 16; ++i) out[i] = float(mvp.m[i]);
}

// Normal matrices: cofactors of the 3x3 part (= det × inverse transpose), sign-corrected so
// mirrored transforms keep outward normals; the shader renormalizes.
void normal_matrix(const Mat4& a, float nm[9]) {
  const double sign = a.det3() < 0 ? -1 : 1;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
      double cof = a.at(r1, c1) * a.at(r2, c2) - a.at(r1, c2) * a.at(r2, c1);
      nm[c * 3 + r] = float(sign * cof);  // column-major mat3
    }
}

// Readback: glReadPixels (bottom row first), flipped so row 0 is the top.
void read_back(int w, int h, RenderImage& img) {
  img.width = w;
  img.height = h;
  img.rgba.resize(size_t(w) * h * 4);
  std::vector<uint8_t> raw(img.rgba.size());
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, raw.data());
  const size_t row = size_t(w) * 4;
  for (int y = 0; y < h; ++y)  // GL's row 0 is the bottom
    std::memcpy(&img.rgba[size_t(y) * row], &raw[size_t(h - 1 - y) * row], row);
  img.coverage.resize(size_t(w) * h);
  for (size_t i = 0; i < img.coverage.size(); ++i) img.coverage[i] = img.rgba[i * 4 + 3] > 0;
}

}  // namespace

bool Renderer::Impl::live(int k) const {
  return k >= 0 && size_t(k) < textures.size() && textures[k].id;
}

// The depth pre-pass: depth alone, after which every set's shading pass keeps the fragments of
// equal depth (no depth writes).
void Renderer::Impl::draw_depth(const GpuGeometry& geo, const CameraFrame& frame) {
  glUseProgram(depth_program);
  glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
  for (const GpuInstance& inst : geo.instances) {
    float mvp_f[16];
    mvp_of(frame, inst, mvp_f);
    glUniformMatrix4fv(d_mvp, 1, GL_FALSE, mvp_f);
    for (const GpuPrimitive& p : geo.meshes[inst.mesh]) {
      glBindVertexArray(p.vao);
      glDrawElements(GL_TRIANGLES, p.index_count, GL_UNSIGNED_INT, nullptr);
    }
  }
  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  glDepthMask(GL_FALSE);
  glDepthFunc(GL_EQUAL);
}

// One shading pass: every instance's primitives with the set `t`, or with each primitive's own
// textures where `t` is empty.
void Renderer::Impl::draw_shaded(const GpuGeometry& geo, const CameraFrame& frame,
                                 const TextureSet& t) {
  const bool explicit_set = !empty_set(t);  // an explicit set overrides the materials' own
  use_shading_program(frame);
  TextureSet bound{-2, -2, -2, -2, -2};  // the set bound so far (bind_set: once per change)
  for (const GpuInstance& inst : geo.instances) {
    const auto& prims = geo.meshes[inst.mesh];
    if (prims.empty()) continue;
    set_instance(frame, inst);
    for (const GpuPrimitive& p : prims) {
      const bool use_set = explicit_set && !p.keeps_own;
      set_primitive(p, use_set);
      bind_set(use_set ? t : p.keeps_own && explicit_set ? kept_set(p, t) : p.textures, bound);
      glBindVertexArray(p.vao);
      glDrawElements(GL_TRIANGLES, p.index_count, GL_UNSIGNED_INT, nullptr);
    }
  }
}

// The set a primitive keeping its own images draws with: each slot's image through `t.kept`.
TextureSet Renderer::Impl::kept_set(const GpuPrimitive& p, const TextureSet& t) {
  auto handle = [&](int32_t image) {
    auto it = std::lower_bound(t.kept.begin(), t.kept.end(), std::make_pair(image, INT_MIN));
    return image >= 0 && it != t.kept.end() && it->first == image ? it->second : -1;
  };
  TextureSet s;
  s.base_color = handle(p.images[0]);
  s.normal = handle(p.images[1]);
  s.orm = handle(p.images[2]);
  s.emissive = handle(p.images[3]);
  s.sheen = handle(p.images[4]);
  return s;
}

// The shading program with the pass's uniforms: the light and the texture units.
void Renderer::Impl::use_shading_program(const CameraFrame& frame) {
  const bool physical = options.shading == Shading::kPhysical;
  const DVec3& l = physical ? frame.light_view : frame.light;
  glUseProgram(program);
  glUniform1i(u_physical, physical ? 1 : 0);
  glUniform3f(u_light, float(l.x), float(l.y), float(l.z));
  glUniform1f(u_ambient, options.ambient);
  glUniform1f(u_diffuse, options.diffuse);
  glUniform1f(u_environment, options.environment);
  glUniform1f(u_light_intensity, options.light_intensity);
  glUniform1f(u_display_scale, std::max(1e-3f, options.display_scale));
  glUniform1i(u_texture, 0);
  glUniform1i(u_texture_plain, 1);
  glUniform1i(u_normal_map, 2);
  glUniform1i(u_orm_map, 3);
  glUniform1i(u_emissive_map, 4);
  glUniform1i(u_dfg, 5);
  glUniform1i(u_sheen_map, 6);
}

// An instance's matrices and winding.
void Renderer::Impl::set_instance(const CameraFrame& frame, const GpuInstance& inst) {
  Mat4 model_view = frame.view * inst.world;
  float mvp_f[16], mv_f[16];
  mvp_of(frame, inst, mvp_f);
  for (int i = 0; i < 16; ++i) mv_f[i] = float(model_view.m[i]);
  float nm[9], nv[9];
  normal_matrix(inst.world, nm);
  normal_matrix(model_view, nv);
  glUniformMatrix4fv(u_mvp, 1, GL_FALSE, mvp_f);
  glUniformMatrix4fv(u_model_view, 1, GL_FALSE, mv_f);
  glUniformMatrix3fv(u_normal, 1, GL_FALSE, nm);
  glUniformMatrix3fv(u_normal_view, 1, GL_FALSE, nv);
  // Mirroring transforms reverse the screen-space winding of front faces.
  glFrontFace(inst.world.det3() < 0 ? GL_CW : GL_CCW);
}

// A primitive's material factors (an explicit set's occlusion at full strength).
void Renderer::Impl::set_primitive(const GpuPrimitive& p, bool explicit_set) {
  glUniform4f(u_factor, p.factor.x, p.factor.y, p.factor.z, p.factor.w);
  glUniform1f(u_metallic, p.metallic);
  glUniform1f(u_roughness, p.roughness);
  glUniform1f(u_occlusion_strength, explicit_set ? 1.0f : p.occlusion_strength);
  glUniform1f(u_normal_scale, p.normal_scale);
  glUniform3f(u_emissive, p.emissive.x, p.emissive.y, p.emissive.z);
  glUniform3f(u_sheen, p.sheen.x, p.sheen.y, p.sheen.z);
  glUniform1f(u_sheen_roughness, p.sheen_roughness);
}

// Binds a texture set where it differs from `bound` (then `bound` is the set) and says which
// maps are there.
void Renderer::Impl::bind_set(const TextureSet& set, TextureSet& bound) {
  if (set.base_color != bound.base_color) {
    const int k = set.base_color;
    glUniform1i(u_textured, live(k) ? 1 : 0);
    glUniform2f(u_texture_size, live(k) ? float(textures[size_t(k)].width) : 1.0f,
                live(k) ? float(textures[size_t(k)].height) : 1.0f);
    bind_unit(GL_TEXTURE0, k);
    bind_unit(GL_TEXTURE1, k);
  }
  bind_map(set.normal, bound.normal, u_has_normal_map, GL_TEXTURE2);
  bind_map(set.orm, bound.orm, u_has_orm_map, GL_TEXTURE3);
  bind_map(set.emissive, bound.emissive, u_has_emissive_map, GL_TEXTURE4);
  bind_map(set.sheen, bound.sheen, u_has_sheen_map, GL_TEXTURE6);
  glActiveTexture(GL_TEXTURE5);
  glBindTexture(GL_TEXTURE_2D, dfg_texture);
  glActiveTexture(GL_TEXTURE0);
  bound = set;
}

// A further map: its unit, and the flag saying the shader has it (physical shading).
void Renderer::Impl::bind_map(int want, int have, GLint flag, GLenum unit) {
  if (want == have) return;
  glUniform1i(flag, options.shading == Shading::kPhysical && live(want) ? 1 : 0);
  bind_unit(unit, want);
}

void Renderer::Impl::bind_unit(GLenum unit, int k) {
  glActiveTexture(unit);
  glBindTexture(GL_TEXTURE_2D, live(k) ? textures[size_t(k)].id : 0);
  const GLuint index = unit - GL_TEXTURE0;
  const int ws = live(k) ? wrap_index(textures[size_t(k)].wrap_s) : 0;
  const int wt = live(k) ? wrap_index(textures[size_t(k)].wrap_t) : 0;
  // Unit 1: the plain base colour; every unit plain where a display scale biases the level.
  glBindSampler(index, samplers[index != 1 && anisotropic()][ws][wt]);
}

std::vector<RenderImage> Renderer::render(int g, const std::vector<TextureSet>& sets,
                                          const std::vector<Camera>& cameras) {
  Impl& m = *impl_;
  const RenderOptions& o = m.options;
  const size_t count = sets.size() * cameras.size();
  std::vector<RenderImage> images(count);
  if (count == 0) return images;
  m.make_current();
  const int w = o.width, h = o.height;
  glViewport(0, 0, w, h);
  glDepthMask(GL_TRUE);
  glDepthFunc(GL_LESS);
  glClearColor(0, 0, 0, 0);
  glClearDepth(1.0);

  bool geometry_ok = g >= 0 && size_t(g) < m.geometries.size() && m.geometries[g].live;
  // The pre-pass pays where several texture sets share it (one pass instead of a geometry pass
  // per set); for one set, drawing the geometry twice costs more than the overdraw it saves
  // (measured: a palette-textured 110k-triangle engine 12% and a 1.7M-triangle forest 60%
  // slower with it).
  const bool prepass = o.depth_prepass && geometry_ok && sets.size() > 1;
  glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  for (size_t c = 0; c < cameras.size(); ++c) {
    const CameraFrame frame = camera_frame(cameras[c], o, w, h);
    const size_t base = c * sets.size();
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    if (prepass) m.draw_depth(m.geometries[g], frame);
    // One shading pass per set, each read back before the next clears the colour.
    for (size_t k = 0; k < sets.size(); ++k) {
      if (k > 0) glClear(prepass ? GL_COLOR_BUFFER_BIT : GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
      if (geometry_ok) m.draw_shaded(m.geometries[g], frame, sets[k]);
      read_back(w, h, images[base + k]);
    }
    glBindVertexArray(0);
    glFrontFace(GL_CCW);
    glDepthMask(GL_TRUE);
    glDepthFunc(GL_LESS);
  }

  return images;
}

}  // namespace meshmux
