// `meshmux render IN -o OUT.png|OUT.pam [options]`: renders a model offscreen the way the web
// viewer draws it (multiplex/render: same projection, texture filtering and shading) from a
// given or default camera. Used to compare the viewer's frames with the C++ renderer, and for
// previews.
#pragma once

#include <string>
#include <vector>

namespace meshmux {

// Exit codes as the other commands: 0 ok, 1 usage, 2 input, 3 output, 4 internal (no EGL/GL).
int cmd_render(const std::vector<std::string>& args);

}  // namespace meshmux
