// Atlas baking (see bake.h).
//
// Reference implemented: Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of
// 3D models for interactive metaverses" §4.4 (the atlas is filled by resampling the source textures
// at each chart's place, with gutters so that filtering and mip levels stay clean).
// Details as decided in docs/ARCHITECTURE.md "Atlas":
// - each chart face is rasterized in atlas texel space (texel (i, j) covers [i, i+1) × [j, j+1),
//   centre (i + ½, j + ½)); a texel belongs to the face when its centre is inside the triangle,
//   or, conservatively, within half a texel of it, so thin triangles still get texels. A texel
//   claimed by several faces keeps the nearest one (centre inside beats centre outside; the
//   first face in chart order wins ties); a chart smaller than a texel that reaches no texel
//   centre so takes the texel under its centre (its own cell's), so it is never left to the fill;
// - the colour of a texel is atlas/material_sample.h's base colour at the surface point whose
//   barycentrics are those of the point of the triangle nearest to the sample (all uv sets and
//   COLOR_0 interpolated), averaged over supersample² samples in linear light. Two passes: the
//   first decides which face owns each texel (centre distance), the second samples colours; with
//   supersampling each sample takes the nearest face among the owners of the texel and its
//   8 neighbours in the same chart, so a texel on an edge between faces reads both sides;
// - flat-colour charts fill their block with their colour;
// - gutters: `gutter` rings of dilation; a ring's empty texel next to filled ones joins the chart
//   most of those neighbours belong to (ties: the smaller chart index) and takes the average
//   colour of the neighbours of that chart only;
// - the rest of the atlas is filled by dilation to convergence (colour and alpha), so mip levels
//   never mix a chart with empty texels; opaque when no baked texel is translucent.
#include "atlas/bake.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "atlas/material_sample.h"
#include "atlas/tangent_frame.h"
#include "core/parallel.h"
#include "image/fill_empty.h"
#include "scene/dvec3.h"

namespace meshmux {
namespace {

struct P2 {
  double x = 0, y = 0;
};

double cross(P2 a, P2 b, P2 c) { return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x); }

// Closest point of segment ab to p: parameter t in [0, 1] and squared distance.
double closest_on_segment(P2 a, P2 b, P2 p, double* t) {
  double dx = b.x - a.x, dy = b.y - a.y;
  double len2 = dx * dx + dy * dy;
  double u = len2 > 0 ? ((p.x - a.x) * dx + (p.y - a.y) * dy) / len2 : 0;
  u = std::clamp(u, 0.0, 1.0);
  double qx = a.x + u * dx - p.x, qy = a.y + u * dy - p.y;
  *t = u;
  return qx * qx + qy * qy;
}

// Barycentrics (of corners 0, 1, 2) of the point of triangle v nearest to p, and the distance
// from p to it (0 when p is inside). Degenerate triangles are handled through their edges.
double nearest_barycentric(const P2 v[3], P2 p, double bary[3]) {
  double area = cross(v[0], v[1], v[2]);
  if (std::fabs(area) > 1e-12) {
    double b0 = cross(v[1], v[2], p) / area;
    double b1 = cross(v[2], v[0], p) / area;
    double b2 = 1 - b0 - b1;
    if (b0 >= 0 && b1 >= 0 && b2 >= 0) {
      bary[0] = b0;
      bary[1] = b1;
      bary[2] = b2;
      return 0;
    }
  }
  double best = std::numeric_limits<double>::infinity();
  for (int e = 0; e < 3; ++e) {
    int i = e, j = (e + 1) % 3;
    double t;
    double d2 = closest_on_segment(v[i], v[j], p, &t);
    if (d2 < best) {
      best = d2;
      bary[0] = bary[1] = bary[2] = 0;
      bary[i] = 1 - t;
      bary[j] = t;
    }
  }
  return std::sqrt(best);
}

Vec4 lerp3(const Vec4& a, const Vec4& b, const Vec4& c, const double w[3]) {
  return {float(a.x * w[0] + b.x * w[1] + c.x * w[2]), float(a.y * w[0] + b.y * w[1] + c.y * w[2]),
          float(a.z * w[0] + b.z * w[1] + c.z * w[2]), float(a.w * w[0] + b.w * w[1] + c.w * w[2])};
}

// A unit of coverage: one face of a textured chart, or a whole flat chart.
struct Job {
  uint32_t chart = 0;
  uint32_t k = 0;  // position of the face in chart.faces; kFlat for a flat chart
};
constexpr uint32_t kFlat = 0xffffffffu;

// Everything bake_atlas reads, with the per-face set-up.
class Source {
 public:
  Source(const Scene& scene, const ChartSet& charts, const std::vector<ChartUv>& uvs,
         const AtlasLayout& layout)
      : scene_(scene), charts_(charts), uvs_(uvs), layout_(layout) {}

