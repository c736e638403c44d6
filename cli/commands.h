// The meshmux commands: each parses its arguments with the one flag table (cli/args.h), runs
// the library that does the work, and ends with an exit code (core/exit_codes.h). Progress and
// warnings go to stderr, data (info, render's summary) to stdout or the output file.
#pragma once

#include <string>
#include <vector>

namespace meshmux {

int cmd_convert(const std::vector<std::string>& args);   // convert_command.cpp
int cmd_info(const std::vector<std::string>& args);      // info_command.cpp
int cmd_simplify(const std::vector<std::string>& args);  // simplify_command.cpp
int cmd_sample(const std::vector<std::string>& args);    // sample_command.cpp
int cmd_batch(const std::vector<std::string>& args);     // batch_command.cpp
int cmd_serve(const std::vector<std::string>& args);     // serve_command.cpp
int cmd_render(const std::vector<std::string>& args);    // render_command.cpp

// `meshmux --help`: every command, the convert options, uploads, exit codes (main.cpp).
const char* meshmux_usage();

}  // namespace meshmux
