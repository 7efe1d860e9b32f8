#pragma once

// Text from outside (a command line, a source URI, a file's contents) as messages quote it.

#include <string>
#include <string_view>

namespace dco {

// `text` with every control character shown as '?': C0 (below 0x20), DEL, and C1 (U+0080..U+009F,
// 0xC2 0x80..0x9F in UTF-8, whose CSI some terminals obey; both bytes become one '?'). A log line
// stays one line, and a terminal or the journal gets no escape sequence from it.
inline std::string printable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    const bool c1 = c == 0xC2 && i + 1 < text.size() &&
                    static_cast<unsigned char>(text[i + 1]) >= 0x80 &&
                    static_cast<unsigned char>(text[i + 1]) <= 0x9F;
    if (c1) ++i;
    out += c < 0x20 || c == 0x7f || c1 ? '?' : text[i];
  }
  return out;
}

}  // namespace dco
