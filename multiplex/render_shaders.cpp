// Shaders of the offscreen renderer (see render_shaders.h).
//
// Physically based shading: the glTF 2.0 metal-roughness model (glTF 2.0 spec, Appendix B) as
// three.js r187's MeshStandardMaterial evaluates it, re-derived from its references rather than
// copied:
// - direct light: GGX distribution (Walter et al. 2007), height-correlated Smith visibility
//   (Heitz 2014; Lagarde and de Rousiers 2014, listing 2), Schlick's Fresnel in Epic's
//   spherical-Gaussian form (Karis 2013), the specular lobe scaled for multiple scattering by
//   1 + F0 (1/E_ss − 1) (Turquin 2019, eq. 16) and the Lambertian diffuse weighted by 1 − F of a
//   0.04 dielectric (glTF's fresnel_mix);
// - environment: a uniform radiance L, whose prefiltered radiance is L at every roughness and
//   whose irradiance is π L, with Fdez-Agüera's multiple-scattering split sum (JCGT 8(1) 2019)
//   evaluated on the DFG table (multiplex/dfg_lut.h) separately for the dielectric and the metal
//   and mixed by metalness; diffuse reduced by the dielectric's scattering;
// - ambient occlusion on the environment's diffuse light, and on its specular through
//   Lagarde's specular occlusion; emissive added; roughness floored at 0.045 and raised by the
//   screen-space variation of the geometric normal (Kaplanyan 2016's specular anti-aliasing,
//   in three.js's form);
// - normal maps in the tangent frame of the uv derivatives (atlas/tangent_frame.h), the map's y
//   negated as glTF's +y points up the image; two-sided: back faces flip the normal and frame;
// - colour: base colour and emissive textures are sRGB-decoded by the GL (SRGB8_ALPHA8), the
//   result is sRGB-encoded (IEC 61966-2-1) with no tone mapping, as three.js outputs it.
#include "multiplex/render_shaders.h"

namespace meshmux {

const char* const kRenderVertexShader = R"(#version 450 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_uv;
uniform mat4 u_mvp;          // projection * view * model
uniform mat3 u_normal;       // model's inverse transpose (world-space normals)
uniform mat4 u_model_view;   // view * model
uniform mat3 u_normal_view;  // (view * model)'s inverse transpose (view-space normals)
out vec3 v_normal;       // world space (Lambert)
out vec3 v_view_normal;  // view space (physical)
out vec3 v_view_position;
out vec2 v_uv;
invariant gl_Position;  // the depth pre-pass (kRenderDepthFragmentShader) must match bit for bit
void main() {
  gl_Position = u_mvp * vec4(a_position, 1.0);
  v_normal = u_normal * a_normal;
  v_view_normal = u_normal_view * a_normal;
  v_view_position = (u_model_view * vec4(a_position, 1.0)).xyz;
  v_uv = a_uv;
}
)";

// The depth pre-pass: the same vertex shader, no colour (render.h RenderOptions::depth_prepass).
const char* const kRenderDepthFragmentShader = R"(#version 450 core
void main() {}
)";

const char* const kRenderFragmentShader = R"(#version 450 core
in vec3 v_normal;
in vec3 v_view_normal;
in vec3 v_view_position;
in vec2 v_uv;
uniform sampler2D u_texture;        // base colour, trilinear + anisotropic (minification)
uniform sampler2D u_texture_plain;  // the same texture, trilinear only (magnification)
uniform vec2 u_texture_size;
uniform bool u_textured;
uniform vec4 u_factor;
uniform vec3 u_light;   // unit, towards the light: world space (Lambert), view space (physical)
uniform float u_ambient;
uniform float u_diffuse;
uniform bool u_physical;
uniform sampler2D u_normal_map, u_orm_map, u_emissive_map, u_dfg;
uniform bool u_has_normal_map, u_has_orm_map, u_has_emissive_map;
uniform float u_metallic, u_roughness, u_occlusion_strength, u_normal_scale;
uniform vec3 u_emissive;
uniform float u_environment, u_light_intensity;
uniform sampler2D u_sheen_map;
uniform bool u_has_sheen_map;
uniform vec3 u_sheen;  // sheen colour factor (0: no sheen layer)
uniform float u_sheen_roughness;
uniform float u_display_scale;  // display pixels per image pixel (RenderOptions::display_scale)
out vec4 o_color;

const float PI = 3.141592653589793;

