// The connection gate (see serve/gate.h): one epoll thread waits for complete request headers
// (peeked, not consumed: the worker's HTTP parser reads them), a small pool serves them.
#include "serve/gate.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace meshmux {

namespace {

using Clock = std::chrono::steady_clock;

std::string peer_address(int fd) {
  sockaddr_storage a{};
  socklen_t n = sizeof a;
  if (getpeername(fd, reinterpret_cast<sockaddr*>(&a), &n) != 0) return "?";
  char text[INET6_ADDRSTRLEN] = "?";
  if (a.ss_family == AF_INET)
    inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(&a)->sin_addr, text, sizeof text);
  else if (a.ss_family == AF_INET6)
    inet_ntop(AF_INET6, &reinterpret_cast<sockaddr_in6*>(&a)->sin6_addr, text, sizeof text);
  return text;
}

void set_blocking(int fd, bool blocking) {
  int flags = fcntl(fd, F_GETFL);
  fcntl(fd, F_SETFL, blocking ? (flags & ~O_NONBLOCK) : (flags | O_NONBLOCK));
}

void answer_and_close(int fd, const char* status) {
  std::string r =
      std::string("HTTP/1.1 ") + status + "\r\nConnection: close\r\nContent-Length: 0\r\n\r\n";
  (void)!send(fd, r.data(), r.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  close(fd);
}

}  // namespace

struct ConnectionGate::Impl {
  GateOptions opts;
  std::function<bool(int)> serve;
  int epfd = -1, wake = -1;
  std::mutex mu;                               // guards everything below
  std::vector<std::pair<int, bool>> incoming;  // (fd, new connection)
  std::map<int, std::string> owner;            // open fd -> remote address
  std::map<std::string, size_t> per_client;    // remote address -> open connections
  std::deque<int> ready;                       // complete headers, for the workers
  std::condition_variable ready_cv;
  bool stopping = false;
  std::map<int, Clock::time_point> pending;  // gate thread only: fd -> header deadline
  std::thread gate;
  std::vector<std::thread> workers;

  void drop(int fd) {  // closes an open connection (any thread)
    {
      std::lock_guard<std::mutex> lock(mu);
      auto it = owner.find(fd);
      if (it != owner.end()) {
        if (--per_client[it->second] == 0) per_client.erase(it->second);
        owner.erase(it);
      }
    }
    close(fd);
  }

  void wake_gate() {
    uint64_t one = 1;
    (void)!write(wake, &one, sizeof one);
  }

  // A pending connection has data: complete header -> a worker; too long -> 431; EOF -> drop.
  void readable(int fd) {
    std::vector<char> buf(opts.max_header_bytes + 1);
    ssize_t n = recv(fd, buf.data(), buf.size(), MSG_PEEK);
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return;
    if (n <= 0) {
      epoll_ctl(epfd, EPOLL_CTL_DEL, fd, nullptr);
      pending.erase(fd);
      return drop(fd);
    }
    const char* end = static_cast<const char*>(memmem(buf.data(), size_t(n), "\r\n\r\n", 4));
    if (!end && size_t(n) <= opts.max_header_bytes) return;  // wait for more
    epoll_ctl(epfd, EPOLL_CTL_DEL, fd, nullptr);
    pending.erase(fd);
    if (!end) {
      {
        std::lock_guard<std::mutex> lock(mu);
        auto it = owner.find(fd);
        if (it != owner.end()) {
          if (--per_client[it->second] == 0) per_client.erase(it->second);
          owner.erase(it);
        }
      }
      return answer_and_close(fd, "431 Request Header Fields Too Large");
    }
    set_blocking(fd, true);
    {
      std::lock_guard<std::mutex> lock(mu);
      ready.push_back(fd);
    }
    ready_cv.notify_one();
  }

