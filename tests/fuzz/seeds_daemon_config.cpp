// Seeds of the daemon configuration target: the defaults as dcod prints them, a hand-written file
// that sets a key of every type, and the pipeline lines a recording carries.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "dco/daemon/daemon_config.hpp"
#include "fuzz_target.hpp"

namespace dco::fuzz {
namespace {

constexpr std::string_view kHandWritten = R"(# dcod on a headset
[source]
uri = "indemind://?fps=50"

[ring]
slots = 6
image = false

[lcm]
preview_hz = 5.5
stats_hz = 2

[stereo]
max_disparity = 96
internal_resolution = "half"

[densify]
lambda_s = 1.5

[runtime]
affinity = "0,1"
)";

std::vector<std::uint8_t> bytes(std::string_view text) {
  return {text.begin(), text.end()};
}

}  // namespace

std::vector<std::vector<std::uint8_t>> seeds() {
  const daemon::LoadedConfig defaults = daemon::load_config({});
  return {bytes(defaults.toml), bytes(kHandWritten), bytes(daemon::pipeline_keys(defaults))};
}

}  // namespace dco::fuzz