  // Makes `job` (a textured chart's face) current; false when its data is out of range.
  bool select(const Job& job) {
    if (job.chart == current_.chart && job.k == current_.k) return true;
    current_ = Job{kFlat, kFlat};
    const Chart& chart = charts_.charts[job.chart];
    if (job.chart >= uvs_.size() || job.chart >= layout_.scale.size() ||
        chart.mesh >= scene_.meshes.size() || job.k >= chart.faces.size())
      return false;
    const Mesh& mesh = scene_.meshes[chart.mesh];
    if (faces_.size() < scene_.meshes.size()) {
      faces_.resize(scene_.meshes.size());
      numbered_.resize(scene_.meshes.size(), 0);
    }
    if (!numbered_[chart.mesh]) {
      faces_[chart.mesh] = mesh_faces(mesh);
      numbered_[chart.mesh] = 1;
    }
    const std::vector<FaceRef>& refs = faces_[chart.mesh];
    const uint32_t face = chart.faces[job.k];
    const ChartUv& cu = uvs_[job.chart];
    if (face >= refs.size() || 3 * size_t(job.k) + 2 >= cu.corner_uv.size()) return false;
    prim_ = &mesh.primitives[refs[face].primitive];
    const size_t base = size_t(refs[face].triangle) * 3;
    const Vec2 off = layout_.offset[job.chart];
    const double scale = layout_.scale[job.chart];
    for (int j = 0; j < 3; ++j) {
      idx_[j] = prim_->indices[base + size_t(j)];
      if (idx_[j] >= prim_->vertex_count()) return false;
      const Vec2& u = cu.corner_uv[3 * size_t(job.k) + size_t(j)];
      corner_[j] = {off.x + scale * u.x, off.y + scale * u.y};
    }
    // The source normal map's uvs (transformed, as the frame follows them).
    uint32_t set = 0;
    TextureTransform tt;
    normal_mapped_ = normal_map_uv(scene_, prim_->material, &set, &tt) && set < prim_->uvs.size() &&
                     prim_->uvs[set].size() >= prim_->vertex_count();
    if (normal_mapped_)
      for (int j = 0; j < 3; ++j) map_uv_[j] = apply_transform(tt, prim_->uvs[set][idx_[j]]);
    current_ = job;
    return true;
  }

  const P2* corners() const { return corner_; }

  // Base colour at the surface point of the current face nearest to atlas point p.
  Vec4 color_at(P2 p) {
    double w[3];
    nearest_barycentric(corner_, p, w);
    return color_at(w);
  }

  // Every channel `ch` asks for at the surface point of the current face nearest to atlas
  // point p (normal: the map value for the atlas's frame, atlas/tangent_frame.h).
  struct Texel {
    Vec4 color;
    Vec3 orm{1, 1, 1}, emissive{0, 0, 0}, sheen{0, 0, 0};
    DVec3 normal{0, 0, 1};
  };
  Texel sample(P2 p, const BakeChannels& ch) {
    double w[3];
    nearest_barycentric(corner_, p, w);
    Texel t;
    t.color = color_at(w);  // fills uv_
    if (ch.orm) t.orm = sample_occlusion_roughness_metallic(scene_, prim_->material, uv_);
    if (ch.emissive) t.emissive = sample_emissive(scene_, prim_->material, uv_);
    if (ch.sheen) t.sheen = sample_sheen_color(scene_, prim_->material, uv_);
    if (ch.normal) t.normal = normal_at(w);
    return t;
  }

