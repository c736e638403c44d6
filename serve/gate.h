// The connection gate in front of `meshmux serve`'s workers. A connection waits
// here, on one epoll thread, until a complete request header has arrived; only then does a
// worker thread serve it, and after each response a kept-alive connection comes back here to
// wait for its next request. So idle and slow clients never hold a worker: before the gate, 8
// slow-header connections (the worker count on 2 cores) blocked every other client.
//
// Limits, each closing the connection: a header not complete `header_seconds` after the
// connection (or its previous response), a header over `max_header_bytes` (431), more than
// `max_per_client` open connections from one address (503 to the newest).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>

namespace meshmux {

struct GateOptions {
  size_t max_header_bytes = 16384;  // request line + headers, bytes
  int header_seconds = 10;          // from connect or from the previous response
  size_t max_per_client = 256;      // open connections per remote address
  size_t workers = 16;              // threads serving complete requests
};

class ConnectionGate {
 public:
  // `serve(fd)` answers one request whose header is complete in the socket's buffer (blocking
  // socket); it returns true to keep the connection open for another request. The gate owns
  // every fd it is given and closes it.
  ConnectionGate(const GateOptions& options, std::function<bool(int fd)> serve);
  ~ConnectionGate();  // stops the threads, closes every connection
  ConnectionGate(const ConnectionGate&) = delete;
  ConnectionGate& operator=(const ConnectionGate&) = delete;

  // A new connection (thread-safe; returns at once).
  void add(int fd);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace meshmux