vec3 fresnel_schlick(vec3 f0, float f90, float vh) {
  float f = exp2((-5.55473 * vh - 6.98316) * vh);
  return f0 * (1.0 - f) + f90 * f;
}
float visibility_ggx(float alpha, float nl, float nv) {
  float a2 = alpha * alpha;
  float gv = nl * sqrt(a2 + (1.0 - a2) * nv * nv);
  float gl = nv * sqrt(a2 + (1.0 - a2) * nl * nl);
  return 0.5 / max(gv + gl, 1e-6);
}
float distribution_ggx(float alpha, float nh) {
  float a2 = alpha * alpha;
  float d = nh * nh * (a2 - 1.0) + 1.0;
  return a2 / (PI * d * d);
}
// Fdez-Agüera's single- and multiple-scattering split sum for Fresnel f0 (f90 = 1).
void scattering(vec2 dfg, vec3 f0, out vec3 single, out vec3 multi) {
  vec3 fss_ess = f0 * dfg.x + dfg.y;
  float ess = dfg.x + dfg.y;
  float ems = 1.0 - ess;
  vec3 favg = f0 + (1.0 - f0) * (1.0 / 21.0);
  vec3 fms = fss_ess * favg / (1.0 - ems * favg);
  single = fss_ess;
  multi = fms * ems;
}
// The sheen layer (KHR_materials_sheen): Estevez and Kulla's "Charlie" distribution, Neubelt
// and Pettineo's visibility, and Estevez and Kulla's fit of its directional albedo (the
// energy the layer takes from the layers below it and the image-based sheen term).
float sheen_distribution(float roughness, float nh) {
  float alpha = roughness * roughness, inv = 1.0 / alpha;
  float sin2h = max(1.0 - nh * nh, 0.0078125);
  return (2.0 + inv) * pow(sin2h, inv * 0.5) / (2.0 * PI);
}
float sheen_visibility(float nv, float nl) {
  return clamp(1.0 / (4.0 * (nl + nv - nl * nv)), 0.0, 1.0);
}
float sheen_albedo(float cos_theta, float roughness) {
  float r2 = roughness * roughness, inv = 1.0 / (roughness + 0.1);
  float a = -1.9362 + 1.0678 * roughness + 0.4573 * r2 - 0.8469 * inv;
  float b = -0.6014 + 0.5538 * roughness - 0.4670 * r2 - 0.1255 * inv;
  return clamp(exp(a * cos_theta + b), 0.0, 1.0);
}

vec3 srgb_encode(vec3 c) {
  return mix(pow(c, vec3(0.41666)) * 1.055 - vec3(0.055), c * 12.92,
             vec3(lessThanEqual(c, vec3(0.0031308))));
}

