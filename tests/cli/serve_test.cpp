// End-to-end tests of `meshmux serve`: the binary runs as a child process on a free port and
// is queried with httplib's client (file bytes and types, Range requests, path traversal,
// CORS, HEAD, index.html, exit codes).
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "test_util.h"

namespace meshmux {
namespace {

using testing::run_meshmux;
using testing::TempDir;

// A `meshmux serve` child process. start() waits (with a timeout) for the line it prints on
// stdout and reads the port from it; the destructor stops it with SIGTERM.
class ServerProcess {
 public:
  ~ServerProcess() { stop(); }

  // False (with `error` set) when the server did not announce itself in time.
  bool start(const std::vector<std::string>& args, const std::string& stderr_file) {
    int fds[2];
    if (::pipe(fds) != 0) return fail("pipe failed");
    pid_ = ::fork();
    if (pid_ < 0) return fail("fork failed");
    if (pid_ == 0) {
      ::dup2(fds[1], 1);
      int err = ::open(stderr_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (err >= 0) ::dup2(err, 2);
      ::close(fds[0]);
      ::close(fds[1]);
      std::vector<std::string> all{MESHMUX_BINARY};
      all.insert(all.end(), args.begin(), args.end());
      std::vector<char*> argv;
      for (auto& a : all) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    ::close(fds[1]);
    out_fd_ = fds[0];
    auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (line_.find('\n') == std::string::npos) {
      int left = int(std::chrono::duration_cast<std::chrono::milliseconds>(
                         deadline - std::chrono::steady_clock::now())
                         .count());
      if (left <= 0) return fail("timed out waiting for the server's first line");
      pollfd p{out_fd_, POLLIN, 0};
      if (::poll(&p, 1, left) <= 0) continue;
      char buf[256];
      ssize_t n = ::read(out_fd_, buf, sizeof buf);
      if (n <= 0) return fail("the server exited before listening; stdout: " + line_);
      line_.append(buf, size_t(n));
    }
    line_ = line_.substr(0, line_.find('\n'));
    // "meshmux: serving DIR at http://HOST:PORT/ (Ctrl-C to stop)"
    size_t url = line_.rfind("http://");
    size_t slash = url == std::string::npos ? url : line_.find('/', url + 7);
    size_t colon = slash == std::string::npos ? slash : line_.rfind(':', slash);
    if (colon == std::string::npos || colon < url) return fail("no port in: " + line_);
    port_ = std::atoi(line_.substr(colon + 1, slash - colon - 1).c_str());
    return port_ > 0 ? true : fail("bad port in: " + line_);
  }

  // SIGTERM and wait; returns the exit status (128+N when killed by signal N), -1 if not running.
  int stop() {
    if (pid_ <= 0) return -1;
    ::kill(pid_, SIGTERM);
    int status = 0;
    auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    pid_t r;
    while ((r = ::waitpid(pid_, &status, WNOHANG)) == 0 &&
           std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (r == 0) {  // did not stop in time
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, &status, 0);
    }
    pid_ = -1;
    if (out_fd_ >= 0) ::close(out_fd_);
    out_fd_ = -1;
    if (r == 0) return 128 + SIGKILL;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }

  int port() const { return port_; }
  const std::string& line() const { return line_; }
  std::string error;

 private:
  bool fail(const std::string& message) {
    error = message;
    return false;
  }
  pid_t pid_ = -1;
  int out_fd_ = -1;
  int port_ = 0;
  std::string line_;
};

std::string pattern_bytes(size_t n) {
  std::string s(n, '\0');
  for (size_t i = 0; i < n; ++i) s[i] = char((i * 131 + 7) % 251);
  return s;
}

// The served folder is <tmp>/site; <tmp>/secret lies outside it and must never be served.
class Serve : public ::testing::Test {
 protected:
  static constexpr const char* kSecret = "TOP-SECRET-CONTENT-6d1f";

  void SetUp() override {
    site_ = tmp_.file("site");
    std::filesystem::create_directories(site_ + "/sub");
    model_ = pattern_bytes(1000);
    testing::write_text(site_ + "/model.glb", model_);
    testing::write_text(site_ + "/report.json", "{\"ok\": true}\n");
    testing::write_text(site_ + "/sub/rd.svg", "<svg xmlns=\"http://www.w3.org/2000/svg\"/>\n");
    testing::write_text(tmp_.file("secret"), kSecret);
  }

  void start(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args{"serve", site_, "--port", "0"};
    args.insert(args.end(), extra.begin(), extra.end());
    ASSERT_TRUE(server_.start(args, tmp_.file("serve.log"))) << server_.error << "\n" << log();
  }

  httplib::Client client() {
    httplib::Client c("127.0.0.1", server_.port());
    c.set_url_encode(false);  // send the paths exactly as written
    c.set_connection_timeout(5);
    c.set_read_timeout(10);
    return c;
  }

  std::string log() const {
    auto bytes = testing::read_file(tmp_.file("serve.log"));
    return std::string(bytes.begin(), bytes.end());
  }

  TempDir tmp_;
  std::string site_, model_;
  ServerProcess server_;
};

TEST_F(Serve, PrintsTheUrlWithTheChosenPort) {
  start();
  std::string canonical = std::filesystem::canonical(site_).string();
  EXPECT_EQ(server_.line(), "meshmux: serving " + canonical + " at http://127.0.0.1:" +
                                std::to_string(server_.port()) + "/ (Ctrl-C to stop)");
}

TEST_F(Serve, FullGetReturnsTheFileWithItsContentType) {
  start();
  auto c = client();
  auto r = c.Get("/model.glb");
  ASSERT_TRUE(r) << httplib::to_string(r.error());
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->body, model_);
  EXPECT_EQ(r->get_header_value("Content-Type"), "model/gltf-binary");
  EXPECT_EQ(r->get_header_value("Accept-Ranges"), "bytes");

  r = c.Get("/report.json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/json");
  r = c.Get("/sub/rd.svg");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "image/svg+xml");
  r = c.Get("/missing.glb");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
}

TEST_F(Serve, RangeReturnsExactlyTheRequestedBytes) {
  start();
  auto c = client();
  auto r = c.Get("/model.glb", {{"Range", "bytes=10-99"}});
  ASSERT_TRUE(r) << httplib::to_string(r.error());
  EXPECT_EQ(r->status, 206);
  EXPECT_EQ(r->get_header_value("Content-Range"), "bytes 10-99/1000");
  EXPECT_EQ(r->body.size(), 90u);
  EXPECT_EQ(r->body, model_.substr(10, 90));
  EXPECT_EQ(r->get_header_value("Content-Type"), "model/gltf-binary");

  // Open-ended, and past the end (clamped to the file).
  r = c.Get("/model.glb", {{"Range", "bytes=990-"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 206);
  EXPECT_EQ(r->get_header_value("Content-Range"), "bytes 990-999/1000");
  EXPECT_EQ(r->body, model_.substr(990));
  r = c.Get("/model.glb", {{"Range", "bytes=900-5000"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 206);
  EXPECT_EQ(r->get_header_value("Content-Range"), "bytes 900-999/1000");
  EXPECT_EQ(r->body, model_.substr(900));
}

// convert writes the viewer's files beside their brotli and gzip forms; a request that accepts one
// gets it with Content-Encoding (the bytes as stored, not recompressed), ranges always get the
// identity bytes, and caches are told the answer varies with Accept-Encoding.
TEST_F(Serve, PrecompressedSiblingIsSentWhenAccepted) {
  testing::write_text(site_ + "/viewer.js", "plain bytes");
  testing::write_text(site_ + "/viewer.js.br", "brotli bytes");
  testing::write_text(site_ + "/viewer.js.gz", "gzip bytes");
  start();
  auto c = client();
  c.set_decompress(false);  // the bytes as sent
  struct Case {
    const char* accept;
    const char* body;
    const char* encoding;
  };
  for (Case k : {Case{"gzip, deflate, br", "brotli bytes", "br"},
                 Case{"gzip", "gzip bytes", "gzip"}, Case{"br;q=0, gzip", "gzip bytes", "gzip"},
                 Case{"identity", "plain bytes", ""}, Case{"", "plain bytes", ""}}) {
    httplib::Headers h;
    if (*k.accept) h.insert({"Accept-Encoding", k.accept});
    auto r = c.Get("/viewer.js", h);
    ASSERT_TRUE(r) << httplib::to_string(r.error());
    EXPECT_EQ(r->status, 200) << k.accept;
    EXPECT_EQ(r->body, k.body) << k.accept;
    EXPECT_EQ(r->get_header_value("Content-Encoding"), k.encoding) << k.accept;
    EXPECT_EQ(r->get_header_value("Content-Type"), "text/javascript") << k.accept;
    EXPECT_EQ(r->get_header_value("Vary"), "Accept-Encoding") << k.accept;
  }
  auto r = c.Get("/viewer.js", {{"Accept-Encoding", "br"}, {"Range", "bytes=0-4"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 206);
  EXPECT_EQ(r->body, "plain");
  EXPECT_EQ(r->get_header_value("Content-Encoding"), "");
  // A file without siblings says nothing about encodings.
  r = c.Get("/model.glb", {{"Accept-Encoding", "br"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->body, model_);
  EXPECT_FALSE(r->has_header("Vary"));
}

// A release-versioned folder (viewer/three-r187/, as convert writes three.js) never changes
// under its name: immutable, cached for a year. Everything else is revalidated.
TEST_F(Serve, VersionedFolderIsImmutableTheRestRevalidated) {
  std::filesystem::create_directories(site_ + "/viewer/three-r187");
  testing::write_text(site_ + "/viewer/three-r187/three.core.js", "core");
  testing::write_text(site_ + "/viewer/meshmux.js", "ours");
  start();
  auto c = client();
  auto r = c.Get("/viewer/three-r187/three.core.js");
  ASSERT_TRUE(r) << httplib::to_string(r.error());
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value_count("Cache-Control"), 1u);
  EXPECT_EQ(r->get_header_value("Cache-Control"), "public, max-age=31536000, immutable");
  for (const char* path : {"/viewer/meshmux.js", "/model.glb"}) {
    r = c.Get(path);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->get_header_value("Cache-Control"), "no-cache") << path;
  }
}

// Validators: a repeat visit revalidates with If-None-Match / If-Modified-Since and gets 304
// with no body; If-Range keeps a range only for the same version.
TEST_F(Serve, ValidatorsAnswerConditionalRequestsWith304) {
  start();
  auto c = client();
  auto r = c.Get("/model.glb");
  ASSERT_TRUE(r) << httplib::to_string(r.error());
  const std::string etag = r->get_header_value("ETag"),
                    modified = r->get_header_value("Last-Modified");
  ASSERT_FALSE(etag.empty());
  EXPECT_EQ(etag.front(), '"');
  EXPECT_NE(modified.find(" GMT"), std::string::npos) << modified;
  r = c.Get("/model.glb", {{"If-None-Match", etag}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 304);
  EXPECT_TRUE(r->body.empty());
  EXPECT_EQ(r->get_header_value("ETag"), etag);
  r = c.Get("/model.glb", {{"If-None-Match", "\"other\", W/" + etag}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 304);
  r = c.Get("/model.glb", {{"If-None-Match", "\"other\""}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->body, model_);
  r = c.Get("/model.glb", {{"If-Modified-Since", modified}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 304);
  r = c.Get("/model.glb", {{"If-Modified-Since", "Thu, 01 Jan 1970 00:00:00 GMT"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  r = c.Get("/model.glb", {{"If-Range", etag}, {"Range", "bytes=0-9"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 206);
  EXPECT_EQ(r->body, model_.substr(0, 10));
  r = c.Get("/model.glb", {{"If-Range", "\"older\""}, {"Range", "bytes=0-9"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->body, model_);
  // Another version of the file, another tag.
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  testing::write_text(site_ + "/model.glb", model_ + "!");
  r = c.Get("/model.glb", {{"If-None-Match", etag}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_NE(r->get_header_value("ETag"), etag);
}

TEST_F(Serve, SuffixRangeReturnsTheLastBytes) {
  start();
  auto c = client();
  auto r = c.Get("/model.glb", {{"Range", "bytes=-16"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 206);
  EXPECT_EQ(r->get_header_value("Content-Range"), "bytes 984-999/1000");
  EXPECT_EQ(r->body, model_.substr(984));
}

TEST_F(Serve, UnsatisfiableRangeIs416) {
  start();
  auto c = client();
  for (const char* range : {"bytes=1000-", "bytes=5000-6000", "bytes=-0"}) {
    auto r = c.Get("/model.glb", {{"Range", range}});
    ASSERT_TRUE(r) << range;
    EXPECT_EQ(r->status, 416) << range;
    EXPECT_EQ(r->get_header_value("Content-Range"), "bytes */1000") << range;
    EXPECT_TRUE(r->body.empty()) << range;
  }
}

TEST_F(Serve, TraversalIsRefused) {
  start();
  auto c = client();
  for (const char* path :
       {"/../secret", "/../etc/passwd", "/%2e%2e/secret", "/%2e%2e/%2e%2e/etc/passwd",
        "/%252e%252e/secret", "/..%2fsecret", "/%2e%2e%2fsecret", "//etc/passwd", "/%2fetc/passwd",
        "/sub/../../secret", "/..\\secret", "/%5c..%5csecret", "/a%00b"}) {
    auto r = c.Get(path);
    if (!r) continue;  // the connection was refused outright: nothing served
    EXPECT_TRUE(r->status == 403 || r->status == 404) << path << " -> " << r->status;
    EXPECT_EQ(r->body.find(kSecret), std::string::npos) << path;
    EXPECT_EQ(r->body.find("root:"), std::string::npos) << path;
  }
}

TEST_F(Serve, SymlinkOutOfTheFolderIsRefused) {
  std::filesystem::create_symlink(tmp_.file("secret"), site_ + "/link");
  start();
  auto c = client();
  auto r = c.Get("/link");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 403);
  EXPECT_EQ(r->body.find(kSecret), std::string::npos);
}

// CORS only when asked for (--cors): by default another site's page cannot read the files.
TEST_F(Serve, CorsOnlyWhenAskedFor) {
  start();
  auto r = client().Get("/model.glb", {{"Origin", "http://example.com"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_FALSE(r->has_header("Access-Control-Allow-Origin"));
}

// Dotfiles (.env, .git/config) were served; they are refused like paths outside the folder.
TEST_F(Serve, DotfilesAreRefused) {
  testing::write_text(site_ + "/.env", kSecret);
  std::filesystem::create_directories(site_ + "/.git");
  testing::write_text(site_ + "/.git/config", kSecret);
  start();
  auto c = client();
  for (const char* path : {"/.env", "/.git/config", "/sub/../.env", "/%2Eenv"}) {
    auto r = c.Get(path);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 403) << path;
    EXPECT_EQ(r->body.find(kSecret), std::string::npos) << path;
  }
}

// Binding beyond loopback exposes the folder to other machines: said on stderr.
TEST_F(Serve, WarnsWhenListeningBeyondLoopback) {
  start({"--host", "0.0.0.0"});
  EXPECT_NE(log().find("beyond loopback"), std::string::npos) << log();
}

// A TCP connection to the server on loopback (blocking), or -1.
int connect_loopback(int port) {
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// 8 slow-header connections (httplib's worker count on 2 cores) once blocked every other client.
// Under 200 idle connections and 50 that trickle a header byte every 0.5 s, an ordinary request is
// still answered within a second, twice.
TEST_F(Serve, OrdinaryRequestAnsweredUnderSlowAndIdleConnections) {
  start({"-q"});
  std::vector<int> idle, slow;
  for (int i = 0; i < 200; ++i) idle.push_back(connect_loopback(server_.port()));
  for (int i = 0; i < 50; ++i) {
    slow.push_back(connect_loopback(server_.port()));
    const char* head = "GET /model.glb HTTP/1.1\r\nHost: x\r\n";
    if (slow.back() >= 0) (void)!::write(slow.back(), head, std::strlen(head));
  }
  std::atomic<bool> done{false};
  std::thread trickle([&] {
    while (!done) {
      for (int fd : slow)
        if (fd >= 0) (void)!::send(fd, "X", 1, MSG_NOSIGNAL);
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
  });
  for (int round = 0; round < 2; ++round) {
    std::this_thread::sleep_for(std::chrono::milliseconds(round == 0 ? 300 : 2500));
    auto t0 = std::chrono::steady_clock::now();
    auto r = client().Get("/report.json");
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_TRUE(r) << "round " << round;
    EXPECT_EQ(r->status, 200);
    EXPECT_LT(seconds, 1.0) << "round " << round;
    std::printf("[ serve ] ordinary request under 200 idle + 50 slow-header connections: %.3f s\n",
                seconds);
  }
  done = true;
  trickle.join();
  for (int fd : idle)
    if (fd >= 0) ::close(fd);
  for (int fd : slow)
    if (fd >= 0) ::close(fd);
}

// Reads what the server sends on `fd` until it closes or `seconds` pass.
std::string read_until_closed(int fd, double seconds) {
  std::string got;
  auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (;;) {
    int left = int(std::chrono::duration_cast<std::chrono::milliseconds>(
                       until - std::chrono::steady_clock::now())
                       .count());
    if (left <= 0) break;
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, left) <= 0) break;
    char buf[4096];
    ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    got.append(buf, size_t(n));
  }
  return got;
}

// Headers were unbounded in total (4 × 250 MB accepted, 1.6 GB RSS): a header over 16 KiB is
// answered 431 and the connection closed, whatever follows.
TEST_F(Serve, OversizedHeaderIsRefused) {
  start({"-q"});
  int fd = connect_loopback(server_.port());
  ASSERT_GE(fd, 0);
  std::string head = "GET /model.glb HTTP/1.1\r\nHost: x\r\n";
  for (int i = 0; i < 64; ++i)
    head += "X-Pad-" + std::to_string(i) + ": " + std::string(1000, 'a') + "\r\n";
  (void)!::send(fd, head.data(), head.size(), MSG_NOSIGNAL);
  std::string answer = read_until_closed(fd, 5);
  ::close(fd);
  EXPECT_EQ(answer.rfind("HTTP/1.1 431", 0), 0u) << answer.substr(0, 80);
  auto r = client().Get("/report.json");  // the server is fine
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
}

// One address may hold at most 256 connections: beyond, new ones are answered 503 and closed.
TEST_F(Serve, ConnectionsPerClientAreCapped) {
  start({"-q"});
  std::vector<int> fds;
  for (int i = 0; i < 270; ++i) fds.push_back(connect_loopback(server_.port()));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  int refused = 0;  // the order the server accepts them in is its own: look at every one
  for (int fd : fds) {
    char buf[64] = {0};
    if (fd >= 0 && ::recv(fd, buf, sizeof buf - 1, MSG_DONTWAIT) > 0 &&
        std::string(buf).rfind("HTTP/1.1 503", 0) == 0)
      ++refused;
  }
  EXPECT_EQ(refused, 270 - 256);
  for (int fd : fds)
    if (fd >= 0) ::close(fd);
}

TEST_F(Serve, CorsHeaderAndPreflight) {
  start({"--cors"});
  auto c = client();
  auto r = c.Get("/model.glb", {{"Range", "bytes=0-3"}, {"Origin", "http://example.com"}});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->get_header_value("Access-Control-Allow-Origin"), "*");
  r = c.Options("/model.glb", {{"Origin", "http://example.com"},
                               {"Access-Control-Request-Method", "GET"},
                               {"Access-Control-Request-Headers", "range"}});
  ASSERT_TRUE(r);
  EXPECT_TRUE(r->status == 200 || r->status == 204) << r->status;
  EXPECT_EQ(r->get_header_value("Access-Control-Allow-Origin"), "*");
  EXPECT_NE(r->get_header_value("Access-Control-Allow-Headers").find("Range"), std::string::npos);
  EXPECT_NE(r->get_header_value("Access-Control-Allow-Methods").find("GET"), std::string::npos);
}

TEST_F(Serve, HeadReturnsHeadersWithoutBody) {
  start();
  auto c = client();
  auto r = c.Head("/model.glb");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Length"), "1000");
  EXPECT_EQ(r->get_header_value("Content-Type"), "model/gltf-binary");
  EXPECT_TRUE(r->body.empty());
  // The connection is still usable afterwards (no stray body bytes).
  r = c.Get("/report.json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->body, "{\"ok\": true}\n");
}

TEST_F(Serve, RootServesIndexHtmlWhenPresent) {
  testing::write_text(site_ + "/index.html", "<!DOCTYPE html><title>viewer</title>\n");
  start();
  auto c = client();
  auto r = c.Get("/");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->body, "<!DOCTYPE html><title>viewer</title>\n");
  EXPECT_EQ(r->get_header_value("Content-Type"), "text/html; charset=utf-8");
}

TEST_F(Serve, RootListsTheFilesWithoutIndexHtml) {
  start();
  auto c = client();
  auto r = c.Get("/");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_EQ(r->get_header_value("Content-Type"), "text/html; charset=utf-8");
  EXPECT_NE(r->body.find("href=\"model.glb\""), std::string::npos) << r->body;
  EXPECT_NE(r->body.find("href=\"sub/\""), std::string::npos) << r->body;
  EXPECT_EQ(r->body.find("secret"), std::string::npos) << r->body;
}

TEST_F(Serve, LogsRequestsUnlessQuietAndStopsCleanlyOnSigterm) {
  start();
  auto c = client();
  ASSERT_TRUE(c.Get("/model.glb"));
  EXPECT_EQ(server_.stop(), 0);
  EXPECT_NE(log().find("GET /model.glb"), std::string::npos) << log();
}

TEST_F(Serve, QuietLogsNothing) {
  start({"-q"});
  auto c = client();
  ASSERT_TRUE(c.Get("/model.glb"));
  EXPECT_EQ(server_.stop(), 0);
  EXPECT_EQ(log(), "");
}

TEST_F(Serve, UsageErrors) {
  auto r = run_meshmux({"serve", tmp_.file("no-such-folder")});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no-such-folder: no such folder"), std::string::npos) << r.err;
  r = run_meshmux({"serve"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no folder given"), std::string::npos) << r.err;
  r = run_meshmux({"serve", tmp_.file("secret")});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("not a folder"), std::string::npos) << r.err;
  for (const char* port : {"70000", "-1", "http", ""}) {
    r = run_meshmux({"serve", site_, "--port", port});
    EXPECT_EQ(r.exit_code, 1) << port;
    EXPECT_NE(r.err.find("--port"), std::string::npos) << r.err;
  }
  r = run_meshmux({"serve", site_, "--bogus"});
  EXPECT_EQ(r.exit_code, 1);
}

TEST_F(Serve, PortInUseIsExit3NamingTheAddress) {
  start();
  std::string port = std::to_string(server_.port());
  // A second server on the same port must fail, not share it (no SO_REUSEPORT). Run as a
  // ServerProcess so that a wrongly successful bind cannot hang the test.
  ServerProcess second;
  EXPECT_FALSE(second.start({"serve", site_, "--port", port}, tmp_.file("second.log")))
      << second.line();
  EXPECT_EQ(second.stop(), 3);
  auto err = testing::read_file(tmp_.file("second.log"));
  std::string text(err.begin(), err.end());
  EXPECT_NE(text.find("cannot listen on 127.0.0.1:" + port), std::string::npos) << text;
}

}  // namespace
}  // namespace meshmux
