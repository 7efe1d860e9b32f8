// Seeds of the compositor scene target: a scene file with both kinds of object, comments, colours
// and CRLF line ends, and command-line objects.

#include <cstdint>
#include <string_view>
#include <vector>

#include "fuzz_target.hpp"

namespace dco::fuzz {
namespace {

constexpr std::string_view kScene =
    "# two objects behind the hand\n"
    "cube 0.1 -0.05 0.8 0.2 0.9 0.3 0.2\n"
    "sphere -0.2 0 1.5 0.25\r\n"
    "\n"
    "  cube\t0 0 3 1   # far\n";

std::vector<std::uint8_t> bytes(std::string_view text) {
  return {text.begin(), text.end()};
}

}  // namespace

std::vector<std::vector<std::uint8_t>> seeds() {
  return {bytes(kScene), bytes("0.1,0,0.8,0.2"), bytes("0,0.1,1.2,0.3,0.2,0.5,0.9")};
}

}  // namespace dco::fuzz