 private:
  // The shading normal the source shows (its interpolated normal, or the face's, perturbed by
  // its normal map in the frame three.js derives from the source uvs), as a map value in the
  // frame it derives from the atlas uvs.
  DVec3 normal_at(const double w[3]) {
    DVec3 p[3];
    for (int j = 0; j < 3; ++j) p[j] = to_dvec3(prim_->positions[idx_[j]]);
    const DVec3 e1 = sub(p[1], p[0]), e2 = sub(p[2], p[0]);
    const DVec3 nf = normalize(cross(e1, e2));
    DVec3 n = nf;
    if (prim_->normals.size() >= prim_->vertex_count()) {
      DVec3 s{0, 0, 0};
      for (int j = 0; j < 3; ++j) s = add(s, mul(to_dvec3(prim_->normals[idx_[j]]), w[j]));
      if (length(s) > 1e-12) n = normalize(s);
    }
    if (!(length(n) > 0)) return {0, 0, 1};
    DVec3 shaded = n;
    if (normal_mapped_) {
      const Vec3 m = sample_normal_map(scene_, prim_->material, uv_);
      const TangentFrame fs =
          derivative_frame(e1, e2, {map_uv_[1].x - map_uv_[0].x, map_uv_[1].y - map_uv_[0].y},
                           {map_uv_[2].x - map_uv_[0].x, map_uv_[2].y - map_uv_[0].y}, n);
      shaded = apply_normal_map(fs, to_dvec3(m));
    }
    const Vec2 d1{float(corner_[1].x - corner_[0].x), float(corner_[1].y - corner_[0].y)};
    const Vec2 d2{float(corner_[2].x - corner_[0].x), float(corner_[2].y - corner_[0].y)};
    return encode_normal_map(derivative_frame(e1, e2, d1, d2, n), shaded);
  }

  Vec4 color_at(const double w[3]) {
    uv_.resize(prim_->uvs.size());
    for (size_t s = 0; s < prim_->uvs.size(); ++s) {
      const std::vector<Vec2>& set = prim_->uvs[s];
      if (set.size() < prim_->vertex_count()) {
        uv_[s] = {0, 0};
        continue;
      }
      const Vec2 &a = set[idx_[0]], &b = set[idx_[1]], &c = set[idx_[2]];
      uv_[s] = {float(a.x * w[0] + b.x * w[1] + c.x * w[2]),
                float(a.y * w[0] + b.y * w[1] + c.y * w[2])};
    }
    Vec4 vc{1, 1, 1, 1};
    if (!prim_->colors.empty() && prim_->colors.size() >= prim_->vertex_count())
      vc = lerp3(prim_->colors[idx_[0]], prim_->colors[idx_[1]], prim_->colors[idx_[2]], w);
    return sample_base_color(scene_, prim_->material, uv_, vc);
  }

  const Scene& scene_;
  const ChartSet& charts_;
  const std::vector<ChartUv>& uvs_;
  const AtlasLayout& layout_;
  std::vector<std::vector<FaceRef>> faces_;  // per mesh, numbered when first needed
  std::vector<uint8_t> numbered_;
  const Primitive* prim_ = nullptr;
  Job current_{kFlat, kFlat};  // the face selected last (kFlat: none)
  uint32_t idx_[3] = {0, 0, 0};
  P2 corner_[3];
  std::vector<Vec2> uv_;
  bool normal_mapped_ = false;  // the current face's material has a decoded normal map
  Vec2 map_uv_[3];              // its corners' normal-map uvs, transformed
};

constexpr double kMargin = 0.5;  // conservative coverage margin, texels

// Pass 1 for one face, in rows [row_begin, row_end): every texel whose centre is within kMargin
// of the triangle and nearer to it than to any face seen so far takes the face (job) as its
// owner. Returns how many it took.
size_t cover_face(const P2 c[3], int32_t job, int w, int row_begin, int row_end,
                  std::vector<int32_t>& owner, std::vector<float>& dist) {
  double minx = std::min({c[0].x, c[1].x, c[2].x}) - kMargin;
  double maxx = std::max({c[0].x, c[1].x, c[2].x}) + kMargin;
  double miny = std::min({c[0].y, c[1].y, c[2].y}) - kMargin;
  double maxy = std::max({c[0].y, c[1].y, c[2].y}) + kMargin;
  if (!(std::isfinite(minx) && std::isfinite(maxx) && std::isfinite(miny) && std::isfinite(maxy)))
    return 0;
  size_t taken = 0;
  // Texels whose centre i + ½ lies in [min, max].
  int x0 = int(std::clamp(std::ceil(minx - 0.5), 0.0, double(w)));
  int x1 = int(std::clamp(std::floor(maxx - 0.5), -1.0, double(w - 1)));
  int y0 = int(std::clamp(std::ceil(miny - 0.5), double(row_begin), double(row_end)));
  int y1 = int(std::clamp(std::floor(maxy - 0.5), double(row_begin) - 1, double(row_end - 1)));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      double bary[3];
      double d = nearest_barycentric(c, {x + 0.5, y + 0.5}, bary);
      if (d > kMargin) continue;
      size_t i = size_t(y) * size_t(w) + size_t(x);
      if (!(float(d) < dist[i])) continue;  // an earlier face is at least as near
      owner[i] = job;
      dist[i] = float(d);
      ++taken;
    }
  return taken;
}

