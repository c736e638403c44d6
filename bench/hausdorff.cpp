#include "bench/hausdorff.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "scene/dvec3.h"

namespace meshmux::bench {

namespace {

inline DVec3 corner(const std::vector<float>& soup, size_t tri, int k) {
  const float* p = &soup[tri * 9 + size_t(k) * 3];
  return {p[0], p[1], p[2]};
}

// Squared distance from p to triangle abc: closest point by Voronoi regions (Ericson,
// Real-Time Collision Detection §5.1.5), evaluated in double.
double point_triangle_dist2(DVec3 p, DVec3 a, DVec3 b, DVec3 c) {
  DVec3 ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
  double d1 = dot(ab, ap), d2 = dot(ac, ap);
  DVec3 q;
  if (d1 <= 0 && d2 <= 0) {
    q = a;
  } else {
    DVec3 bp = sub(p, b);
    double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) {
      q = b;
    } else {
      double vc = d1 * d4 - d3 * d2;
      if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        double v = d1 / (d1 - d3);
        q = add(a, mul(ab, v));
      } else {
        DVec3 cp = sub(p, c);
        double d5 = dot(ab, cp), d6 = dot(ac, cp);
        if (d6 >= 0 && d5 <= d6) {
          q = c;
        } else {
          double vb = d5 * d2 - d1 * d6;
          if (vb <= 0 && d2 >= 0 && d6 <= 0) {
            double w = d2 / (d2 - d6);
            q = add(a, mul(ac, w));
          } else {
            double va = d3 * d6 - d5 * d4;
            if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
              double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
              q = add(b, mul(sub(c, b), w));
            } else {
              double denom = va + vb + vc;
              if (!(std::abs(denom) > 0)) {  // degenerate triangle: nearest of the corners
                double da = dot(sub(p, a), sub(p, a)), db = dot(sub(p, b), sub(p, b)),
                       dc = dot(sub(p, c), sub(p, c));
                return std::min(da, std::min(db, dc));
              }
              double v = vb / denom, w = vc / denom;
              q = add(a, add(mul(ab, v), mul(ac, w)));
            }
          }
        }
      }
    }
  }
  DVec3 d = sub(p, q);
  return dot(d, d);
}

// A bounding-volume hierarchy over a triangle soup: median splits on the longest axis of
// the centroid bounds, up to kLeaf triangles per leaf. Nodes are in one array; an inner
// node's children are at `first` and `first + 1`.
class Bvh {
 public:
  explicit Bvh(const std::vector<float>& soup) {
    size_t n = soup.size() / 9;
    order_.resize(n);
    centroids_.resize(n * 3);
    boxes_.resize(n * 6);
    for (size_t t = 0; t < n; ++t) {
      order_[t] = uint32_t(t);
      for (int a = 0; a < 3; ++a) {
        float v0 = soup[t * 9 + size_t(a)], v1 = soup[t * 9 + 3 + size_t(a)],
              v2 = soup[t * 9 + 6 + size_t(a)];
        boxes_[t * 6 + size_t(a)] = std::min(v0, std::min(v1, v2));
        boxes_[t * 6 + 3 + size_t(a)] = std::max(v0, std::max(v1, v2));
        centroids_[t * 3 + size_t(a)] = (v0 + v1 + v2) / 3.0f;
      }
    }
    nodes_.reserve(n / kLeaf * 2 + 2);
    if (n > 0) {
      nodes_.emplace_back();
      build(0, 0, uint32_t(n));
    }
    tris_.resize(n * 9);
    for (size_t i = 0; i < n; ++i)
      std::copy(&soup[size_t(order_[i]) * 9], &soup[size_t(order_[i]) * 9 + 9], &tris_[i * 9]);
    centroids_.clear();
    centroids_.shrink_to_fit();
    boxes_.clear();
    boxes_.shrink_to_fit();
  }

  bool empty() const { return nodes_.empty(); }

