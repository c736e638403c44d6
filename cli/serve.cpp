// `meshmux serve DIR`: a small static HTTP server for a converted output folder, so the
// browser viewer can stream it (GET, HEAD, single Range requests, CORS preflight).
//
// Connections: httplib accepts, then hands every socket to the ConnectionGate (serve_gate.h),
// which waits on one epoll thread for a complete request header (≤ 16 KiB, within 10 s, at
// most 256 connections per client address) before a worker serves it with httplib's request
// processing; kept-alive connections return to the gate between requests. Idle and slow
// clients therefore never hold a worker.
//
// Every request goes through one pre-routing handler. Paths are decoded once (by httplib) and
// refused with 403 when they could leave DIR: "..", backslash, NUL, an absolute path, a '%'
// escape still left after the one decoding (double encoding), or a canonical file outside the
// canonical DIR (symbolic links included).
//
// Ranges are answered here, not by httplib: cpp-httplib 0.11 neither clamps a range that runs
// past the end of the content (its Content-Range then names bytes that do not exist) nor
// answers a range that starts past the end with a correct 416. The handler therefore clears
// the request's parsed ranges before httplib's post-processing sees them and writes the 206 or
// 416 response itself. A request with several ranges gets the whole file (200), which RFC 9110
// allows.
#include "cli/serve.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cli/serve_gate.h"
#include "cli/text.h"