// Pass 1 for a chart smaller than a texel whose faces reached no texel centre within kMargin (a
// sphere sampling a 1×1 texture is sized to a fraction of a texel): the texel under the centre
// of its corners' bounds takes the chart's face nearest to that texel's centre, so the chart
// has its colour there instead of whatever the fill around it brings. The chart's cell is its
// own, so no other chart holds that texel.
void cover_tiny_chart(Source& src, const std::vector<Job>& jobs, size_t first_job, size_t end_job,
                      int w, int h, std::vector<int32_t>& owner, std::vector<float>& dist) {
  double minx = std::numeric_limits<double>::infinity(), miny = minx;
  double maxx = -minx, maxy = -minx;
  for (size_t j = first_job; j < end_job; ++j) {
    src.select(jobs[j]);
    for (int k = 0; k < 3; ++k) {
      const P2 c = src.corners()[k];
      minx = std::min(minx, c.x), maxx = std::max(maxx, c.x);
      miny = std::min(miny, c.y), maxy = std::max(maxy, c.y);
    }
  }
  if (!(std::isfinite(minx) && std::isfinite(maxx) && std::isfinite(miny) && std::isfinite(maxy)))
    return;
  const int x = int(std::clamp(std::floor(0.5 * (minx + maxx)), 0.0, double(w - 1)));
  const int y = int(std::clamp(std::floor(0.5 * (miny + maxy)), 0.0, double(h - 1)));
  const size_t i = size_t(y) * size_t(w) + size_t(x);
  for (size_t j = first_job; j < end_job; ++j) {
    src.select(jobs[j]);
    double bary[3];
    const double d = nearest_barycentric(src.corners(), {x + 0.5, y + 0.5}, bary);
    if (owner[i] >= 0 && !(float(d) < dist[i])) continue;
    owner[i] = int32_t(j);
    dist[i] = float(d);
  }
}

// Pass 1's jobs (flat charts and textured faces, chart order) and the job owning each texel.
struct Coverage {
  std::vector<Job> jobs;
  std::vector<int32_t> owner;  // per texel, -1: none
};

// Jobs [job_begin, job_end) in order over rows [row_begin, row_end): a flat chart takes the
// texels of its block that no earlier face covers exactly, a face those cover_face gives it.
// Adds to taken[chart] the texels each chart's faces took.
void cover_jobs(const std::vector<Job>& jobs, const std::vector<std::array<P2, 3>>& corners,
                const AtlasLayout& layout, size_t job_begin, size_t job_end, int w, int row_begin,
                int row_end, std::vector<int32_t>& owner, std::vector<float>& dist,
                std::vector<size_t>& taken) {
  for (size_t j = job_begin; j < job_end; ++j) {
    const Job& job = jobs[j];
    if (job.k != kFlat) {
      taken[job.chart] +=
          cover_face(corners[j].data(), int32_t(j), w, row_begin, row_end, owner, dist);
      continue;
    }
    const Vec2 off = layout.offset[job.chart];
    const int block = job.chart < layout.block.size() ? layout.block[job.chart] : 0;
    const int bx = int(std::floor(off.x)), by = int(std::floor(off.y));
    for (int y = std::max(row_begin, by); y < std::min(row_end, by + block); ++y)
      for (int x = std::max(0, bx); x < std::min(w, bx + block); ++x) {
        const size_t i = size_t(y) * size_t(w) + size_t(x);
        if (!(0.0f < dist[i])) continue;  // inside an earlier chart's face
        owner[i] = int32_t(j);
        dist[i] = 0;
      }
  }
}