  // Squared distance from p to the nearest triangle.
  double nearest2(DVec3 p) const {
    double best = std::numeric_limits<double>::infinity();
    struct Entry {
      uint32_t node;
      double d2;
    };
    Entry stack[128];
    int top = 0;
    stack[top++] = {0, box_dist2(nodes_[0], p)};
    while (top > 0) {
      Entry e = stack[--top];
      if (e.d2 >= best) continue;
      const Node& nd = nodes_[e.node];
      if (nd.count > 0) {
        for (uint32_t i = nd.first; i < nd.first + nd.count; ++i) {
          double d = point_triangle_dist2(p, corner(tris_, i, 0), corner(tris_, i, 1),
                                          corner(tris_, i, 2));
          if (d < best) best = d;
        }
        continue;
      }
      uint32_t l = nd.first, r = nd.first + 1;
      double dl = box_dist2(nodes_[l], p), dr = box_dist2(nodes_[r], p);
      if (dl > dr) {
        std::swap(l, r);
        std::swap(dl, dr);
      }
      // Nearer child on top so it is searched first.
      if (dr < best && top < 127) stack[top++] = {r, dr};
      if (dl < best && top < 127) stack[top++] = {l, dl};
    }
    return best;
  }

 private:
  static constexpr uint32_t kLeaf = 4;
  struct Node {
    float lo[3], hi[3];
    uint32_t first = 0;  // leaf: first triangle; inner: left child
    uint32_t count = 0;  // leaf: triangles; 0 for inner nodes
  };

  static double box_dist2(const Node& n, DVec3 p) {
    double q[3] = {p.x, p.y, p.z}, d2 = 0;
    for (int a = 0; a < 3; ++a) {
      double d = 0;
      if (q[a] < n.lo[a])
        d = n.lo[a] - q[a];
      else if (q[a] > n.hi[a])
        d = q[a] - n.hi[a];
      d2 += d * d;
    }
    return d2;
  }

  void build(uint32_t node, uint32_t begin, uint32_t end) {
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    float clo[3] = {INFINITY, INFINITY, INFINITY}, chi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = begin; i < end; ++i) {
      size_t t = order_[i];
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], boxes_[t * 6 + size_t(a)]);
        hi[a] = std::max(hi[a], boxes_[t * 6 + 3 + size_t(a)]);
        clo[a] = std::min(clo[a], centroids_[t * 3 + size_t(a)]);
        chi[a] = std::max(chi[a], centroids_[t * 3 + size_t(a)]);
      }
    }
    for (int a = 0; a < 3; ++a) {
      nodes_[node].lo[a] = lo[a];
      nodes_[node].hi[a] = hi[a];
    }
    uint32_t n = end - begin;
    int axis = 0;
    for (int a = 1; a < 3; ++a)
      if (chi[a] - clo[a] > chi[axis] - clo[axis]) axis = a;
    if (n <= kLeaf || !(chi[axis] > clo[axis])) {
      nodes_[node].first = begin;
      nodes_[node].count = n;
      return;
    }
    uint32_t mid = begin + n / 2;
    std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                     [&](uint32_t x, uint32_t y) {
                       return centroids_[size_t(x) * 3 + size_t(axis)] <
                              centroids_[size_t(y) * 3 + size_t(axis)];
                     });
    uint32_t left = uint32_t(nodes_.size());
    nodes_.emplace_back();
    nodes_.emplace_back();
    nodes_[node].first = left;
    nodes_[node].count = 0;
    build(left, begin, mid);
    build(left + 1, mid, end);
  }

  std::vector<Node> nodes_;
  std::vector<uint32_t> order_;
  std::vector<float> tris_;       // triangles in leaf order, 9 floats each
  std::vector<float> centroids_;  // build only
  std::vector<float> boxes_;      // build only
};

