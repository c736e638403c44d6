// Compact vertex splits (multiplex/vsplit.h): the state both ends of the stream keep and the
// decoder. DESIGN.md "Package"; paper 002 (vertex order, parents); the ring-relative connectivity
// and barycentric prediction follow compressed progressive meshes (Pajarola & Rossignac 2000)
// and valence-driven progressive coding (Alliez & Desbrun 2001), adapted to corner lists.
#include "multiplex/vsplit.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "scene/quantize.h"

namespace meshmux {

void VsplitMesh::reset(uint32_t capacity_vertices, uint32_t capacity_faces) {
  vertices.clear(), indices.clear(), head.clear(), next.clear(), stamp_.clear();
  twin_latest_.clear(), twin_previous_.clear();
  solid = 0, stamp_value_ = 0;
  capacity_vertices_ = capacity_vertices, capacity_faces_ = capacity_faces;
}

uint32_t VsplitMesh::add_vertex(const QuantizedVertex& q) {
  vertices.push_back(q);
  head.push_back(-1);
  stamp_.push_back(0);
  twin_previous_.push_back(-1);
  return uint32_t(vertices.size() - 1);
}

void VsplitMesh::add_face(uint32_t a, uint32_t b, uint32_t c) {
  for (uint32_t v : {a, b, c}) {
    int32_t corner = int32_t(indices.size());
    indices.push_back(v);
    next.push_back(head[v]);
    head[v] = corner;
  }
  if (a != b && b != c && a != c) ++solid;
}

void VsplitMesh::move_corner(uint32_t p, int32_t previous, int32_t corner, uint32_t v) {
  if (previous < 0)
    head[p] = next[size_t(corner)];
  else
    next[size_t(previous)] = next[size_t(corner)];
  size_t f = size_t(corner) / 3 * 3;
  bool before = indices[f] != indices[f + 1] && indices[f + 1] != indices[f + 2] &&
                indices[f] != indices[f + 2];
  indices[size_t(corner)] = v;
  next[size_t(corner)] = head[v];
  head[v] = corner;
  bool after = indices[f] != indices[f + 1] && indices[f + 1] != indices[f + 2] &&
               indices[f] != indices[f + 2];
  solid += uint64_t(after) - uint64_t(before);
}

uint32_t VsplitMesh::new_stamp() {
  if (++stamp_value_ == 0) {  // wrapped: clear and start again
    std::fill(stamp_.begin(), stamp_.end(), 0);
    stamp_value_ = 1;
  }
  return stamp_value_;
}

void VsplitMesh::ring(uint32_t p, uint32_t v, uint32_t limit, std::vector<uint32_t>& out) {
  out.clear();
  uint32_t s = new_stamp();
  stamp_[p] = stamp_[v] = s;
  for (uint32_t centre : {v, p})
    for (int32_t c = head[centre]; c >= 0; c = next[size_t(c)]) {
      size_t f = size_t(c) / 3 * 3, slot = size_t(c) - f;
      for (size_t k = 1; k <= 2; ++k) {
        uint32_t w = indices[f + (slot + k) % 3];
        if (stamp_[w] == s) continue;
        stamp_[w] = s;
        out.push_back(w);
        if (out.size() >= limit) return;
      }
    }
}

namespace {
// round(sum / n) with halves up, for any sign: floor((2·sum + n) / (2n)).
int64_t mean(int64_t sum, int64_t n) {
  int64_t a = 2 * sum + n, b = 2 * n;
  int64_t q = a / b;
  if ((a % b != 0) && (a < 0)) --q;
  return q;
}
}  // namespace

QuantizedVertex VsplitMesh::predict(uint32_t v, uint32_t p) {
  int64_t sp[3] = {0, 0, 0}, sn[3] = {0, 0, 0}, st[2] = {0, 0};
  int64_t n = 0;
  uint32_t s = new_stamp();
  stamp_[v] = s;
  for (int32_t c = head[v]; c >= 0; c = next[size_t(c)]) {
    size_t f = size_t(c) / 3 * 3, slot = size_t(c) - f;
    for (size_t k = 1; k <= 2; ++k) {
      uint32_t w = indices[f + (slot + k) % 3];
      if (stamp_[w] == s) continue;
      stamp_[w] = s;
      const QuantizedVertex& q = vertices[w];
      for (int i = 0; i < 3; ++i) sp[i] += q.p[i], sn[i] += q.n[i];
      st[0] += q.t[0], st[1] += q.t[1];
      ++n;
    }
  }
  if (n == 0) return vertices[p];
  QuantizedVertex out;
  for (int i = 0; i < 3; ++i)
    out.p[i] = uint16_t(mean(sp[i], n)), out.n[i] = int8_t(mean(sn[i], n));
  out.t[0] = uint16_t(mean(st[0], n)), out.t[1] = uint16_t(mean(st[1], n));
  return out;
}

bool VsplitMesh::fan(uint32_t p, uint32_t start, uint32_t count, std::vector<uint8_t>& moved,
                     uint32_t& vl, uint32_t& vr) const {
  uint32_t n1[kFanLimit], n2[kFanLimit], d = 0;
  for (int32_t c = head[p]; c >= 0; c = next[size_t(c)]) {
    if (d == kFanLimit) return false;
    size_t f = size_t(c) / 3 * 3, slot = size_t(c) - f;
    n1[d] = indices[f + (slot + 1) % 3], n2[d] = indices[f + (slot + 2) % 3];
    if (n1[d] == p || n2[d] == p || n1[d] == n2[d]) return false;
    for (uint32_t j = 0; j < d; ++j)
      if (n1[j] == n1[d]) return false;
    ++d;
  }
  if (start >= d || count == 0 || count > d) return false;
  moved.assign(d, 0);
  uint32_t at = start;
  for (uint32_t k = 0;; ++k) {
    if (moved[at]) return false;
    moved[at] = 1;
    if (k + 1 == count) break;
    uint32_t j = 0;
    while (j < d && n1[j] != n2[at]) ++j;
    if (j == d) return false;
    at = j;
  }
  vl = n1[start], vr = n2[at];
  return vl != vr;
}

bool VsplitMesh::predict_uv(uint32_t v, uint32_t p, const uint16_t position[3],
                            uint16_t uv[2]) const {
  // w: the third vertex of v's newest face with p.
  int64_t w = -1;
  for (int32_t c = head[v]; c >= 0 && w < 0; c = next[size_t(c)]) {
    size_t f = size_t(c) / 3 * 3;
    uint32_t a = indices[f], b = indices[f + 1], d = indices[f + 2];
    if (a == p || b == p || d == p) w = int64_t(a != v && a != p ? a : b != v && b != p ? b : d);
  }
  if (w < 0 || uint32_t(w) == v || uint32_t(w) == p) return false;
  // x: the third vertex of p's first face with w but without v (across the edge p-w).
  int64_t x = -1;
  for (int32_t c = head[p]; c >= 0 && x < 0; c = next[size_t(c)]) {
    size_t f = size_t(c) / 3 * 3;
    uint32_t a = indices[f], b = indices[f + 1], d = indices[f + 2];
    if (a == v || b == v || d == v || (a != w && b != w && d != w)) continue;
    x = int64_t(a != uint32_t(w) && a != p ? a : b != uint32_t(w) && b != p ? b : d);
  }
  if (x < 0 || uint32_t(x) == p || uint32_t(x) == uint32_t(w)) return false;
  // v's place along and off the edge p→w in 3D, carried to uv space on the side away from x.
  // Plain double operations in a fixed order, as the web client does them.
  const QuantizedVertex &P = vertices[p], &W = vertices[size_t(w)], &X = vertices[size_t(x)];
  double ex = double(W.p[0]) - double(P.p[0]), ey = double(W.p[1]) - double(P.p[1]),
         ez = double(W.p[2]) - double(P.p[2]);
  double dx = double(position[0]) - double(P.p[0]), dy = double(position[1]) - double(P.p[1]),
         dz = double(position[2]) - double(P.p[2]);
  double ee = ex * ex + ey * ey + ez * ez;
  if (!(ee > 0)) return false;
  double s = (dx * ex + dy * ey + dz * ez) / ee;
  double rx = dx - s * ex, ry = dy - s * ey, rz = dz - s * ez;
  double t = std::sqrt((rx * rx + ry * ry + rz * rz) / ee);
  double ux = double(W.t[0]) - double(P.t[0]), uy = double(W.t[1]) - double(P.t[1]);
  double side = ux * (double(X.t[1]) - double(P.t[1])) - uy * (double(X.t[0]) - double(P.t[0]));
  double k = side > 0 ? -t : t;  // along the left normal (-uy, ux), away from x
  double u0 = double(P.t[0]) + s * ux - k * uy, u1 = double(P.t[1]) + s * uy + k * ux;
  auto round_uv = [](double a) {
    double r = std::floor(a + 0.5);
    return uint16_t(r < 0 ? 0 : r > kUvMax ? kUvMax : r);
  };
  uv[0] = round_uv(u0), uv[1] = round_uv(u1);
  return true;
}

namespace {
uint64_t position_key(const QuantizedVertex& q) {
  return uint64_t(q.p[0]) << 32 | uint64_t(q.p[1]) << 16 | uint64_t(q.p[2]);
}
}  // namespace

uint32_t VsplitMesh::twins(uint32_t p, uint32_t* out) const {
  auto it = twin_latest_.find(position_key(vertices[p]));
  uint32_t n = 0;
  for (int32_t u = it == twin_latest_.end() ? -1 : int32_t(it->second); u >= 0 && n < kTwinLimit;
       u = twin_previous_[size_t(u)])
    out[n++] = uint32_t(u);
  return n;
}

void VsplitMesh::add_twin(uint32_t p, uint32_t v) {
  auto [it, fresh] = twin_latest_.try_emplace(position_key(vertices[p]), v);
  if (!fresh) {
    twin_previous_[v] = int32_t(it->second);
    it->second = v;
  }
}

uint32_t state_digest(const VsplitMesh& mesh) {
  uint32_t h = 2166136261u;
  auto byte = [&h](uint32_t b) { h = (h ^ (b & 0xffu)) * 16777619u; };
  for (const QuantizedVertex& q : mesh.vertices) {
    for (uint16_t x : q.p) byte(x), byte(x >> 8);
    for (int8_t x : q.n) byte(uint8_t(x));
    for (uint16_t x : q.t) byte(x), byte(x >> 8);
  }
  for (uint32_t i : mesh.indices) byte(i), byte(i >> 8), byte(i >> 16), byte(i >> 24);
  return h;
}

void put_varint(std::vector<uint8_t>& out, uint32_t v) {
  while (v >= 0x80) {
    out.push_back(uint8_t(v | 0x80));
    v >>= 7;
  }
  out.push_back(uint8_t(v));
}

std::vector<uint8_t> deflate_bytes(const std::vector<uint8_t>& in) {
  uLongf size = compressBound(uLong(in.size()));
  std::vector<uint8_t> out(size);
  if (compress2(out.data(), &size, in.data(), uLong(in.size()), 9) != Z_OK) return {};
  out.resize(size);
  return out;
}

std::vector<uint8_t> deflate_raw(const std::vector<uint8_t>& in) {
  z_stream z{};
  // Raw deflate (RFC 1951, no zlib framing), the filtered strategy: the splits' residual
  // bytes are small numbers with few long matches (a few % smaller than the default).
  if (deflateInit2(&z, 9, Z_DEFLATED, -15, 8, Z_FILTERED) != Z_OK) return {};
  std::vector<uint8_t> out(deflateBound(&z, uLong(in.size())) + 16);
  z.next_in = const_cast<Bytef*>(in.data());
  z.avail_in = uInt(in.size());
  z.next_out = out.data();
  z.avail_out = uInt(out.size());
  int r = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  if (r != Z_STREAM_END) return {};
  return out;
}

namespace {

Result<std::vector<uint8_t>> inflate_any(const uint8_t* data, size_t size, uint64_t limit,
                                         bool raw) {
  z_stream z{};
  if ((raw ? inflateInit2(&z, -15) : inflateInit(&z)) != Z_OK)
    return Status::error("zlib: cannot initialize", ErrorKind::kInternal);
  std::vector<uint8_t> out;
  z.next_in = const_cast<Bytef*>(data);
  z.avail_in = uInt(size);
  int r = Z_OK;
  uint8_t buffer[16384];
  while (r == Z_OK) {
    z.next_out = buffer;
    z.avail_out = sizeof buffer;
    r = inflate(&z, Z_NO_FLUSH);
    if (r != Z_OK && r != Z_STREAM_END) break;
    size_t got = sizeof buffer - z.avail_out;
    if (out.size() + got > limit) {
      inflateEnd(&z);
      return Status::error("inflates past its limit of " + std::to_string(limit) + " bytes",
                           ErrorKind::kInput);
    }
    out.insert(out.end(), buffer, buffer + got);
    if (r == Z_OK && got == 0 && z.avail_in == 0) break;  // truncated
  }
  bool done = r == Z_STREAM_END && z.avail_in == 0;
  inflateEnd(&z);
  if (!done)
    return Status::error(raw ? "not a complete deflate stream" : "not a complete zlib stream",
                         ErrorKind::kInput);
  return out;
}

}  // namespace

Result<std::vector<uint8_t>> inflate_bytes(const uint8_t* data, size_t size, uint64_t limit) {
  return inflate_any(data, size, limit, false);
}

Result<std::vector<uint8_t>> inflate_raw(const uint8_t* data, size_t size, uint64_t limit) {
  return inflate_any(data, size, limit, true);
}

namespace {

// A bounded reader over one of a part's byte streams.
struct Reader {
  const uint8_t* p = nullptr;
  const uint8_t* end = nullptr;
  bool varint(uint32_t& v) {
    v = 0;
    for (int shift = 0; shift < 35; shift += 7) {
      if (p == end) return false;
      uint8_t b = *p++;
      if (shift == 28 && (b & 0x70)) return false;  // past 32 bits
      v |= uint32_t(b & 0x7f) << shift;
      if (!(b & 0x80)) return true;
    }
    return false;
  }
};
struct BitReader {
  const uint8_t* p = nullptr;
  uint64_t bits = 0, at = 0;
  bool bit(bool& b) {
    if (at >= bits) return false;
    b = (p[at >> 3] >> (at & 7)) & 1;
    ++at;
    return true;
  }
};

}  // namespace

uint64_t part_byte_limit(uint64_t splits, uint64_t faces) {
  return kPartBytesPerElement * (splits + faces) + kPartBytesConstant;
}

Status decode_vsplit_part(VsplitMesh& mesh, const uint8_t* data, size_t size, uint32_t splits,
                          uint32_t faces) {
  if (size > part_byte_limit(splits, faces))
    return Status::error(std::to_string(size) + " bytes are more than " + std::to_string(splits) +
                             " splits and " + std::to_string(faces) + " faces may take",
                         ErrorKind::kInput);
  Reader head{data, data + size};
  uint32_t len[kVsplitStreams];
  uint64_t total = 0;
  for (uint32_t& l : len) {
    if (!head.varint(l)) return Status::error("stream lengths cut short", ErrorKind::kInput);
    total += l;
  }
  if (total != uint64_t(head.end - head.p))
    return Status::error("stream lengths add up to " + std::to_string(total) + " bytes, " +
                             std::to_string(head.end - head.p) + " follow",
                         ErrorKind::kInput);
  Reader s[kVsplitStreams];
  const uint8_t* at = head.p;
  for (int i = 0; i < kVsplitStreams; ++i) s[i] = {at, at + len[i]}, at += len[i];
  Reader &Z = s[0], &K = s[1], &F = s[2], &E = s[4], &W = s[5], &P = s[6], &N = s[7], &T = s[8],
         &A = s[9];
  BitReader M{s[3].p, uint64_t(len[3]) * 8, 0};
  if (uint64_t(mesh.vertex_count()) + splits > mesh.capacity_vertices_ ||
      uint64_t(mesh.face_count()) + faces > mesh.capacity_faces_)
    return Status::error("more vertices or faces than the mesh holds", ErrorKind::kInput);
  const uint32_t face_goal = mesh.face_count() + faces;
  const bool normals = len[7] > 0;  // an empty N stream: the mesh carries no normals (+Z)
  uint32_t previous = 0;
  std::vector<uint32_t> ring;
  std::vector<uint8_t> moved;
  auto fail = [](uint32_t i, const std::string& what) {
    return Status::error("split " + std::to_string(i) + ": " + what, ErrorKind::kInput);
  };
  for (uint32_t i = 0; i < splits; ++i) {
    uint32_t z, k = 0;
    bool fan_mode;
    if (!Z.varint(z) || !M.bit(fan_mode)) return fail(i, "connectivity cut short");
    if (!fan_mode && !K.varint(k)) return fail(i, "face count cut short");
    int64_t parent = int64_t(previous) + unzigzag(z);
    if (parent < 0 || parent >= int64_t(mesh.vertex_count()))
      return fail(i, "parent " + std::to_string(parent) + " of " +
                         std::to_string(mesh.vertex_count()) + " vertices");
    uint32_t p = uint32_t(parent);
    previous = p;
    uint32_t v = mesh.add_vertex(QuantizedVertex{});
    uint32_t vl = 0, vr = 0;
    if (fan_mode) {
      uint32_t start, count, more = 0;
      if (A.p == A.end) return fail(i, "fan arguments cut short");
      start = *A.p >> 3, count = *A.p++ & 7u;
      if (count == 7 && (!A.varint(more) || more > kFanLimit))
        return fail(i, "fan arguments cut short");
      count += more;
      if (!mesh.fan(p, start, count + 1, moved, vl, vr))
        return fail(i, "parent " + std::to_string(p) + " has no such fan");
      k = 2;
    }
    uint32_t position = 0;
    for (int32_t c = mesh.head[p], prev = -1; c >= 0; ++position) {
      int32_t after = mesh.next[size_t(c)];
      bool take;
      if (fan_mode)
        take = moved[position] != 0;
      else if (!M.bit(take))
        return fail(i, "corner mask cut short");
      if (take)
        mesh.move_corner(p, prev, c, v);
      else
        prev = c;
      c = after;
    }
    if (!fan_mode && k > 0) mesh.ring(p, v, kRingLimit, ring);
    if (uint64_t(mesh.face_count()) + k > face_goal)
      return fail(i, "more than the part's " + std::to_string(faces) + " faces");
    if (fan_mode) {
      mesh.add_face(v, p, vl);
      mesh.add_face(v, vr, p);
      k = 0;
    }
    for (uint32_t f = 0; f < k; ++f) {
      uint32_t code, w;
      if (!F.varint(code)) return fail(i, "face codes cut short");
      uint32_t index = code >> 1;
      if (index < ring.size()) {
        w = ring[index];
      } else if (index == ring.size()) {
        if (!E.varint(w)) return fail(i, "escaped vertices cut short");
        if (w >= v || w == p) return fail(i, "face names vertex " + std::to_string(w));
      } else {
        return fail(
            i, "ring position " + std::to_string(index) + " of " + std::to_string(ring.size()));
      }
      if (code & 1)
        mesh.add_face(v, w, p);
      else
        mesh.add_face(v, p, w);
    }
    QuantizedVertex q = mesh.predict(v, p);
    uint32_t twin[kTwinLimit], twins = mesh.twins(p, twin), pick = 0;
    if (twins > 0 && (!W.varint(pick) || pick > twins))
      return fail(i, "twin index missing or past the candidates");
    uint32_t r[8];
    for (int c = 0; c < 3 && pick == 0; ++c)
      if (!P.varint(r[c])) return fail(i, "positions cut short");
    for (int c = 0; c < 3; ++c)
      if (!normals)
        r[3 + c] = zigzag(int32_t(c == 2 ? 127 : 0) - q.n[c]);
      else if (!N.varint(r[3 + c]))
        return fail(i, "normals cut short");
    for (int c = 0; c < 2; ++c)
      if (!T.varint(r[6 + c])) return fail(i, "texture coordinates cut short");
    for (int c = 0; c < 3; ++c) {
      int64_t x = pick ? mesh.vertices[twin[pick - 1]].p[c] : int64_t(q.p[c]) + unzigzag(r[c]);
      int64_t y = int64_t(q.n[c]) + unzigzag(r[3 + c]);
      if (x < 0 || x > 65535 || y < -128 || y > 127) return fail(i, "attribute out of range");
      q.p[c] = uint16_t(x), q.n[c] = int8_t(y);
    }
    mesh.predict_uv(v, p, q.p, q.t);  // with v's position known, when a face allows
    for (int c = 0; c < 2; ++c) {
      int64_t x = int64_t(q.t[c]) + unzigzag(r[6 + c]);
      if (x < 0 || x > 65535) return fail(i, "attribute out of range");
      q.t[c] = uint16_t(x);
    }
    mesh.vertices[v] = q;
    mesh.add_twin(p, v);
  }
  uint32_t extra;
  if (!K.varint(extra)) return Status::error("extra face count missing", ErrorKind::kInput);
  if (uint64_t(mesh.face_count()) + extra != face_goal)
    return Status::error(std::to_string(face_goal - mesh.face_count()) + " faces expected, " +
                             std::to_string(extra) + " extra faces follow the splits",
                         ErrorKind::kInput);
  for (uint32_t f = 0; f < extra; ++f) {
    uint32_t a, b, c;
    if (!E.varint(a) || !E.varint(b) || !E.varint(c))
      return Status::error("extra faces cut short", ErrorKind::kInput);
    if (a >= mesh.vertex_count() || b >= mesh.vertex_count() || c >= mesh.vertex_count())
      return Status::error("extra face " + std::to_string(f) + " names a vertex not received",
                           ErrorKind::kInput);
    mesh.add_face(a, b, c);
  }
  for (int i = 0; i < kVsplitStreams; ++i)
    if (i != 3 && s[i].p != s[i].end)
      return Status::error("stream " + std::to_string(i) + " has bytes left over",
                           ErrorKind::kInput);
  if ((M.bits - M.at) >= 8)
    return Status::error("corner mask has bytes left over", ErrorKind::kInput);
  return Status::ok();
}

}  // namespace meshmux