// Pass 1 of bake_atlas. A texel's owner depends only on the jobs before it in order, so rows are
// covered in bands on every core, each band visiting every job in order: the same owners as one
// pass over the whole atlas, whatever the thread count. A textured chart whose faces took no
// texel (smaller than a texel) is placed by cover_tiny_chart between its own faces and the next
// chart's, so where one exists the pass is redone chart by chart on one core.
Coverage cover_texels(Source& src, const ChartSet& charts, const AtlasLayout& layout,
                      size_t chart_count, int w, int h) {
  Coverage cov;
  std::vector<std::array<P2, 3>> corners;  // per job (a flat chart's unused)
  std::vector<size_t> first_job(chart_count + 1, 0);
  for (size_t c = 0; c < chart_count; ++c) {
    first_job[c] = cov.jobs.size();
    const Chart& chart = charts.charts[c];
    if (!chart.textured) {
      cov.jobs.push_back({uint32_t(c), kFlat});
      corners.push_back({});
      continue;
    }
    for (size_t k = 0; k < chart.faces.size(); ++k) {
      const Job j{uint32_t(c), uint32_t(k)};
      if (!src.select(j)) continue;
      cov.jobs.push_back(j);
      corners.push_back({src.corners()[0], src.corners()[1], src.corners()[2]});
    }
  }
  first_job[chart_count] = cov.jobs.size();
  const size_t texels = size_t(w) * size_t(h);
  cov.owner.assign(texels, -1);
  std::vector<float> dist(texels, std::numeric_limits<float>::infinity());
  constexpr size_t kBandRows = 128;
  const size_t bands = (size_t(h) + kBandRows - 1) / kBandRows;
  std::vector<std::vector<size_t>> band_taken(bands, std::vector<size_t>(chart_count, 0));
  parallel_chunks(bands, 1, [&](size_t begin, size_t end) {
    for (size_t b = begin; b < end; ++b)
      cover_jobs(cov.jobs, corners, layout, 0, cov.jobs.size(), w, int(b * kBandRows),
                 int(std::min(size_t(h), (b + 1) * kBandRows)), cov.owner, dist, band_taken[b]);
  });
  auto tiny = [&](size_t c, const std::vector<size_t>& taken) {
    return charts.charts[c].textured && first_job[c + 1] > first_job[c] && taken[c] == 0;
  };
  std::vector<size_t> taken(chart_count, 0);
  for (const std::vector<size_t>& t : band_taken)
    for (size_t c = 0; c < chart_count; ++c) taken[c] += t[c];
  bool any_tiny = false;
  for (size_t c = 0; c < chart_count && !any_tiny; ++c) any_tiny = tiny(c, taken);
  if (!any_tiny) return cov;
  std::fill(cov.owner.begin(), cov.owner.end(), -1);
  std::fill(dist.begin(), dist.end(), std::numeric_limits<float>::infinity());
  std::fill(taken.begin(), taken.end(), 0);
  for (size_t c = 0; c < chart_count; ++c) {
    cover_jobs(cov.jobs, corners, layout, first_job[c], first_job[c + 1], w, 0, h, cov.owner, dist,
               taken);
    if (tiny(c, taken))
      cover_tiny_chart(src, cov.jobs, first_job[c], first_job[c + 1], w, h, cov.owner, dist);
  }
  return cov;
}

