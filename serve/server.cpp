// meshmux serve as a library: a small static HTTP server for a converted output folder, so the
// browser viewer can stream it (GET, HEAD, single Range requests, CORS preflight).
//
// Connections: httplib accepts, then hands every socket to the ConnectionGate (serve/gate.h),
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
#include "serve/server.h"

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

#include "core/text.h"
#include "serve/gate.h"
#include "serve/http.h"

namespace meshmux {
namespace {

namespace fs = std::filesystem;

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
    const std::string type = content_type_for(file.string());

    // A whole-file request that accepts brotli or gzip gets the file's precompressed sibling
    // (FILE.br, FILE.gz: convert writes them for the viewer) with Content-Encoding; ranges
    // always get the identity bytes, so that byte offsets mean what the package's table says.
    std::string encoding;
    const bool has_br = regular_sibling(file, ".br"), has_gz = regular_sibling(file, ".gz");
    if (has_br || has_gz) res.set_header("Vary", "Accept-Encoding");
    if (ranges.empty()) {
      const std::string accept = req.get_header_value("Accept-Encoding");
      const char* pick = has_br && accepts_encoding(accept, "br")     ? "br"
                         : has_gz && accepts_encoding(accept, "gzip") ? "gzip"
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
    const std::string etag =
        entity_tag(size, int64_t(st.st_mtim.tv_sec), int64_t(st.st_mtim.tv_nsec), encoding);
    res.set_header("ETag", etag);
    res.set_header("Last-Modified", http_date(st.st_mtim.tv_sec));
    // A versioned folder (convert writes three.js under viewer/three-r<release>/) never changes
    // under its name: caches keep it without asking again. The rest is revalidated (no-cache).
    if (versioned_path(req.path)) {
      res.headers.erase("Cache-Control");  // the server's default, no-cache
      res.set_header("Cache-Control", "public, max-age=31536000, immutable");
    }
    if (not_modified(header(req, "If-None-Match"), header(req, "If-Modified-Since"), etag,
                     st.st_mtim.tv_sec)) {
      res.status = 304;
      return;
    }

    // Only a single range is answered with 206; several ranges, or an If-Range naming another
    // version (its ETag, or a date other than Last-Modified), get the whole file.
    const bool range_valid =
        range_is_current(header(req, "If-Range"), etag, http_date(st.st_mtim.tv_sec));
    if (ranges.size() == 1 && range_valid) {
      uint64_t first = 0, last = 0;
      if (!satisfiable({int64_t(ranges[0].first), int64_t(ranges[0].second)}, size, &first,
                       &last)) {
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

  // A request header's value, or nullptr when it is absent (the pointer lives with `req`).
  static const std::string* header(const httplib::Request& req, const char* name) {
    auto it = req.headers.find(name);
    return it == req.headers.end() ? nullptr : &it->second;
  }

  static bool regular_sibling(const fs::path& file, const char* suffix) {
    struct stat st;
    return ::stat((file.string() + suffix).c_str(), &st) == 0 && S_ISREG(st.st_mode);
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
// ConnectionGate (serve/gate.h), which calls serve_one() on a worker once a complete header
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

Status serve_folder(const ServeOptions& o) {
  const fs::path root = o.root;
  // SIGINT and SIGTERM are taken by one waiting thread (blocked everywhere else, including
  // httplib's worker threads, which inherit this mask), which stops the server. They stay
  // blocked afterwards: the process is about to exit.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  std::signal(SIGPIPE, SIG_IGN);

  Site site(root, o.quiet);
  GatedServer svr;
  ConnectionGate gate(GateOptions{}, [&svr](int fd) { return svr.serve_one(fd); });
  svr.set_gate(&gate);
  httplib::Headers defaults = {{"Cache-Control", "no-cache"}};
  if (o.cors) {
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

  const std::string& host = o.host;
  int port = o.port;
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
    return Status::error("serve: cannot listen on " + address +
                             (err ? std::string(": ") + std::strerror(err) : std::string()),
                         ErrorKind::kOutput);
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
    if (!o.quiet) std::fprintf(stderr, "meshmux: serve: stopped\n");
    return Status::ok();
  }
  return Status::error("serve: the server on " + url_host(host) + ":" + std::to_string(port) +
                           " stopped unexpectedly" + (ok ? "" : " (listen failed)"),
                       ErrorKind::kOutput);
}

}  // namespace meshmux