namespace meshmux {
namespace {

namespace fs = std::filesystem;

constexpr int kExitOk = 0;
constexpr int kExitUsage = 1;
constexpr int kExitOutput = 3;

const char* kServeUsage =
    "usage: meshmux serve DIR [--port P] [--host H] [--cors] [-q]\n"
    "  serves the files under DIR over HTTP (GET, HEAD, Range requests) for the viewer;\n"
    "  files and folders whose names start with '.' are never served\n"
    "  --port P   TCP port, 0 picks a free one (default 8080)\n"
    "  --host H   address to listen on (default 127.0.0.1, loopback only; any other address\n"
    "             is reachable by other machines: a warning says so)\n"
    "  --cors     allow pages from any origin to fetch the files\n"
    "             (Access-Control-Allow-Origin: *; off by default)\n"
    "  -q         do not log requests on stderr\n";

int usage_error(const std::string& message) {
  std::fprintf(stderr, "meshmux: serve: %s\n(see meshmux --help)\n", message.c_str());
  return kExitUsage;
}

// File name extension → Content-Type.
std::string content_type_for(const fs::path& file) {
  std::string ext = file.extension().string();
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

bool is_hex(char c) { return std::isxdigit(static_cast<unsigned char>(c)) != 0; }

// Request text for the log: control and non-ASCII bytes as \xHH.
std::string printable(const std::string& s) {
  std::string out;
  for (unsigned char c : s) {
    if (c < 0x20 || c >= 0x7f || c == '\\') {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02X", c);
      out += buf;
    } else {
      out += char(c);
    }
  }
  return out;
}

void set_text(httplib::Response& res, int status, const std::string& text) {
  res.status = status;
  res.set_content(text + "\n", "text/plain; charset=utf-8");
}

// An open file shared by the content provider calls of one response.
struct OpenFile {
  int fd = -1;
  ~OpenFile() {
    if (fd >= 0) ::close(fd);
  }
};

// Streams [offset, offset + length) of the file as the response body.
void set_file_body(httplib::Response& res, const std::shared_ptr<OpenFile>& file, uint64_t offset,
                   uint64_t length, const std::string& type) {
  if (length == 0) {
    res.set_content(std::string(), type);
    return;
  }
  res.set_content_provider(size_t(length), type,
                           [file, offset](size_t pos, size_t want, httplib::DataSink& sink) {
                             char buf[1 << 16];
                             size_t n = std::min(want, sizeof buf);
                             ssize_t got = ::pread(file->fd, buf, n, off_t(offset + pos));
                             if (got <= 0)
                               return false;  // read error or the file shrank: abort the connection
                             return sink.write(buf, size_t(got));
                           });
}

class Site {
 public:
  Site(fs::path root, bool quiet) : root_(std::move(root)), quiet_(quiet) {
    root_str_ = root_.string();
    prefix_ = root_str_;
    if (prefix_.empty() || prefix_.back() != '/') prefix_ += '/';
  }

  void handle(const httplib::Request& req, httplib::Response& res) const {
    // httplib parsed the Range header into req.ranges; it would apply them to whatever this
    // handler answers, wrongly past the end of the content (see the top of the file). Take them
    // and leave none behind. The request object is not const where httplib owns it.
    httplib::Ranges ranges = req.ranges;
    const_cast<httplib::Request&>(req).ranges.clear();

    res.set_header("Accept-Ranges", "bytes");
    if (req.method == "OPTIONS") {
      res.status = 204;
      res.set_header("Allow", "GET, HEAD, OPTIONS");
      res.set_header("Access-Control-Allow-Methods", "GET, HEAD, OPTIONS");
      res.set_header("Access-Control-Allow-Headers", "Range");
      res.set_header("Access-Control-Max-Age", "86400");
      return;
    }
    if (req.method != "GET" && req.method != "HEAD") {
      res.set_header("Allow", "GET, HEAD, OPTIONS");
      return set_text(res, 405, "405 method not allowed");
    }

    fs::path target;
    int status = resolve(req.path, &target);
    if (status != 200)
      return set_text(res, status, status == 403 ? "403 forbidden" : "404 not found");

    std::error_code ec;
    if (fs::is_directory(target, ec)) {
      if (req.path.back() != '/') {
        // Relative links inside the folder need the trailing slash.
        std::string location = req.target.substr(0, req.target.find('?')) + "/";
        res.set_redirect(location, 301);
        return;
      }
      fs::path index;
      if (resolve_inside(target / "index.html", &index) == 200 && fs::is_regular_file(index, ec))
        return serve_file(req, res, index, ranges);
      return serve_listing(req, res, target);
    }
    if (!fs::is_regular_file(target, ec)) return set_text(res, 403, "403 forbidden");
    serve_file(req, res, target, ranges);
  }

  void log(const httplib::Request& req, const httplib::Response& res) const {
    if (quiet_) return;
    std::string length = res.get_header_value("Content-Length");
    std::fprintf(stderr, "meshmux: %s \"%s %s\" %d %s\n", req.remote_addr.c_str(),
                 printable(req.method).c_str(), printable(req.target).c_str(), res.status,
                 length.empty() ? "-" : length.c_str());
  }

 private:
  // The decoded request path → a canonical file or folder inside the root. Returns 200, 403
  // (refused) or 404 (absent).
  int resolve(const std::string& path, fs::path* out) const {
    if (path.empty() || path[0] != '/') return 403;
    if (path.find('\0') != std::string::npos || path.find('\\') != std::string::npos ||
        path.find("..") != std::string::npos)
      return 403;
    // The path was decoded once; an escape left over means it was encoded twice.
    for (size_t i = 0; i + 2 < path.size(); ++i)
      if (path[i] == '%' && is_hex(path[i + 1]) && is_hex(path[i + 2])) return 403;
    std::string rel = path.substr(1);
    if (!rel.empty() && rel[0] == '/') return 403;  // "//etc/passwd": absolute once decoded
    // Dotfiles and dot-folders (.git, .env, .htpasswd) are never served.
    for (size_t i = 0; i < path.size(); ++i)
      if (path[i] == '/' && i + 1 < path.size() && path[i + 1] == '.') return 403;
    if (fs::path(rel).is_absolute() || fs::path(rel).has_root_name()) return 403;
    return resolve_inside(rel.empty() ? root_ : root_ / rel, out);
  }

  int resolve_inside(const fs::path& candidate, fs::path* out) const {
    std::error_code ec;
    fs::path canon = fs::canonical(candidate, ec);
    if (ec) return 404;
    std::string s = canon.string();
    if (s != root_str_ && s.compare(0, prefix_.size(), prefix_) != 0) return 403;
    *out = canon;
    return 200;
  }

  void serve_file(const httplib::Request& req, httplib::Response& res, const fs::path& file,
                  const httplib::Ranges& ranges) const {
    auto open = std::make_shared<OpenFile>();
    open->fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    struct stat st;
    if (open->fd < 0 || ::fstat(open->fd, &st) != 0 || !S_ISREG(st.st_mode))
      return set_text(res, 403, "403 forbidden");
    uint64_t size = uint64_t(st.st_size);
    const std::string type = content_type_for(file);

    // A whole-file request that accepts brotli or gzip gets the file's precompressed sibling
    // (FILE.br, FILE.gz: convert writes them for the viewer) with Content-Encoding; ranges
    // always get the identity bytes, so that byte offsets mean what the package's table says.
    std::string encoding;
    const bool has_br = regular_sibling(file, ".br"), has_gz = regular_sibling(file, ".gz");
    if (has_br || has_gz) res.set_header("Vary", "Accept-Encoding");
    if (ranges.empty()) {
      const std::string accept = req.get_header_value("Accept-Encoding");
      const char* pick = has_br && accepts(accept, "br")     ? "br"
                         : has_gz && accepts(accept, "gzip") ? "gzip"
                                                             : nullptr;
      if (pick) {
        const fs::path sibling = file.string() + (pick[0] == 'b' ? ".br" : ".gz");
        auto encoded = std::make_shared<OpenFile>();
        encoded->fd = ::open(sibling.c_str(), O_RDONLY | O_CLOEXEC);
        struct stat est;
        if (encoded->fd >= 0 && ::fstat(encoded->fd, &est) == 0 && S_ISREG(est.st_mode)) {
          open = encoded, st = est, size = uint64_t(est.st_size), encoding = pick;
          res.set_header("Content-Encoding", encoding);
        }
      }
    }
    // Validators (RFC 9110 §8.8): the ETag names the bytes sent (size, modification time and
    // encoding), Last-Modified the file's time; a request holding either gets 304 and no body
    // when nothing changed, so a repeat visit costs headers only.
    const std::string etag = "\"" + hex(size) + "-" + hex(uint64_t(st.st_mtim.tv_sec)) + "." +
                             hex(uint64_t(st.st_mtim.tv_nsec)) +
                             (encoding.empty() ? "" : "-" + encoding) + "\"";
    res.set_header("ETag", etag);
    res.set_header("Last-Modified", http_date(st.st_mtim.tv_sec));
    // A versioned folder (convert writes three.js under viewer/three-r<release>/) never changes
    // under its name: caches keep it without asking again. The rest is revalidated (no-cache).
    if (versioned_path(req.path)) {
      res.headers.erase("Cache-Control");  // the server's default, no-cache
      res.set_header("Cache-Control", "public, max-age=31536000, immutable");
    }
    if (not_modified(req, etag, st.st_mtim.tv_sec)) {
      res.status = 304;
      return;
    }

    // Only a single range is answered with 206; several ranges, or an If-Range naming another
    // version (its ETag, or a date other than Last-Modified), get the whole file.
    const std::string if_range = req.get_header_value("If-Range");
    const bool range_valid =
        !req.has_header("If-Range") || if_range == etag || if_range == http_date(st.st_mtim.tv_sec);
    if (ranges.size() == 1 && range_valid) {
      uint64_t first = 0, last = 0;
      if (!satisfiable(ranges[0], size, &first, &last)) {
        res.status = 416;
        res.set_header("Content-Range", "bytes */" + std::to_string(size));
        return;
      }
      res.status = 206;
      res.set_header("Content-Range", "bytes " + std::to_string(first) + "-" +
                                          std::to_string(last) + "/" + std::to_string(size));
      set_file_body(res, open, first, last - first + 1, type);
      return;
    }
    res.status = 200;
    set_file_body(res, open, 0, size, type);
  }

  // Whether a request path lies in a folder named NAME-rDIGITS (a release-versioned folder).
  static bool versioned_path(const std::string& path) {
    for (size_t at = 0; (at = path.find("-r", at)) != std::string::npos; at += 2) {
      size_t end = at + 2;
      while (end < path.size() && std::isdigit(static_cast<unsigned char>(path[end]))) ++end;
      if (end > at + 2 && end < path.size() && path[end] == '/') return true;
    }
    return false;
  }

  static bool regular_sibling(const fs::path& file, const char* suffix) {
    struct stat st;
    return ::stat((file.string() + suffix).c_str(), &st) == 0 && S_ISREG(st.st_mode);
  }

  // Whether an Accept-Encoding value lists `coding` without q=0.
  static bool accepts(const std::string& header, const std::string& coding) {
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

  static std::string hex(uint64_t v) {
    char buf[24];
    std::snprintf(buf, sizeof buf, "%llx", static_cast<unsigned long long>(v));
    return buf;
  }

  // An IMF-fixdate ("Sun, 06 Nov 1994 08:49:37 GMT"), in English whatever the locale.
  static std::string http_date(time_t t) {
    static const char* const days[] = {"Sun", "Mon", "Tue", "Wed", "Thu", "Fri", "Sat"};
    static const char* const months[] = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                         "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};
    struct tm g;
    gmtime_r(&t, &g);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s, %02d %s %04d %02d:%02d:%02d GMT", days[g.tm_wday],
                  g.tm_mday, months[g.tm_mon], g.tm_year + 1900, g.tm_hour, g.tm_min, g.tm_sec);
    return buf;
  }

  // The time an IMF-fixdate names, or -1.
  static time_t parse_http_date(const std::string& s) {
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
  static bool not_modified(const httplib::Request& req, const std::string& etag, time_t mtime) {
    if (req.has_header("If-None-Match")) {
      const std::string list = req.get_header_value("If-None-Match");
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
    if (req.has_header("If-Modified-Since")) {
      const time_t since = parse_http_date(req.get_header_value("If-Modified-Since"));
      return since >= 0 && mtime <= since;
    }
    return false;
  }

  // One parsed range (first, last; -1 for a missing end) against the file size: the bytes to
  // send, clamped to the file, or false when none of them exists.
  static bool satisfiable(const std::pair<ssize_t, ssize_t>& r, uint64_t size, uint64_t* first,
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

  void serve_listing(const httplib::Request& req, httplib::Response& res,
                     const fs::path& folder) const {
    std::vector<std::string> names;
    std::error_code ec;
    for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
      std::error_code dec;
      std::string name = it->path().filename().string();
      if (it->is_directory(dec)) name += '/';
      names.push_back(name);
    }
    std::sort(names.begin(), names.end());
    std::string title = "Index of " + html_escape(req.path);
    std::string html = "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" + title +
                       "</title></head>\n<body><h1>" + title + "</h1>\n<ul>\n";
    for (const std::string& name : names) {
      bool dir = name.back() == '/';
      std::string bare = dir ? name.substr(0, name.size() - 1) : name;
      html += "<li><a href=\"" + url_escape(bare) + (dir ? "/" : "") + "\">" + html_escape(name) +
              "</a></li>\n";
    }
    html += "</ul>\n</body></html>\n";
    res.status = 200;
    res.set_content(html, "text/html; charset=utf-8");
  }

  fs::path root_;
  std::string root_str_, prefix_;
  bool quiet_;
};

bool parse_port(const std::string& text, int* port) {
  if (text.empty() || text.size() > 5) return false;
  for (char c : text)
    if (c < '0' || c > '9') return false;
  long v = std::strtol(text.c_str(), nullptr, 10);
  if (v < 0 || v > 65535) return false;
  *port = int(v);
  return true;
}

std::string url_host(const std::string& host) {
  return host.find(':') != std::string::npos ? "[" + host + "]" : host;
}

// One connection's HTTP I/O for httplib's request processing, with our limits: every read of
// a request must arrive within 10 s of the first, and at most 32 KiB are read per request (the
// gate already checked the header is complete and at most 16 KiB; GET, HEAD and OPTIONS carry
// no body). Writes time out after 10 s of no progress.
class GateStream : public httplib::Stream {
 public:
  explicit GateStream(int fd) : fd_(fd), deadline_(Clock::now() + std::chrono::seconds(10)) {}
  bool is_readable() const override { return wait(POLLIN, deadline_); }
  bool is_writable() const override {
    return wait(POLLOUT, Clock::now() + std::chrono::seconds(10));
  }
  ssize_t read(char* ptr, size_t size) override {
    if (read_ >= kMaxRequestBytes || !is_readable()) return -1;
    size = std::min(size, kMaxRequestBytes - read_);
    ssize_t n;
    do n = ::recv(fd_, ptr, size, 0);
    while (n < 0 && errno == EINTR);
    if (n > 0) read_ += size_t(n);
    return n;
  }
  ssize_t write(const char* ptr, size_t size) override {
    if (!is_writable()) return -1;
    ssize_t n;
    do n = ::send(fd_, ptr, size, MSG_NOSIGNAL);
    while (n < 0 && errno == EINTR);
    return n;
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    address(::getpeername, ip, port);
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    address(::getsockname, ip, port);
  }
  socket_t socket() const override { return fd_; }

 private:
  using Clock = std::chrono::steady_clock;
  static constexpr size_t kMaxRequestBytes = 32768;
  bool wait(short what, Clock::time_point until) const {
    for (;;) {
      auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now());
      if (left.count() <= 0) return false;
      pollfd p{fd_, what, 0};
      int r = ::poll(&p, 1, int(left.count()));
      if (r > 0) return true;
      if (r == 0 || errno != EINTR) return false;
    }
  }
  template <class F>
  void address(F get, std::string& ip, int& port) const {
    sockaddr_storage a{};
    socklen_t n = sizeof a;
    ip.clear();
    port = 0;
    if (get(fd_, reinterpret_cast<sockaddr*>(&a), &n) != 0) return;
    char text[INET6_ADDRSTRLEN] = "";
    if (a.ss_family == AF_INET) {
      auto* v4 = reinterpret_cast<sockaddr_in*>(&a);
      inet_ntop(AF_INET, &v4->sin_addr, text, sizeof text);
      port = ntohs(v4->sin_port);
    } else if (a.ss_family == AF_INET6) {
      auto* v6 = reinterpret_cast<sockaddr_in6*>(&a);
      inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof text);
      port = ntohs(v6->sin6_port);
    }
    ip = text;
  }
  int fd_;
  Clock::time_point deadline_;
  size_t read_ = 0;
};

// httplib's server with its connection handling replaced: accepted sockets go to the
// ConnectionGate (serve_gate.h), which calls serve_one() on a worker once a complete header
// has arrived; httplib still parses requests and writes responses.
class GatedServer : public httplib::Server {
 public:
  void set_gate(ConnectionGate* gate) { gate_ = gate; }
  // httplib 0.11 listens with a backlog of 5: a burst of connections then waits for SYN
  // retransmits (1 s, 3 s, ...). Listening again on the bound socket raises it.
  void raise_backlog() {
    if (svr_sock_ != INVALID_SOCKET) ::listen(svr_sock_, SOMAXCONN);
  }
  // Answers one request on `fd`; true when the connection may carry another.
  bool serve_one(int fd) {
    GateStream stream(fd);
    bool closed = false;
    bool ok = process_request(stream, /*close_connection=*/false, closed, nullptr);
    return ok && !closed;
  }

 private:
  bool process_and_close_socket(socket_t sock) override {
    gate_->add(sock);  // the gate owns and closes it
    return true;
  }
  ConnectionGate* gate_ = nullptr;
};

}  // namespace

int cmd_serve(const std::vector<std::string>& args) {
  std::string dir, host = "127.0.0.1";
  int port = 8080;
  bool quiet = false, cors = false;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "-h" || a == "--help") {
      std::fputs(kServeUsage, stdout);
      return kExitOk;
    } else if (a == "-q" || a == "--quiet") {
      quiet = true;
    } else if (a == "--cors") {
      cors = true;
    } else if (a == "--port" || a == "--host") {
      if (i + 1 >= args.size()) return usage_error(a + " needs a value");
      const std::string& v = args[++i];
      if (a == "--host") {
        if (v.empty()) return usage_error("--host needs a non-empty address");
        host = v;
      } else if (!parse_port(v, &port)) {
        return usage_error("--port expects a whole number from 0 to 65535, got '" + v + "'");
      }
    } else if (!a.empty() && a[0] == '-') {
      return usage_error("unknown option " + a);
    } else if (!dir.empty()) {
      return usage_error("more than one folder given ('" + dir + "' and '" + a + "')");
    } else {
      dir = a;
    }
  }
  if (dir.empty()) return usage_error("no folder given (meshmux serve DIR)");
  std::error_code ec;
  if (!fs::exists(dir, ec)) return usage_error(dir + ": no such folder");
  if (!fs::is_directory(dir, ec)) return usage_error(dir + ": not a folder");
  fs::path root = fs::canonical(dir, ec);
  if (ec) return usage_error(dir + ": " + ec.message());