void main() {
  // llvmpipe's anisotropic filter blurs and perturbs magnified textures (GPUs filter those
  // bilinearly), so the anisotropic sampler is used only where the pixel footprint spans more
  // than one texel. Both samples are taken in uniform control flow (implicit derivatives).
  vec4 base = u_factor;
  // llvmpipe runs a branch's texture fetches even where its uniform condition is false (masked),
  // and its anisotropic filter's cost follows the footprint: the texture coordinates are zero
  // where no texture reads them. A simulator's untextured bowl, its uvs spanning −79..119 on
  // 10 cm, took 1.2 s per 256² image (150 µs a pixel) where the same geometry with uvs in
  // [0, 1] took 30 ms.
  const bool sampled = u_textured || u_has_normal_map || u_has_orm_map || u_has_emissive_map ||
                       u_has_sheen_map;
  const vec2 uv = sampled ? v_uv : vec2(0.0);
  // A display pixel's footprint in the textures is the image pixel's over the display scale:
  // the level of detail moves by −log2(scale) (a bias keeps the implicit derivatives, and with
  // them llvmpipe's fast path and its anisotropic filter, whose ratio a uniform scale leaves as
  // it is).
  const float bias = -log2(u_display_scale);
  if (u_textured) {
    vec2 t = uv * u_texture_size / u_display_scale;
    vec2 dx = dFdx(t), dy = dFdy(t);
    bool minified = max(dot(dx, dx), dot(dy, dy)) > 1.0;
    vec4 a = texture(u_texture, uv, bias), p = texture(u_texture_plain, uv, bias);
    base *= minified ? a : p;
  }
  float face = gl_FrontFacing ? 1.0 : -1.0;
  if (!u_physical) {
    // Texels are sRGB bytes used as stored (see render.cpp's top comment).
    float len = length(v_normal);
    vec3 n = len > 1e-20 ? v_normal / len : vec3(0.0, 0.0, 1.0);
    n *= face;  // two-sided lighting
    float lambert = max(dot(n, u_light), 0.0);
    o_color = vec4(base.rgb * (u_ambient + u_diffuse * lambert), 1.0);
    return;
  }
  // Derivatives first, in uniform control flow.
  vec3 q0 = dFdx(v_view_position), q1 = dFdy(v_view_position);
  vec2 st0 = dFdx(uv), st1 = dFdy(uv);
  // Each map at the texture coordinates only where it is present (zero where it is not).
  const vec2 z = vec2(0.0);
  vec4 normal_texel = texture(u_normal_map, u_has_normal_map ? uv : z, bias);
  vec4 orm_texel = texture(u_orm_map, u_has_orm_map ? uv : z, bias);
  vec4 emissive_texel = texture(u_emissive_map, u_has_emissive_map ? uv : z, bias);
  vec4 sheen_texel = texture(u_sheen_map, u_has_sheen_map ? uv : z, bias);
  // Zero vertex normals mark a flat-shaded primitive: three.js's FLAT_SHADED face normal.
  float len = length(v_view_normal);
  vec3 flat_normal = cross(q0, q1);
  float flat_len = length(flat_normal);
  vec3 n = len > 1e-20 ? v_view_normal / len * face
                       : (flat_len > 0.0 ? flat_normal / flat_len : vec3(0.0, 0.0, 1.0));
  vec3 dxy = max(abs(dFdx(n)), abs(dFdy(n)));
  float geometry_roughness = max(max(dxy.x, dxy.y), dxy.z);
  if (u_has_normal_map) {
    vec3 q1perp = cross(q1, n), q0perp = cross(n, q0);
    vec3 T = q1perp * st0.x + q0perp * st1.x;
    vec3 B = q1perp * st0.y + q0perp * st1.y;
    float det = max(dot(T, T), dot(B, B));
    float s = det == 0.0 ? 0.0 : inversesqrt(det);
    vec3 m = normal_texel.xyz * 2.0 - 1.0;
    m.xy *= vec2(u_normal_scale, -u_normal_scale);
    n = normalize(mat3(T * s * face, B * s * face, n) * m);
  }
  float metallic = u_metallic, roughness = u_roughness, occlusion = 1.0;
  if (u_has_orm_map) {
    roughness *= orm_texel.g;
    metallic *= orm_texel.b;
    occlusion = (orm_texel.r - 1.0) * u_occlusion_strength + 1.0;
  }
  roughness = min(max(roughness, 0.045) + geometry_roughness, 1.0);
  vec3 view = normalize(-v_view_position);
  vec3 diffuse = base.rgb * (1.0 - metallic);
  const vec3 f0_dielectric = vec3(0.04);
  vec3 f0 = mix(f0_dielectric, base.rgb, metallic);
  float nv = clamp(dot(n, view), 0.0, 1.0);
  vec2 dfg = texture(u_dfg, vec2(roughness, nv)).rg;

  // The directional light.
  vec3 l = u_light;
  float nl = clamp(dot(n, l), 0.0, 1.0);
  vec3 h = normalize(l + view);
  float nh = clamp(dot(n, h), 0.0, 1.0), vh = clamp(dot(view, h), 0.0, 1.0);
  float alpha = max(roughness, 0.045) * max(roughness, 0.045);
  vec3 irradiance = vec3(nl * u_light_intensity);
  vec3 compensation = 1.0 + f0 * (1.0 / (dfg.x + dfg.y) - 1.0);
  vec3 specular = irradiance * fresnel_schlick(f0, 1.0, vh) *
                  (visibility_ggx(alpha, nl, nv) * distribution_ggx(alpha, nh)) * compensation;
  vec3 lit = irradiance * diffuse / PI * (1.0 - fresnel_schlick(f0_dielectric, 1.0, vh));

  // The uniform environment.
  vec3 single_d, multi_d, single_m, multi_m;
  scattering(dfg, f0_dielectric, single_d, multi_d);
  scattering(dfg, base.rgb, single_m, multi_m);
  vec3 env = vec3(u_environment);
  vec3 env_specular = env * mix(single_d, single_m, metallic) + mix(multi_d, multi_m, metallic) * env;
  vec3 env_diffuse = diffuse * (1.0 - (single_d + multi_d)) * env;
  env_diffuse *= occlusion;
  env_specular *= clamp(pow(nv + occlusion, exp2(-16.0 * roughness - 1.0)) - 1.0 + occlusion, 0.0, 1.0);

  vec3 sheen = vec3(0.0);
  if (max(max(u_sheen.r, u_sheen.g), u_sheen.b) > 0.0) {
    vec3 sheen_color = u_sheen * (u_has_sheen_map ? sheen_texel.rgb : vec3(1.0));
    float sheen_roughness = clamp(u_sheen_roughness, 0.0001, 1.0);
    float strongest = max(max(sheen_color.r, sheen_color.g), sheen_color.b);
    float albedo_v = sheen_albedo(nv, sheen_roughness);
    // Direct: the layer's lobe, and less light for the layers below.
    sheen = irradiance * sheen_color * (sheen_distribution(sheen_roughness, nh) *
                                        sheen_visibility(nv, nl));
    float direct_left = 1.0 - strongest * max(albedo_v, sheen_albedo(nl, sheen_roughness));
    lit *= direct_left;
    specular *= direct_left;
    // Environment: π L irradiance through the albedo fit (÷ π), occluded like diffuse light.
    float env_left = 1.0 - strongest * albedo_v;
    env_specular *= env_left;
    env_diffuse *= env_left;
    sheen += env * sheen_color * albedo_v * occlusion;
  }
  vec3 emissive = u_emissive * (u_has_emissive_map ? emissive_texel.rgb : vec3(1.0));
  vec3 color = lit + specular + env_diffuse + env_specular + sheen + emissive;
  o_color = vec4(srgb_encode(max(color, vec3(0.0))), 1.0);
}
)";

}  // namespace meshmux
