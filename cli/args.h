// The command line of every meshmux command: one table of flags (which commands take each, its
// value and range, whether batch hands it to every conversion) and one parser over it. A
// command reads what was given from ParsedArgs; a bad argument is one usage line naming the
// command and the flag, and exit code kExitUsage (core/exit_codes.h).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/status.h"
#include "importers/import.h"
#include "importers/upload.h"

namespace meshmux {

// The commands, as bits of Flag::commands.
enum Command : unsigned {
  kConvert = 1u << 0,
  kBatch = 1u << 1,
  kServe = 1u << 2,
  kRender = 1u << 3,
  kSimplify = 1u << 4,
  kInfo = 1u << 5,
  kSample = 1u << 6,
};
const char* command_name(Command c);

enum class FlagValue {
  kSwitch,  // no value
  kText,    // any value (non-empty)
  kWhole,   // a whole number in [lo, hi]
  kNumber,  // a number in [lo, hi] (an open end where open_lo, open_hi say so)
};

struct Flag {
  const char* name;         // "--jpeg-quality"
  const char* alias;        // a short spelling ("-o"), or nullptr
  unsigned commands;        // the commands that take it (Command bits)
  FlagValue value;          // what follows it
  double lo = 0, hi = 0;    // kWhole, kNumber: the accepted range
  bool open_lo = false;     // kNumber: lo itself is refused
  bool open_hi = false;     // kNumber: hi itself is refused
  bool to_convert = false;  // batch gives it to every conversion (a convert flag)
};

// The one table (cli/args.cpp). A name may appear twice for different commands (--max-memory:
// a positive number of MB for a conversion, at least 64 for batch's per-conversion limit).
const std::vector<Flag>& flag_table();

struct ParsedArgs {
  std::vector<std::string> positional;                     // in order
  std::vector<std::pair<const Flag*, std::string>> given;  // every flag, in order, its value
  bool help = false;                                       // -h or --help

  bool has(const char* name) const;
  // The last value given for the flag, or `fallback`.
  std::string text(const char* name, const std::string& fallback = "") const;
  long long whole(const char* name, long long fallback) const;
  double number(const char* name, double fallback) const;
  // The flags given that batch hands to every conversion, as arguments (flag, then value).
  std::vector<std::string> convert_args() const;
};

// Parses `args` (after the command's name) for `command`, which takes at most `max_positional`
// positional arguments. -h or --help anywhere: only `help` is set, whatever else is given. Errors
// (kInput), one line without the command's name: "unknown option
// --x", "--jobs expects a whole number from 1 to 1024, got '0'", "--host needs a value", "more
// than one input given ('a' and 'b')".
Result<ParsedArgs> parse_args(Command command, const std::vector<std::string>& args,
                              size_t max_positional = 1);

// Prints "meshmux: COMMAND: MESSAGE" and "(see meshmux [COMMAND] --help)" on stderr; returns
// kExitUsage.
int usage_error(Command command, const std::string& message);

// The upload and limit flags of convert, info and simplify (--main, --root, --allow-outside,
// --max-texels, --max-instances, --max-elements, --max-memory).
struct UploadFlags {
  ImportOptions import;
  UploadOptions upload;
  uint64_t max_memory_mb = 0;  // 0: from the input's size
};
UploadFlags upload_flags(const ParsedArgs& p);

// Whether `path` ends in `extension` (".glb"), in any case.
bool has_extension(const std::string& path, const char* extension);

// "WxH" with whole numbers 1..8192 into *w and *h (--size, --display); false for anything else.
bool parse_size(const std::string& text, int* w, int* h);

// The convert flags batch hands on, for its --help: "--position-bits N --no-draco ...".
std::string convert_flags_text();

}  // namespace meshmux
