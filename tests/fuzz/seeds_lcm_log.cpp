#include <sstream>

#include "dco/drivers/lcm_log.hpp"
#include "fuzz_target.hpp"

namespace dco::fuzz {

// Logs of one and of three events, as lcm-logger writes them.
std::vector<std::vector<std::uint8_t>> seeds() {
  using namespace dco::drivers;
  std::vector<std::vector<std::uint8_t>> out;
  std::ostringstream all;
  for (int i = 0; i < 3; ++i) {
    LcmLogEvent e;
    e.number = i;
    e.timestamp_us = 1700000000000000 + 33000 * i;
    e.channel = i == 1 ? "DCO_STATS" : "DCO_RAW";
    e.data.assign(static_cast<std::size_t>(16 + 8 * i), static_cast<std::uint8_t>(i + 1));
    std::ostringstream one;
    write_lcm_log_event(one, e);
    write_lcm_log_event(all, e);
    const std::string s = one.str();
    out.emplace_back(s.begin(), s.end());
  }
  const std::string s = all.str();
  out.emplace_back(s.begin(), s.end());
  return out;
}

}  // namespace dco::fuzz
