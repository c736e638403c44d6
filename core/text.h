// Small text helpers the commands share: byte counts for people, escaping for HTML pages.
#pragma once

#include <cstdint>
#include <string>

namespace meshmux {

// "512 B", "12.3 kB", "4.56 MB" (decimal units, as the viewer shows them).
std::string human_bytes(uint64_t bytes);

// &, <, >, " and ' as entities: safe in element text and quoted attributes.
std::string html_escape(const std::string& s);

// Everything but RFC 3986's unreserved characters percent-encoded: one path segment of a link.
std::string url_escape(const std::string& s);

// %XX escapes decoded (RFC 3986; glTF 2.0 §2.8 URIs, world.json URLs); a '%' not followed by two
// hex digits stays as it is.
std::string percent_decode(const std::string& s);

}  // namespace meshmux