// splitmix64: tiny, fast and identical everywhere (std:: distributions are not).
struct Rng {
  uint64_t s;
  uint64_t next() {
    uint64_t z = (s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * (1.0 / 9007199254740992.0); }  // [0,1)
};

// Area-weighted samples on a soup; empty when the soup has no area.
std::vector<DVec3> sample_surface(const std::vector<float>& soup, size_t count, uint64_t seed) {
  size_t n = soup.size() / 9;
  std::vector<double> cdf(n);
  double total = 0;
  for (size_t t = 0; t < n; ++t) {
    DVec3 a = corner(soup, t, 0), b = corner(soup, t, 1), c = corner(soup, t, 2);
    DVec3 cr = cross(sub(b, a), sub(c, a));
    double area = 0.5 * std::sqrt(dot(cr, cr));
    if (!std::isfinite(area)) area = 0;
    total += area;
    cdf[t] = total;
  }
  std::vector<DVec3> out;
  if (!(total > 0)) return out;
  out.reserve(count);
  Rng rng{seed};
  for (size_t i = 0; i < count; ++i) {
    double u = rng.uniform() * total;
    size_t t = size_t(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin());
    if (t >= n) t = n - 1;
    double r1 = std::sqrt(rng.uniform()), r2 = rng.uniform();
    DVec3 a = corner(soup, t, 0), b = corner(soup, t, 1), c = corner(soup, t, 2);
    out.push_back(add(add(mul(a, 1 - r1), mul(b, r1 * (1 - r2))), mul(c, r1 * r2)));
  }
  return out;
}

struct Directed {
  double max = 0, sum = 0, sum2 = 0;
  size_t count = 0;
};

Directed directed(const std::vector<DVec3>& samples, const Bvh& target) {
  Directed d;
  for (const DVec3& p : samples) {
    double d2 = target.nearest2(p);
    double dist = std::sqrt(d2);
    d.max = std::max(d.max, dist);
    d.sum += dist;
    d.sum2 += d2;
    ++d.count;
  }
  return d;
}

}  // namespace

std::vector<float> world_triangles(const Scene& scene) {
  std::vector<float> soup;
  for (const Instance& inst : scene.instances) {
    if (inst.mesh >= scene.meshes.size()) continue;
    for (const Primitive& prim : scene.meshes[inst.mesh].primitives) {
      std::vector<Vec3> world(prim.positions.size());
      for (size_t v = 0; v < prim.positions.size(); ++v)
        world[v] = inst.world.transform_point(prim.positions[v]);
      for (size_t i = 0; i + 2 < prim.indices.size(); i += 3) {
        uint32_t a = prim.indices[i], b = prim.indices[i + 1], c = prim.indices[i + 2];
        if (a >= world.size() || b >= world.size() || c >= world.size()) continue;
        for (uint32_t v : {a, b, c}) soup.insert(soup.end(), {world[v].x, world[v].y, world[v].z});
      }
    }
  }
  return soup;
}

struct HausdorffReference::Impl {
  Impl(const std::vector<float>& soup, double diag, const HausdorffOptions& opt)
      : options(opt),
        diagonal(diag),
        samples(sample_surface(soup, opt.samples, opt.seed)),
        bvh(soup) {}
  HausdorffOptions options;
  double diagonal;
  std::vector<DVec3> samples;
  Bvh bvh;
};

HausdorffReference::HausdorffReference(const std::vector<float>& soup, double diagonal,
                                       const HausdorffOptions& options)
    : impl_(std::make_unique<Impl>(soup, diagonal, options)) {}
HausdorffReference::~HausdorffReference() = default;
HausdorffReference::HausdorffReference(HausdorffReference&&) noexcept = default;
HausdorffReference& HausdorffReference::operator=(HausdorffReference&&) noexcept = default;

HausdorffResult HausdorffReference::compare(const std::vector<float>& b) const {
  const Impl& a = *impl_;
  HausdorffResult r;
  r.diagonal = a.diagonal;
  std::vector<DVec3> sb =
      sample_surface(b, a.options.samples, a.options.seed ^ 0x9e3779b97f4a7c15ULL);
  if (a.samples.empty() || sb.empty() || !(a.diagonal > 0)) {
    r.hausdorff = r.forward = r.backward = r.mean = r.rms = INFINITY;
    return r;
  }
  Bvh bb(b);
  Directed f = directed(a.samples, bb), g = directed(sb, a.bvh);
  double inv = 1.0 / a.diagonal;
  r.forward = f.max * inv;
  r.backward = g.max * inv;
  r.hausdorff = std::max(r.forward, r.backward);
  double n = double(f.count + g.count);
  r.mean = (f.sum + g.sum) / n * inv;
  r.rms = std::sqrt((f.sum2 + g.sum2) / n) * inv;
  r.valid = true;
  return r;
}

HausdorffResult hausdorff_soup(const std::vector<float>& a, const std::vector<float>& b,
                               double diagonal, const HausdorffOptions& options) {
  return HausdorffReference(a, diagonal, options).compare(b);
}

HausdorffResult hausdorff(const Scene& reference, const Scene& other,
                          const HausdorffOptions& options) {
  return hausdorff_soup(world_triangles(reference), world_triangles(other),
                        double(scene_bounds(reference).diagonal()), options);
}

}  // namespace meshmux::bench
