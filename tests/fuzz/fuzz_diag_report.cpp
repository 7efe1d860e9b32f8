// libFuzzer entry point: arbitrary bytes as a dcod log for dco-diag. The report never crashes:
// a log without a single event is one dco::Error, anything else gives a digest whose counts add
// up, ordered latency percentiles, and a complete HTML document.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "dco/core/error.hpp"
#include "dco/diag/html_report.hpp"
#include "dco/diag/log_digest.hpp"
#include "dco/diag/log_summary.hpp"
#include "fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dco::diag;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  DigestOptions options;
  options.max_previews = 4;
  options.max_log_lines = 16;
  LogDigest d;
  try {
    d = digest_log(in, "fuzz.log", options);
  } catch (const dco::Error&) {
    return 0;  // no event at all
  }
  if (d.events < 1 || d.bytes > size) std::abort();
  long events = 0, frames = 0;
  for (const auto& [name, tally] : d.channels) {
    events += tally.events;
    if (tally.undecodable > tally.events) std::abort();
    if (name == "DCO_DEPTH") frames = tally.events - tally.undecodable;
  }
  if (events != d.events || frames != static_cast<long>(d.frames.size())) std::abort();
  if (d.previews.size() > options.max_previews || d.log.size() > options.max_log_lines)
    std::abort();
  const LogSummary s = summarize(d);
  if (s.frames > 0 &&
      !(s.latency.p50_ms <= s.latency.p90_ms && s.latency.p90_ms <= s.latency.p99_ms &&
        s.latency.p99_ms <= s.latency.max_ms))
    std::abort();
  const std::string html = html_report(d, s);
  if (html.find("</html>") == std::string::npos) std::abort();
  std::size_t open = 0, close = 0;
  for (std::size_t at = html.find("<svg "); at != std::string::npos;
       at = html.find("<svg ", at + 1))
    ++open;
  for (std::size_t at = html.find("</svg>"); at != std::string::npos;
       at = html.find("</svg>", at + 1))
    ++close;
  if (open != 8 || close != 8) std::abort();
  if (text_summary(d, s, "").empty() || json_summary(d, s).empty()) std::abort();
  return 0;
}