  // SIGINT and SIGTERM are taken by one waiting thread (blocked everywhere else, including
  // httplib's worker threads, which inherit this mask), which stops the server. They stay
  // blocked afterwards: the process is about to exit.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  std::signal(SIGPIPE, SIG_IGN);

  Site site(root, quiet);
  GatedServer svr;
  ConnectionGate gate(GateOptions{}, [&svr](int fd) { return svr.serve_one(fd); });
  svr.set_gate(&gate);
  httplib::Headers defaults = {{"Cache-Control", "no-cache"}};
  if (cors) {
    defaults.emplace("Access-Control-Allow-Origin", "*");
    defaults.emplace("Access-Control-Expose-Headers",
                     "Content-Range, Content-Length, Accept-Ranges");
  }
  svr.set_default_headers(defaults);
  svr.set_payload_max_length(0);  // GET, HEAD and OPTIONS only: no request body is read
  svr.set_pre_routing_handler([&site](const httplib::Request& req, httplib::Response& res) {
    site.handle(req, res);
    return httplib::Server::HandlerResponse::Handled;
  });
  svr.set_logger(
      [&site](const httplib::Request& req, const httplib::Response& res) { site.log(req, res); });

  // httplib's default socket options include SO_REUSEPORT, which lets a second server bind a
  // port already in use (the kernel then splits the connections between them). Keep only
  // SO_REUSEADDR: a restart binds despite TIME_WAIT, a busy port fails.
  svr.set_socket_options([](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });

