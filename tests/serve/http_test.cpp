// serve/http.h in-process: the rules a browser's caching and range requests depend on, each on
// the header values real clients send.
#include "serve/http.h"

#include <gtest/gtest.h>

#include <string>

namespace meshmux {
namespace {

// A package is fetched by Range requests: the bytes named must exist, clamped to the file, and
// a range wholly past the end is 416 (cpp-httplib's own handling got both wrong).
TEST(HttpRules, RangesAreClampedOrUnsatisfiable) {
  uint64_t first = 0, last = 0;
  ASSERT_TRUE(satisfiable({0, 99}, 1000, &first, &last));
  EXPECT_EQ(first, 0u);
  EXPECT_EQ(last, 99u);
  ASSERT_TRUE(satisfiable({900, 5000}, 1000, &first, &last));  // runs past the end: clamped
  EXPECT_EQ(last, 999u);
  ASSERT_TRUE(satisfiable({500, -1}, 1000, &first, &last));  // "bytes=500-"
  EXPECT_EQ(first, 500u);
  EXPECT_EQ(last, 999u);
  ASSERT_TRUE(satisfiable({-1, 100}, 1000, &first, &last));  // "bytes=-100": the last 100
  EXPECT_EQ(first, 900u);
  EXPECT_EQ(last, 999u);
  ASSERT_TRUE(satisfiable({-1, 5000}, 1000, &first, &last));  // a suffix longer than the file
  EXPECT_EQ(first, 0u);
  EXPECT_FALSE(satisfiable({1000, 1200}, 1000, &first, &last));  // starts at the end
  EXPECT_FALSE(satisfiable({50, 10}, 1000, &first, &last));      // backwards
  EXPECT_FALSE(satisfiable({-1, 0}, 1000, &first, &last));       // an empty suffix
  EXPECT_FALSE(satisfiable({0, 0}, 0, &first, &last));           // an empty file has no byte
}

// A repeat visit must cost headers only: the ETag a client holds, weak or in a list, gives
// 304; a changed file does not; If-None-Match decides over If-Modified-Since.
TEST(HttpRules, ValidatorsAnswerNotModified) {
  const std::string etag = entity_tag(1234, 1700000000, 5, "");
  EXPECT_EQ(etag, "\"4d2-6553f100.5\"");
  EXPECT_EQ(entity_tag(1234, 1700000000, 5, "br"), "\"4d2-6553f100.5-br\"");
  const std::string list = "\"other\", W/" + etag, star = "*", stale = "\"4d2-6553f100.6\"";
  EXPECT_TRUE(not_modified(&etag, nullptr, etag, 1700000000));
  EXPECT_TRUE(not_modified(&list, nullptr, etag, 1700000000));
  EXPECT_TRUE(not_modified(&star, nullptr, etag, 1700000000));
  EXPECT_FALSE(not_modified(&stale, nullptr, etag, 1700000000));
  const std::string date = http_date(1700000000);
  EXPECT_EQ(date, "Tue, 14 Nov 2023 22:13:20 GMT");
  EXPECT_EQ(parse_http_date(date), 1700000000);
  EXPECT_TRUE(not_modified(nullptr, &date, etag, 1700000000));
  EXPECT_FALSE(not_modified(nullptr, &date, etag, 1700000001));  // modified a second later
  EXPECT_FALSE(not_modified(&stale, &date, etag, 1700000000));   // the ETag decides
  const std::string garbage = "yesterday";
  EXPECT_FALSE(not_modified(nullptr, &garbage, etag, 0));
  EXPECT_FALSE(not_modified(nullptr, nullptr, etag, 0));
}

// If-Range: a part is sent only of the version the client already holds.
TEST(HttpRules, IfRangeNamesTheCurrentVersion) {
  const std::string etag = "\"a-b.c\"", modified = http_date(1700000000), other = "\"x\"";
  EXPECT_TRUE(range_is_current(nullptr, etag, modified));
  EXPECT_TRUE(range_is_current(&etag, etag, modified));
  EXPECT_TRUE(range_is_current(&modified, etag, modified));
  EXPECT_FALSE(range_is_current(&other, etag, modified));
}

// Precompressed siblings are chosen by Accept-Encoding, never when the client refuses them.
TEST(HttpRules, AcceptEncodingHonoursQZero) {
  EXPECT_TRUE(accepts_encoding("gzip, deflate, br", "br"));
  EXPECT_TRUE(accepts_encoding("br;q=0.5", "br"));
  EXPECT_FALSE(accepts_encoding("br;q=0, gzip", "br"));
  EXPECT_FALSE(accepts_encoding("br; q=0.0", "br"));
  EXPECT_TRUE(accepts_encoding("br;q=0, gzip", "gzip"));
  EXPECT_FALSE(accepts_encoding("gzip", "br"));
  EXPECT_FALSE(accepts_encoding("", "gzip"));
}

// three.js lives under a release-named folder and may be cached for good; nothing else.
TEST(HttpRules, OnlyReleaseFoldersAreImmutable) {
  EXPECT_TRUE(versioned_path("/viewer/three-r187/three.module.js"));
  EXPECT_FALSE(versioned_path("/viewer/three-r187"));  // the folder name alone is no file in it
  EXPECT_FALSE(versioned_path("/viewer/three-rc/x.js"));
  EXPECT_FALSE(versioned_path("/model.mmxp"));
}

// Content types the viewer's loaders check.
TEST(HttpRules, ContentTypesByExtension) {
  EXPECT_EQ(content_type_for("/a/model.GLB"), "model/gltf-binary");
  EXPECT_EQ(content_type_for("index.html"), "text/html; charset=utf-8");
  EXPECT_EQ(content_type_for("x.wasm"), "application/wasm");
  EXPECT_EQ(content_type_for("x.mjs"), "text/javascript");
  EXPECT_EQ(content_type_for("noextension"), "application/octet-stream");
}

}  // namespace
}  // namespace meshmux
