// world.json and layout files (see world_format.h).
#include "stream/world_format.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "core/file_io.h"
#include "core/json_depth.h"

namespace meshmux {

namespace {

using Json = nlohmann::json;
constexpr int kMaxDepth = 16;     // world.json nests 4 deep; layouts 4
constexpr size_t kMaxName = 256;  // bytes of a package name
constexpr size_t kMaxUrl = 2048;  // bytes of a URL

Status fail(const std::string& file, const std::string& what) {
  return Status::error(file + ": " + what, ErrorKind::kInput);
}

// Shortest text that reads back to the same double (up to 17 significant digits).
std::string number(double v) {
  if (v == 0) v = 0;  // −0 reads back as 0
  char buf[32];
  for (int digits = 6; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

template <size_t N>
std::string numbers(const std::array<double, N>& a) {
  std::string out = "[";
  for (size_t i = 0; i < N; ++i) out += (i ? ", " : "") + number(a[i]);
  return out + "]";
}

// N finite numbers of magnitude ≤ kWorldMaxCoordinate.
template <size_t N>
Status read_numbers(const Json& j, const std::string& file, const std::string& where,
                    std::array<double, N>* out) {
  if (!j.is_array() || j.size() != N)
    return fail(file, where + " is not " + std::to_string(N) + " numbers");
  for (size_t i = 0; i < N; ++i) {
    if (!j[i].is_number()) return fail(file, where + "[" + std::to_string(i) + "] is not a number");
    const double v = j[i].get<double>();
    if (!std::isfinite(v) || std::abs(v) > kWorldMaxCoordinate)
      return fail(file, where + "[" + std::to_string(i) + "] is not a finite coordinate");
    (*out)[i] = v;
  }
  return Status::ok();
}

// The determinant of the matrix's 3x3 part (column-major).
double det3(const std::array<double, 16>& m) {
  return m[0] * (m[5] * m[10] - m[9] * m[6]) - m[4] * (m[1] * m[10] - m[9] * m[2]) +
         m[8] * (m[1] * m[6] - m[5] * m[2]);
}

// An affine placement: the last row 0 0 0 1, the 3x3 part invertible.
Status check_matrix(const std::array<double, 16>& m, const std::string& file,
                    const std::string& where) {
  if (m[3] != 0 || m[7] != 0 || m[11] != 0 || m[15] != 1)
    return fail(file, where + " is not affine (its last row must be 0 0 0 1)");
  if (!world_matrix_is_affine(m)) return fail(file, where + " is singular");
  return Status::ok();
}

// j[key], an array of at most `limit` entries.
Result<const Json*> array_field(const Json& j, const char* key, size_t limit,
                                const std::string& file) {
  auto it = j.find(key);
  if (it == j.end() || !it->is_array())
    return fail(file, std::string("\"") + key + "\" is missing or not an array");
  if (it->size() > limit)
    return fail(
        file, std::to_string(it->size()) + " " + key + " (at most " + std::to_string(limit) + ")");
  return &*it;
}

Result<Json> parse_json(const std::string& text, const std::string& file, size_t max_bytes) {
  if (text.empty()) return fail(file, "empty file");
  if (text.size() > max_bytes)
    return fail(file, "larger than " + std::to_string(max_bytes >> 20) + " MB");
  if (json_depth(reinterpret_cast<const uint8_t*>(text.data()), text.size(), kMaxDepth) > kMaxDepth)
    return fail(file, "nested deeper than " + std::to_string(kMaxDepth) + " levels");
  Json j = Json::parse(text, nullptr, false);
  if (j.is_discarded()) return fail(file, "not valid JSON");
  if (!j.is_object()) return fail(file, "not a JSON object");
  return j;
}

std::array<double, 16> scale_rotate_translate(const std::array<double, 3>& s, double degrees,
                                              const std::array<double, 3>& t) {
  const double r = degrees * M_PI / 180.0, c = std::cos(r), sn = std::sin(r);
  // Column-major: x' = R_y · S · x + t.
  return {c * s[0],  0, -sn * s[0], 0, 0,    s[1], 0,    0,
          sn * s[2], 0, c * s[2],   0, t[0], t[1], t[2], 1};
}

}  // namespace

bool world_matrix_is_affine(const std::array<double, 16>& m) {
  if (m[3] != 0 || m[7] != 0 || m[11] != 0 || m[15] != 1) return false;
  const double d = det3(m);
  return std::abs(d) > 0 && std::isfinite(d);
}

std::array<double, 16> identity_matrix() {
  return {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
}

bool world_url_is_inside(const std::string& url) {
  if (url.empty() || url.size() > kMaxUrl || url[0] == '/') return false;
  // Spaces too: URL parsers strip them at the ends (" //host/x" would leave the site).
  for (unsigned char c : url)
    if (c <= 0x20 || c == 0x7F || c == '\\' || c == '?' || c == '#') return false;
  const size_t colon = url.find(':'), slash = url.find('/');
  if (colon != std::string::npos && (slash == std::string::npos || colon < slash))
    return false;  // a scheme ("https:", "data:", "javascript:")
  size_t start = 0;
  while (start <= url.size()) {
    size_t end = url.find('/', start);
    if (end == std::string::npos) end = url.size();
    std::string segment = url.substr(start, end - start);
    for (char& c : segment) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (segment == ".." || segment == "%2e%2e" || segment == ".%2e" || segment == "%2e.")
      return false;
    start = end + 1;
  }
  return true;
}

std::string world_json(const World& world) {
  std::string out =
      "{\n  \"meshmux_world\": " + std::to_string(kWorldVersion) + ",\n  \"packages\": [";
  for (size_t i = 0; i < world.packages.size(); ++i) {
    const WorldPackage& p = world.packages[i];
    out += i ? ",\n    " : "\n    ";
    out += "{\"name\": " + Json(p.name).dump() + ", \"url\": " + Json(p.url).dump() +
           ", \"bounds\": " + numbers(p.bounds) + ", \"bytes\": " + std::to_string(p.bytes);
    if (p.head_bytes > 0) out += ", \"head_bytes\": " + std::to_string(p.head_bytes);
    out += "}";
  }
  out += world.packages.empty() ? "],\n  \"placements\": [" : "\n  ],\n  \"placements\": [";
  for (size_t i = 0; i < world.placements.size(); ++i) {
    const WorldPlacement& p = world.placements[i];
    out += i ? ",\n    " : "\n    ";
    out +=
        "{\"package\": " + std::to_string(p.package) + ", \"matrix\": " + numbers(p.matrix) + "}";
  }
  out += world.placements.empty() ? "]\n}\n" : "\n  ]\n}\n";
  return out;
}

Result<World> parse_world(const std::string& text, const std::string& file,
                          const WorldLimits& limits) {
  auto parsed = parse_json(text, file, limits.max_bytes);
  if (!parsed.ok()) return parsed.status();
  const Json& j = *parsed;
  auto version = j.find("meshmux_world");
  if (version == j.end() || !version->is_number_integer())
    return fail(file, "not a meshmux world (no \"meshmux_world\" version)");
  if (version->get<int64_t>() != kWorldVersion)
    return fail(file, "world version " + version->dump() + " (this meshmux reads version " +
                          std::to_string(kWorldVersion) + ")");
  auto packages_field = array_field(j, "packages", limits.max_packages, file);
  if (!packages_field.ok()) return packages_field.status();
  const Json* packages = *packages_field;
  World world;
  for (size_t i = 0; i < packages->size(); ++i) {
    const Json& e = (*packages)[i];
    const std::string where = "packages[" + std::to_string(i) + "]";
    if (!e.is_object()) return fail(file, where + " is not an object");
    WorldPackage p;
    auto url = e.find("url");
    if (url == e.end() || !url->is_string() || url->get<std::string>().empty())
      return fail(file, where + ".url is missing or not a string");
    p.url = url->get<std::string>();
    if (p.url.size() > kMaxUrl) return fail(file, where + ".url is longer than 2048 bytes");
    if (!limits.allow_external_urls && !world_url_is_inside(p.url))
      return fail(file, where + ".url " + Json(p.url).dump() + " leaves the world's folder");
    if (auto name = e.find("name"); name != e.end()) {
      if (!name->is_string() || name->get<std::string>().size() > kMaxName)
        return fail(file, where + ".name is not a string of at most 256 bytes");
      p.name = name->get<std::string>();
    } else {
      p.name = p.url;
    }
    auto bounds = e.find("bounds");
    if (bounds == e.end()) return fail(file, where + ".bounds is missing");
    if (Status s = read_numbers(*bounds, file, where + ".bounds", &p.bounds); !s) return s;
    for (int a = 0; a < 3; ++a)
      if (p.bounds[size_t(a)] > p.bounds[size_t(a) + 3])
        return fail(file, where + ".bounds has a minimum above its maximum");
    if (auto bytes = e.find("bytes"); bytes != e.end()) {
      if (!bytes->is_number_unsigned() || bytes->get<uint64_t>() > (uint64_t(1) << 53))
        return fail(file, where + ".bytes is not a byte count");
      p.bytes = bytes->get<uint64_t>();
    }
    if (auto head = e.find("head_bytes"); head != e.end()) {
      if (!head->is_number_unsigned() || head->get<uint64_t>() > (uint64_t(1) << 53))
        return fail(file, where + ".head_bytes is not a byte count");
      p.head_bytes = head->get<uint64_t>();
      if (p.bytes > 0 && p.head_bytes > p.bytes)
        return fail(file, where + ".head_bytes is more than the package's bytes");
    }
    world.packages.push_back(std::move(p));
  }
  auto placements_field = array_field(j, "placements", limits.max_placements, file);
  if (!placements_field.ok()) return placements_field.status();
  const Json* placements = *placements_field;
  for (size_t i = 0; i < placements->size(); ++i) {
    const Json& e = (*placements)[i];
    const std::string where = "placements[" + std::to_string(i) + "]";
    if (!e.is_object()) return fail(file, where + " is not an object");
    auto package = e.find("package");
    if (package == e.end() || !package->is_number_unsigned() ||
        package->get<uint64_t>() >= world.packages.size())
      return fail(file, where + ".package is not the index of a package (0 to " +
                            std::to_string(world.packages.size()) + " - 1)");
    WorldPlacement p;
    p.package = uint32_t(package->get<uint64_t>());
    auto matrix = e.find("matrix");
    if (matrix == e.end()) return fail(file, where + ".matrix is missing");
    if (Status s = read_numbers(*matrix, file, where + ".matrix", &p.matrix); !s) return s;
    if (Status s = check_matrix(p.matrix, file, where + ".matrix"); !s) return s;
    world.placements.push_back(p);
  }
  return world;
}

Result<std::vector<LayoutEntry>> read_layout(const std::string& path, const WorldLimits& limits) {
  const std::string file = base_name(path);
  auto bytes = read_whole_file(path, limits.max_bytes);
  if (!bytes.ok()) return bytes.status();
  auto parsed = parse_json(std::string(bytes->begin(), bytes->end()), file, limits.max_bytes);
  if (!parsed.ok()) return parsed.status();
  auto placements_field = array_field(*parsed, "placements", limits.max_placements, file);
  if (!placements_field.ok()) return placements_field.status();
  const Json* placements = *placements_field;
  std::vector<LayoutEntry> out;
  for (size_t i = 0; i < placements->size(); ++i) {
    const Json& e = (*placements)[i];
    const std::string where = "placements[" + std::to_string(i) + "]";
    if (!e.is_object()) return fail(file, where + " is not an object");
    LayoutEntry entry;
    auto name = e.find("name");
    if (name == e.end() || !name->is_string() || name->get<std::string>().empty() ||
        name->get<std::string>().size() > kMaxName)
      return fail(file, where + ".name is missing or not a name");
    entry.name = name->get<std::string>();
    const bool has_matrix = e.contains("matrix");
    if (has_matrix &&
        (e.contains("translation") || e.contains("scale") || e.contains("rotation_y_degrees")))
      return fail(file,
                  where + " gives a matrix and translation, scale or rotation: one or the other");
    if (has_matrix) {
      if (Status s = read_numbers(e["matrix"], file, where + ".matrix", &entry.matrix); !s)
        return s;
    } else {
      std::array<double, 3> t{0, 0, 0}, s{1, 1, 1};
      std::array<double, 1> r{0};
      if (e.contains("translation"))
        if (Status st = read_numbers(e["translation"], file, where + ".translation", &t); !st)
          return st;
      if (e.contains("scale")) {
        const Json& sj = e["scale"];
        if (sj.is_number()) {
          std::array<double, 1> one{};
          if (Status st = read_numbers(Json::array({sj}), file, where + ".scale", &one); !st)
            return st;
          s = {one[0], one[0], one[0]};
        } else if (Status st = read_numbers(sj, file, where + ".scale", &s); !st) {
          return st;
        }
      }
      if (e.contains("rotation_y_degrees"))
        if (Status st = read_numbers(Json::array({e["rotation_y_degrees"]}), file,
                                     where + ".rotation_y_degrees", &r);
            !st)
          return st;
      entry.matrix = scale_rotate_translate(s, r[0], t);
    }
    if (Status s = check_matrix(entry.matrix, file, where); !s) return s;
    out.push_back(std::move(entry));
  }
  return out;
}

}  // namespace meshmux
