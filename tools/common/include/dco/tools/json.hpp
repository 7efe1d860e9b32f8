#pragma once

#include <string>
#include <string_view>

// The few pieces of JSON output the tools need; the documents are small and written by hand.
namespace dco::tools {

// A JSON string literal: quotes added, '"', '\\' and control characters escaped. Bytes >= 0x80 pass
// through unchanged (UTF-8 stays UTF-8).
std::string json_string(std::string_view text);

// The shortest text that reads back as the same double; "null" for NaN and infinities, which JSON
// cannot express (dco uses NaN for "not defined", e.g. an error rate over zero pixels).
std::string json_number(double value);

}  // namespace dco::tools
