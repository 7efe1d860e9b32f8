#include <fmt/format.h>

#include "dco/core/error.hpp"
#include "sources.hpp"

namespace dco::drivers {

namespace {

#ifdef DCO_HAVE_LIBCAMERA
constexpr const char* kAvailable = "synthetic://, replay://, lcmlog://, indemind://, libcamera://";
#else
constexpr const char* kAvailable = "synthetic://, replay://, lcmlog://, indemind://";
#endif

// Throws dco::Error for a scheme this build cannot open.
void check_scheme(std::string_view text, const SourceUri& uri) {
  for (const char* known : {"synthetic", "replay", "lcmlog", "indemind"})
    if (uri.scheme() == known) return;
#ifdef DCO_HAVE_LIBCAMERA
  if (uri.scheme() == "libcamera") return;
#else
  if (uri.scheme() == "libcamera")
    throw Error(fmt::format("source '{}': {}:// is not supported by this build (available: {})",
                            text, uri.scheme(), kAvailable));
#endif
  throw Error(fmt::format("source '{}': unknown scheme '{}' (available: {})", text, uri.scheme(),
                          kAvailable));
}

}  // namespace

void check_source_uri(std::string_view text) {
  const SourceUri uri(text);
  check_scheme(text, uri);
}

std::unique_ptr<FrameSource> open_source(std::string_view text) {
  SourceUri uri(text);
  check_scheme(text, uri);
  if (uri.scheme() == "synthetic") return open_synthetic(uri);
  if (uri.scheme() == "replay") return open_replay(uri);
  if (uri.scheme() == "lcmlog") return open_lcmlog(uri);
#ifdef DCO_HAVE_LIBCAMERA
  if (uri.scheme() == "libcamera") return open_libcamera(uri);
#endif
  return open_indemind(uri);
}

SourceStatus FrameSource::status() const {
  SourceStatus s;
  s.state = SourceStatus::State::kStreaming;
  s.device = info().description;
  return s;
}

}  // namespace dco::drivers
