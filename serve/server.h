// meshmux serve as a library: a small static HTTP server for converted output folders, so the
// browser viewer can stream them (GET, HEAD, single Range requests, CORS preflight,
// validators and 304s, precompressed siblings). Paths that could leave the root, dotfiles and
// double-encoded escapes are refused with 403. The HTTP rules themselves are serve/http.h; the
// connection gate in front of the workers is serve/gate.h.
#pragma once

#include <string>

#include "core/status.h"

namespace meshmux {

struct ServeOptions {
  std::string root;                // canonical folder to serve (the caller checks it exists)
  std::string host = "127.0.0.1";  // address to listen on (loopback by default)
  int port = 8080;                 // TCP port; 0 picks a free one
  bool cors = false;               // Access-Control-Allow-Origin: * on every response
  bool quiet = false;              // no request log on stderr
};

// Serves until SIGINT or SIGTERM (then ok). Prints "meshmux: serving ROOT at http://HOST:PORT/"
// on stdout once listening, and a warning on stderr when the host is beyond loopback. Errors
// (kOutput): the address cannot be bound, or the server stopped by itself.
Status serve_folder(const ServeOptions& options);

}  // namespace meshmux