const int kDx[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
const int kDy[8] = {-1, -1, -1, 0, 0, 1, 1, 1};

struct Linear4 {
  float v[4];
};

Linear4 decode(const uint8_t* p) {
  return {{srgb_to_linear(p[0]), srgb_to_linear(p[1]), srgb_to_linear(p[2]), p[3] / 255.0f}};
}

void encode(Vec4 c, uint8_t* p) {
  p[0] = linear_to_srgb(c.x);
  p[1] = linear_to_srgb(c.y);
  p[2] = linear_to_srgb(c.z);
  p[3] = uint8_t(std::lround(std::clamp(c.w, 0.0f, 1.0f) * 255.0f));
}

void encode_data(Vec4 c, uint8_t* p) {
  const float v[4] = {c.x, c.y, c.z, c.w};
  for (int k = 0; k < 4; ++k) p[k] = uint8_t(std::lround(std::clamp(v[k], 0.0f, 1.0f) * 255.0f));
}

// The gutters: ring-by-ring dilation from the filled texels of `rgba` (sRGB bytes; averages are
// taken in linear light). Each ring's texels are computed from the texels filled before the ring,
// so the result does not depend on visiting order (which is deterministic anyway). A new texel
// joins the majority chart of its filled 8-neighbours (ties: the smaller index) and averages only
// that chart's neighbours. Stops after `rings` rings.
struct Layer {
  std::vector<uint8_t>* rgba;  // w × h RGBA8
  bool srgb;                   // colour (averaged in linear light) or data (averaged as stored)
};

void dilate(int w, int h, const std::vector<Layer>& layers, std::vector<int32_t>& chart,
            std::vector<uint8_t>& filled, int rings) {
  std::vector<uint8_t> queued(filled.size(), 0);
  std::vector<size_t> frontier;
  auto enqueue_neighbours = [&](size_t i) {
    int x = int(i % size_t(w)), y = int(i / size_t(w));
    for (int k = 0; k < 8; ++k) {
      int nx = x + kDx[k], ny = y + kDy[k];
      if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
      size_t j = size_t(ny) * size_t(w) + size_t(nx);
      if (!filled[j] && !queued[j]) {
        queued[j] = 1;
        frontier.push_back(j);
      }
    }
  };
  // The first ring: empty texels with a filled neighbour, in texel order (bands of rows on every
  // core, joined in order).
  constexpr size_t kBand = 64;
  std::vector<std::vector<size_t>> first((size_t(h) + kBand - 1) / kBand);
  parallel_chunks(first.size(), 1, [&](size_t band_begin, size_t band_end) {
    for (size_t b = band_begin; b < band_end; ++b)
      for (int y = int(b * kBand); y < std::min(h, int((b + 1) * kBand)); ++y)
        for (int x = 0; x < w; ++x) {
          const size_t i = size_t(y) * size_t(w) + size_t(x);
          if (filled[i]) continue;
          for (int k = 0; k < 8; ++k) {
            const int nx = x + kDx[k], ny = y + kDy[k];
            if (nx >= 0 && ny >= 0 && nx < w && ny < h &&
                filled[size_t(ny) * size_t(w) + size_t(nx)]) {
              first[b].push_back(i);
              break;
            }
          }
        }
  });
  for (const std::vector<size_t>& band : first)
    for (size_t i : band) {
      queued[i] = 1;
      frontier.push_back(i);
    }
  std::vector<std::vector<uint8_t>> new_rgba(layers.size());
  std::vector<int32_t> new_chart;
  for (int ring = 0; ring < rings && !frontier.empty(); ++ring) {
    for (std::vector<uint8_t>& v : new_rgba) v.assign(frontier.size() * 4, 0);
    new_chart.assign(frontier.size(), -1);
    // Each texel of the ring reads only texels filled before the ring and writes its own slot:
    // on every core, the same bytes.
    parallel_chunks(frontier.size(), 4096, [&](size_t ring_begin, size_t ring_end) {
      for (size_t f = ring_begin; f < ring_end; ++f) {
        const size_t i = frontier[f];
        const int x = int(i % size_t(w)), y = int(i / size_t(w));
        int32_t ids[8];
        size_t js[8];
        int count = 0;
        for (int k = 0; k < 8; ++k) {
          int nx = x + kDx[k], ny = y + kDy[k];
          if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
          size_t j = size_t(ny) * size_t(w) + size_t(nx);
          if (!filled[j]) continue;
          ids[count] = chart[j];
          js[count] = j;
          ++count;
        }
        int32_t who = -1;
        int best = 0;
        for (int a = 0; a < count; ++a) {
          int votes = 0;
          for (int b = 0; b < count; ++b) votes += ids[b] == ids[a];
          if (votes > best || (votes == best && ids[a] < who)) {
            best = votes;
            who = ids[a];
          }
        }
        for (size_t l = 0; l < layers.size(); ++l) {
          const std::vector<uint8_t>& rgba = *layers[l].rgba;
          double sum[4] = {0, 0, 0, 0};
          int used = 0;
          for (int a = 0; a < count; ++a) {
            if (ids[a] != who) continue;
            const uint8_t* q = &rgba[js[a] * 4];
            Linear4 c = layers[l].srgb
                            ? decode(q)
                            : Linear4{{q[0] / 255.0f, q[1] / 255.0f, q[2] / 255.0f, q[3] / 255.0f}};
            for (int k = 0; k < 4; ++k) sum[k] += c.v[k];
            ++used;
          }
          if (used == 0) continue;
          const Vec4 mean{float(sum[0] / used), float(sum[1] / used), float(sum[2] / used),
                          float(sum[3] / used)};
          if (layers[l].srgb)
            encode(mean, &new_rgba[l][f * 4]);
          else
            encode_data(mean, &new_rgba[l][f * 4]);
        }
        new_chart[f] = who;
      }
    });
    for (size_t f = 0; f < frontier.size(); ++f) {
      for (size_t l = 0; l < layers.size(); ++l)
        std::copy_n(&new_rgba[l][f * 4], 4, &(*layers[l].rgba)[frontier[f] * 4]);
      chart[frontier[f]] = new_chart[f];
      filled[frontier[f]] = 1;
    }
    std::vector<size_t> ring_texels;
    ring_texels.swap(frontier);
    for (size_t i : ring_texels) enqueue_neighbours(i);
  }
}

}  // namespace

