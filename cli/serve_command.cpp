// meshmux serve DIR: the folder checked, then the server library (serve/server.h).
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "core/exit_codes.h"
#include "serve/server.h"

namespace meshmux {

namespace {

const char* const kServeUsage =
    "usage: meshmux serve DIR [--port P] [--host H] [--cors] [-q]\n"
    "  serves the files under DIR over HTTP (GET, HEAD, Range requests) for the viewer;\n"
    "  files and folders whose names start with '.' are never served\n"
    "  --port P   TCP port, 0 picks a free one (default 8080)\n"
    "  --host H   address to listen on (default 127.0.0.1, loopback only; any other address\n"
    "             is reachable by other machines: a warning says so)\n"
    "  --cors     allow pages from any origin to fetch the files\n"
    "             (Access-Control-Allow-Origin: *; off by default)\n"
    "  -q         do not log requests on stderr\n";

}  // namespace

int cmd_serve(const std::vector<std::string>& args) {
  namespace fs = std::filesystem;
  auto p = parse_args(kServe, args);
  if (!p.ok()) return usage_error(kServe, p.status().message());
  if (p->help) return std::fputs(kServeUsage, stdout), kExitOk;
  if (p->positional.empty()) return usage_error(kServe, "no folder given (meshmux serve DIR)");
  const std::string dir = p->positional[0];
  std::error_code ec;
  if (!fs::exists(dir, ec)) return usage_error(kServe, dir + ": no such folder");
  if (!fs::is_directory(dir, ec)) return usage_error(kServe, dir + ": not a folder");
  ServeOptions o;
  o.root = fs::canonical(dir, ec).string();
  if (ec) return usage_error(kServe, dir + ": " + ec.message());
  o.host = p->text("--host", o.host);
  o.port = int(p->whole("--port", o.port));
  o.cors = p->has("--cors");
  o.quiet = p->has("--quiet");
  if (Status s = serve_folder(o); !s) return print_error(s);
  return kExitOk;
}

}  // namespace meshmux