  std::string address = url_host(host) + ":" + std::to_string(port);
  errno = 0;
  if (port == 0) {
    int bound = svr.bind_to_any_port(host);
    if (bound > 0)
      port = bound;
    else
      port = -1;
  } else if (!svr.bind_to_port(host, port)) {
    port = -1;
  }
  if (port >= 0) svr.raise_backlog();
  if (port < 0) {
    int err = errno;
    std::fprintf(stderr, "meshmux: serve: cannot listen on %s%s%s\n", address.c_str(),
                 err ? ": " : "", err ? std::strerror(err) : "");
    return kExitOutput;
  }

  if (host != "127.0.0.1" && host != "::1" && host != "localhost")
    std::fprintf(stderr,
                 "meshmux: serve: warning: listening on %s, beyond loopback: other machines "
                 "can read %s\n",
                 host.c_str(), root.c_str());
  std::printf("meshmux: serving %s at http://%s:%d/ (Ctrl-C to stop)\n", root.c_str(),
              url_host(host).c_str(), port);
  std::fflush(stdout);

  std::atomic<bool> listening_done{false}, got_signal{false};
  std::thread waiter([&] {
    int sig = 0;
    sigwait(&stop_signals, &sig);
    if (listening_done) return;  // woken by the main thread below
    got_signal = true;
    // stop() only acts once listen_after_bind is running; repeat until it has returned.
    while (!listening_done) {
      svr.stop();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  bool ok = svr.listen_after_bind();
  listening_done = true;
  if (!got_signal) pthread_kill(waiter.native_handle(), SIGTERM);
  waiter.join();
  if (got_signal) {
    if (!quiet) std::fprintf(stderr, "meshmux: serve: stopped\n");
    return kExitOk;
  }
  std::fprintf(stderr, "meshmux: serve: the server on %s:%d stopped unexpectedly%s\n",
               url_host(host).c_str(), port, ok ? "" : " (listen failed)");
  return kExitOutput;
}

}  // namespace meshmux
