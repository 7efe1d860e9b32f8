#pragma once

// Text from outside (a command line, a source URI, a file's contents) as messages quote it.

#include <string>
#include <string_view>

namespace dco {

// `text` with every control character (below 0x20, and 0x7f) shown as '?': a log line stays one
// line, and a terminal or the journal gets no escape sequence from it.
inline std::string printable(std::string_view text) {
  std::string out(text);
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return out;
}

}  // namespace dco