BakeResult bake_atlas(const Scene& scene, const ChartSet& charts, const std::vector<ChartUv>& uvs,
                      const AtlasLayout& layout, const BakeOptions& options,
                      const BakeChannels& channels) {
  BakeResult result;
  const int w = layout.size, h = layout.rows();
  if (w <= 0 || h <= 0) return result;
  const size_t texels = size_t(w) * size_t(h);
  const size_t chart_count = std::min(charts.charts.size(), layout.offset.size());
  Source src(scene, charts, uvs, layout);

  // Pass 1: which face (or flat chart) owns each texel.
  Coverage coverage = cover_texels(src, charts, layout, chart_count, w, h);
  const std::vector<Job>& jobs = coverage.jobs;
  std::vector<int32_t>& owner = coverage.owner;

  // Pass 2: colours. A texel's samples come from its owner face; with supersampling, each sample
  // takes the nearest of the faces owning the texel or its 8 neighbours within the same chart,
  // so texels on an edge between two faces read each side from its own face.
  Image& img = result.atlas;
  img.name = "atlas";
  img.width = w;
  img.height = h;
  img.rgba.assign(texels * 4, 0);
  // The further channels: same size, alpha 255.
  auto channel_image = [&](bool on, Image& out, const char* name) -> std::vector<uint8_t>* {
    if (!on) return nullptr;
    out.name = name;
    out.width = w;
    out.height = h;
    out.rgba.assign(texels * 4, 255);
    return &out.rgba;
  };
  std::vector<uint8_t>* normal = channel_image(channels.normal, result.normal, "atlas normal");
  std::vector<uint8_t>* orm =
      channel_image(channels.orm, result.orm, "atlas occlusion-roughness-metallic");
  std::vector<uint8_t>* emissive =
      channel_image(channels.emissive, result.emissive, "atlas emissive");
  std::vector<uint8_t>* sheen = channel_image(channels.sheen, result.sheen, "atlas sheen");
  const float emissive_scale = channels.emissive_scale > 0 && std::isfinite(channels.emissive_scale)
                                   ? channels.emissive_scale
                                   : 1.0f;
  auto put_channels = [&](size_t i, Vec3 o, Vec3 e, DVec3 m, Vec3 sh) {
    if (sheen) encode({sh.x, sh.y, sh.z, 1}, &(*sheen)[i * 4]);
    if (orm) encode_data({o.x, o.y, o.z, 1}, &(*orm)[i * 4]);
    if (emissive)
      encode({e.x / emissive_scale, e.y / emissive_scale, e.z / emissive_scale, 1},
             &(*emissive)[i * 4]);
    if (normal)
      encode_data({float(0.5 * m.x + 0.5), float(0.5 * m.y + 0.5), float(0.5 * m.z + 0.5), 1},
                  &(*normal)[i * 4]);
  };
  result.texel_chart.assign(texels, -1);
  std::vector<uint8_t> filled(texels, 0);
  const int ss = std::max(1, options.supersample);
  // Rows in chunks on every core: each texel is written by its own row's thread only, and
  // each thread has its own Source (its current face), so the atlas is the same bytes.
  parallel_chunks(size_t(h), 16, [&](size_t row_begin, size_t row_end) {
    Source local = src;  // this thread's current face
    for (int y = int(row_begin); y < int(row_end); ++y)
      for (int x = 0; x < w; ++x) {
        const size_t i = size_t(y) * size_t(w) + size_t(x);
        if (owner[i] < 0) continue;
        const Job& own = jobs[size_t(owner[i])];
        result.texel_chart[i] = int32_t(own.chart);
        filled[i] = 1;
        if (own.k == kFlat) {
          const Chart& chart = charts.charts[own.chart];
          encode(chart.color, &img.rgba[i * 4]);
          put_channels(i, chart.orm, chart.emissive, {0, 0, 1}, chart.sheen);
          continue;
        }
        Source::Texel texel;
        if (ss == 1) {
          local.select(own);
          texel = local.sample({x + 0.5, y + 0.5}, channels);
        } else {
          int32_t cand[9];
          int nc = 0;
          cand[nc++] = owner[i];
          for (int k = 0; k < 8; ++k) {
            int nx = x + kDx[k], ny = y + kDy[k];
            if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
            int32_t o = owner[size_t(ny) * size_t(w) + size_t(nx)];
            if (o < 0 || jobs[size_t(o)].chart != own.chart || jobs[size_t(o)].k == kFlat) continue;
            if (std::find(cand, cand + nc, o) == cand + nc) cand[nc++] = o;
          }
          double sum[4] = {0, 0, 0, 0};
          double orm_sum[3] = {0, 0, 0}, em_sum[3] = {0, 0, 0}, sh_sum[3] = {0, 0, 0};
          DVec3 n_sum{0, 0, 0};
          for (int sy = 0; sy < ss; ++sy)
            for (int sx = 0; sx < ss; ++sx) {
              const P2 p{x + (sx + 0.5) / ss, y + (sy + 0.5) / ss};
              int32_t best = cand[0];
              double best_d = std::numeric_limits<double>::infinity();
              for (int a = 0; a < nc; ++a) {  // the owner first: it wins ties
                local.select(jobs[size_t(cand[a])]);
                double bary[3];
                double d = nearest_barycentric(local.corners(), p, bary);
                if (d < best_d) {
                  best_d = d;
                  best = cand[a];
                }
              }
              local.select(jobs[size_t(best)]);
              const Source::Texel t = local.sample(p, channels);
              sum[0] += t.color.x;
              sum[1] += t.color.y;
              sum[2] += t.color.z;
              sum[3] += t.color.w;
              orm_sum[0] += t.orm.x, orm_sum[1] += t.orm.y, orm_sum[2] += t.orm.z;
              em_sum[0] += t.emissive.x, em_sum[1] += t.emissive.y, em_sum[2] += t.emissive.z;
              sh_sum[0] += t.sheen.x, sh_sum[1] += t.sheen.y, sh_sum[2] += t.sheen.z;
              n_sum = add(n_sum, t.normal);
            }
          const double inv = 1.0 / (ss * ss);
          texel.color = {float(sum[0] * inv), float(sum[1] * inv), float(sum[2] * inv),
                         float(sum[3] * inv)};
          texel.orm = {float(orm_sum[0] * inv), float(orm_sum[1] * inv), float(orm_sum[2] * inv)};
          texel.emissive = {float(em_sum[0] * inv), float(em_sum[1] * inv), float(em_sum[2] * inv)};
          texel.sheen = {float(sh_sum[0] * inv), float(sh_sum[1] * inv), float(sh_sum[2] * inv)};
          texel.normal = length(n_sum) > 0 ? normalize(n_sum) : DVec3{0, 0, 1};
        }
        encode(texel.color, &img.rgba[i * 4]);
        put_channels(i, texel.orm, texel.emissive, texel.normal, texel.sheen);
      }
  });
  owner.clear();
  owner.shrink_to_fit();

  std::vector<Layer> layers{{&img.rgba, true}};
  if (normal) layers.push_back({normal, false});
  if (orm) layers.push_back({orm, false});
  if (emissive) layers.push_back({emissive, true});
  if (sheen) layers.push_back({sheen, true});
  // Gutters.
  if (options.gutter > 0) dilate(w, h, layers, result.texel_chart, filled, options.gutter);

  // Translucency of what was baked (charts and their gutters).
  for (size_t i = 0; i < texels && !result.has_alpha; ++i)
    if (filled[i] && img.rgba[i * 4 + 3] < 255) result.has_alpha = true;
  // The empty space takes the colour and alpha of the charts around it (pull-push; chart -1), so
  // no mip level averages a chart with transparent black: at the sizes a model is seen at, a
  // coarse level is what shows, and black there darkens every chart edge (and thins alpha-masked
  // ones).
  std::vector<FillLayer> fill;
  for (const Layer& l : layers) fill.push_back({l.rgba, l.srgb});
  fill_empty_texels(w, h, filled, fill);
  if (!result.has_alpha)
    for (size_t i = 0; i < texels; ++i) img.rgba[i * 4 + 3] = 255;
  return result;
}

}  // namespace meshmux
