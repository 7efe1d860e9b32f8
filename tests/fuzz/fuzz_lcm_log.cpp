// libFuzzer entry point: arbitrary bytes as an LCM log. Reading never throws, never claims more
// bytes than there are, says where it stopped when it stopped early, and the events it read
// re-encode to exactly the bytes they came from.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "dco/drivers/lcm_log.hpp"
#include "fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dco::drivers;
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  std::istringstream in(bytes);
  LcmLogReader reader(in, "fuzz.log");
  std::ostringstream again;
  LcmLogEvent event;
  while (reader.next(event)) write_lcm_log_event(again, event);
  if (reader.bytes_read() > size) std::abort();
  if (reader.bytes_read() < size && reader.damage().empty()) std::abort();
  if (again.str() != bytes.substr(0, reader.bytes_read())) std::abort();
  return 0;
}