  void gate_loop() {
    epoll_event events[64];
    for (;;) {
      int n = epoll_wait(epfd, events, 64, 200);
      std::vector<std::pair<int, bool>> fresh;
      {
        std::lock_guard<std::mutex> lock(mu);
        if (stopping) return;
        fresh.swap(incoming);
      }
      for (int i = 0; i < n; ++i) {
        int fd = events[i].data.fd;
        if (fd == wake) {
          uint64_t v;
          (void)!read(wake, &v, sizeof v);
        } else if (pending.count(fd)) {
          readable(fd);
        }
      }
      const auto now = Clock::now();
      for (auto [fd, is_new] : fresh) {
        if (is_new) {
          std::string ip = peer_address(fd);
          bool over;
          {
            std::lock_guard<std::mutex> lock(mu);
            over = per_client[ip] >= opts.max_per_client;
            if (!over) {
              ++per_client[ip];
              owner[fd] = ip;
            } else if (per_client[ip] == 0) {
              per_client.erase(ip);
            }
          }
          if (over) {
            answer_and_close(fd, "503 Service Unavailable");
            continue;
          }
        }
        set_blocking(fd, false);
        pending[fd] = now + std::chrono::seconds(opts.header_seconds);
        epoll_event ev{};
        ev.events = EPOLLIN | EPOLLET | EPOLLRDHUP;
        ev.data.fd = fd;
        if (epoll_ctl(epfd, EPOLL_CTL_ADD, fd, &ev) != 0) {
          pending.erase(fd);
          drop(fd);
          continue;
        }
        readable(fd);  // what arrived before it was watched
      }
      // Headers that did not complete in time: idle and slow clients.
      for (auto it = pending.begin(); it != pending.end();) {
        if (it->second > now) {
          ++it;
          continue;
        }
        int fd = it->first;
        it = pending.erase(it);
        epoll_ctl(epfd, EPOLL_CTL_DEL, fd, nullptr);
        drop(fd);
      }
    }
  }

  void worker_loop() {
    for (;;) {
      int fd;
      {
        std::unique_lock<std::mutex> lock(mu);
        ready_cv.wait(lock, [&] { return stopping || !ready.empty(); });
        if (stopping) return;
        fd = ready.front();
        ready.pop_front();
      }
      if (serve(fd)) {
        {
          std::lock_guard<std::mutex> lock(mu);
          incoming.emplace_back(fd, false);
        }
        wake_gate();
      } else {
        drop(fd);
      }
    }
  }
};

ConnectionGate::ConnectionGate(const GateOptions& options, std::function<bool(int)> serve)
    : impl_(std::make_unique<Impl>()) {
  impl_->opts = options;
  impl_->serve = std::move(serve);
  impl_->epfd = epoll_create1(EPOLL_CLOEXEC);
  impl_->wake = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.fd = impl_->wake;
  epoll_ctl(impl_->epfd, EPOLL_CTL_ADD, impl_->wake, &ev);
  impl_->gate = std::thread([this] { impl_->gate_loop(); });
  for (size_t i = 0; i < std::max<size_t>(1, options.workers); ++i)
    impl_->workers.emplace_back([this] { impl_->worker_loop(); });
}

ConnectionGate::~ConnectionGate() {
  {
    std::lock_guard<std::mutex> lock(impl_->mu);
    impl_->stopping = true;
  }
  impl_->wake_gate();
  impl_->ready_cv.notify_all();
  impl_->gate.join();
  for (std::thread& t : impl_->workers) t.join();
  for (const auto& [fd, address] : impl_->owner) close(fd);
  for (const auto& [fd, is_new] : impl_->incoming)
    if (is_new) close(fd);
  close(impl_->epfd);
  close(impl_->wake);
}

void ConnectionGate::add(int fd) {
  {
    std::lock_guard<std::mutex> lock(impl_->mu);
    if (impl_->stopping) {
      close(fd);
      return;
    }
    impl_->incoming.emplace_back(fd, true);
  }
  impl_->wake_gate();
}

}  // namespace meshmux
