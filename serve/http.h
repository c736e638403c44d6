// The HTTP rules of meshmux serve, as plain functions on strings and numbers (no server, no
// sockets), so they are tested in-process: content types, precompressed siblings chosen by
// Accept-Encoding, validators and conditional requests (RFC 9110 §8.8, §13.1), byte ranges
// (RFC 9110 §14), and which paths name a release-versioned, cache-forever folder.
#pragma once

#include <cstdint>
#include <ctime>
#include <string>
#include <utility>

namespace meshmux {

// The Content-Type for a file name's extension (".glb" → "model/gltf-binary"; unknown:
// "application/octet-stream"). Case-insensitive.
std::string content_type_for(const std::string& path);

// Whether a request path lies in a folder named NAME-rDIGITS ("/viewer/three-r187/x.js"): such
// a folder never changes under its name, so it is served "immutable".
bool versioned_path(const std::string& path);

// Whether an Accept-Encoding value lists `coding` ("br", "gzip") without q=0.
bool accepts_encoding(const std::string& header, const std::string& coding);

// Lower-case hexadecimal, no leading zeros.
std::string hex(uint64_t v);

// An IMF-fixdate ("Sun, 06 Nov 1994 08:49:37 GMT"), in English whatever the locale, and the
// time one names (-1 when it is not one).
std::string http_date(time_t t);
time_t parse_http_date(const std::string& s);

// The ETag of the bytes sent: "SIZE-MTIME_S.MTIME_NS" in hex, "-ENCODING" for a precompressed
// sibling (quoted).
std::string entity_tag(uint64_t size, int64_t mtime_seconds, int64_t mtime_nanoseconds,
                       const std::string& encoding);

// RFC 9110 §13.1: If-None-Match (a list of entity tags, or *; weak tags match) decides when
// given; else If-Modified-Since, to the second. nullptr: the header is absent. True: answer 304.
bool not_modified(const std::string* if_none_match, const std::string* if_modified_since,
                  const std::string& etag, time_t mtime);

// Whether a Range request may be answered with a part: no If-Range, or one naming the current
// ETag or Last-Modified exactly (else the whole file is sent).
bool range_is_current(const std::string* if_range, const std::string& etag,
                      const std::string& last_modified);

// One parsed range (first, last; first -1: a suffix of `last` bytes; last -1: to the end)
// against the file size: the bytes to send, [*first, *last], clamped to the file; false when
// none of them exists (answer 416).
bool satisfiable(const std::pair<int64_t, int64_t>& r, uint64_t size, uint64_t* first,
                 uint64_t* last);

}  // namespace meshmux
