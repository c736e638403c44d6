#include "serve/http.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>

namespace meshmux {

// File name extension → Content-Type.
std::string content_type_for(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  struct Entry {
    const char* ext;
    const char* type;
  };
  static const Entry kTypes[] = {
      {".glb", "model/gltf-binary"},
      {".gltf", "model/gltf+json"},
      {".json", "application/json"},
      {".svg", "image/svg+xml"},
      {".html", "text/html; charset=utf-8"},
      {".htm", "text/html; charset=utf-8"},
      {".js", "text/javascript"},
      {".mjs", "text/javascript"},
      {".css", "text/css"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".jpeg", "image/jpeg"},
      {".mmxp", "application/octet-stream"},
      {".wasm", "application/wasm"},
  };
  for (const Entry& e : kTypes)
    if (ext == e.ext) return e.type;
  return "application/octet-stream";
}

// Whether a request path lies in a folder named NAME-rDIGITS (a release-versioned folder).
bool versioned_path(const std::string& path) {
  for (size_t at = 0; (at = path.find("-r", at)) != std::string::npos; at += 2) {
    size_t end = at + 2;
    while (end < path.size() && std::isdigit(static_cast<unsigned char>(path[end]))) ++end;
    if (end > at + 2 && end < path.size() && path[end] == '/') return true;
  }
  return false;
}

// Whether an Accept-Encoding value lists `coding` without q=0.
bool accepts_encoding(const std::string& header, const std::string& coding) {
  size_t at = 0;
  while (at < header.size()) {
    size_t end = header.find(',', at);
    if (end == std::string::npos) end = header.size();
    std::string item = header.substr(at, end - at);
    at = end + 1;
    const size_t semi = item.find(';');
    std::string name = item.substr(0, semi),
                params = semi == std::string::npos ? "" : item.substr(semi);
    name.erase(0, name.find_first_not_of(" \t"));
    name.erase(name.find_last_not_of(" \t") + 1);
    if (name != coding) continue;
    params.erase(std::remove(params.begin(), params.end(), ' '), params.end());
    const size_t q = params.find("q=");
    return q == std::string::npos || std::strtod(params.c_str() + q + 2, nullptr) > 0;
  }
  return false;
}

std::string hex(uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%llx", static_cast<unsigned long long>(v));
  return buf;
}

// An IMF-fixdate ("Sun, 06 Nov 1994 08:49:37 GMT"), in English whatever the locale.
std::string http_date(time_t t) {
  static const char* const days[] = {"Sun", "Mon", "Tue", "Wed", "Thu", "Fri", "Sat"};
  static const char* const months[] = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                       "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};
  struct tm g;
  gmtime_r(&t, &g);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s, %02d %s %04d %02d:%02d:%02d GMT", days[g.tm_wday], g.tm_mday,
                months[g.tm_mon], g.tm_year + 1900, g.tm_hour, g.tm_min, g.tm_sec);
  return buf;
}

// The time an IMF-fixdate names, or -1.
time_t parse_http_date(const std::string& s) {
  static const char* const months[] = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                       "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};
  char wday[4], mon[4];
  struct tm g {};
  if (std::sscanf(s.c_str(), "%3[A-Za-z], %d %3s %d %d:%d:%d GMT", wday, &g.tm_mday, mon,
                  &g.tm_year, &g.tm_hour, &g.tm_min, &g.tm_sec) != 7)
    return -1;
  g.tm_mon = -1;
  for (int i = 0; i < 12; ++i)
    if (std::strcmp(mon, months[i]) == 0) g.tm_mon = i;
  if (g.tm_mon < 0) return -1;
  g.tm_year -= 1900;
  return timegm(&g);
}

// RFC 9110 §13.1: If-None-Match (a list of entity tags, or *) decides when present; else
// If-Modified-Since, to the second.
bool not_modified(const std::string* if_none_match, const std::string* if_modified_since,
                  const std::string& etag, time_t mtime) {
  if (if_none_match) {
    const std::string& list = *if_none_match;
    if (list.find('*') != std::string::npos) return true;
    // Weak comparison: W/"x" matches "x".
    for (size_t at = list.find('"'); at != std::string::npos; at = list.find('"', at)) {
      const size_t end = list.find('"', at + 1);
      if (end == std::string::npos) break;
      if (list.compare(at, end - at + 1, etag) == 0) return true;
      at = end + 1;
    }
    return false;
  }
  if (if_modified_since) {
    const time_t since = parse_http_date(*if_modified_since);
    return since >= 0 && mtime <= since;
  }
  return false;
}

// One parsed range (first, last; -1 for a missing end) against the file size: the bytes to
// send, clamped to the file, or false when none of them exists.
bool satisfiable(const std::pair<int64_t, int64_t>& r, uint64_t size, uint64_t* first,
                 uint64_t* last) {
  if (size == 0) return false;
  if (r.first < 0) {  // suffix: the last r.second bytes
    if (r.second <= 0) return false;
    uint64_t n = std::min<uint64_t>(uint64_t(r.second), size);
    *first = size - n;
    *last = size - 1;
    return true;
  }
  if (uint64_t(r.first) >= size) return false;
  if (r.second >= 0 && r.second < r.first) return false;
  *first = uint64_t(r.first);
  *last = r.second < 0 ? size - 1 : std::min<uint64_t>(uint64_t(r.second), size - 1);
  return true;
}

std::string entity_tag(uint64_t size, int64_t mtime_seconds, int64_t mtime_nanoseconds,
                       const std::string& encoding) {
  return "\"" + hex(size) + "-" + hex(uint64_t(mtime_seconds)) + "." +
         hex(uint64_t(mtime_nanoseconds)) + (encoding.empty() ? "" : "-" + encoding) + "\"";
}

bool range_is_current(const std::string* if_range, const std::string& etag,
                      const std::string& last_modified) {
  return !if_range || *if_range == etag || *if_range == last_modified;
}

}  // namespace meshmux
