#include "core/stderr_progress.h"

#include <cctype>

namespace meshmux {

// What kind of warning a message is: the message with its numbers and quoted names blanked,
// so "geometry 'a': <lines> skipped (3 lines)" and "geometry 'b': <lines> skipped (9 lines)"
// are one kind.
std::string warning_kind(const std::string& message) {
  std::string kind;
  for (size_t i = 0; i < message.size(); ++i) {
    char c = message[i];
    if (c == '\'' || c == '"') {
      size_t end = message.find(c, i + 1);
      if (end != std::string::npos) {
        kind += "#";
        i = end;
        continue;
      }
    }
    if (std::isdigit(static_cast<unsigned char>(c))) {
      if (kind.empty() || kind.back() != '#') kind += '#';
      continue;
    }
    kind += c;
  }
  return kind;
}

}  // namespace meshmux
