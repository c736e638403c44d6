// `meshmux serve DIR [--port P] [--host H] [-q]`: serves a converted output folder to the
// browser viewer over HTTP (GET, HEAD, single Range requests, CORS), files under DIR only.
#pragma once

#include <string>
#include <vector>

namespace meshmux {

// Runs the server until SIGINT or SIGTERM. Exit codes: 0 after a clean stop, 1 usage error
// (missing DIR, DIR not a folder, bad port), 3 when the address cannot be bound.
int cmd_serve(const std::vector<std::string>& args);

}  // namespace meshmux
