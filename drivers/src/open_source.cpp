#include <fmt/format.h>

#include "dco/core/error.hpp"
#include "sources.hpp"

namespace dco::drivers {

std::unique_ptr<FrameSource> open_source(std::string_view text) {
  SourceUri uri(text);
  if (uri.scheme() == "synthetic") return open_synthetic(uri);
  if (uri.scheme() == "replay") return open_replay(uri);
  if (uri.scheme() == "lcmlog") return open_lcmlog(uri);
  if (uri.scheme() == "indemind") return open_indemind(uri);
#ifdef DCO_HAVE_LIBCAMERA
  if (uri.scheme() == "libcamera") return open_libcamera(uri);
  constexpr const char* kAvailable =
      "synthetic://, replay://, lcmlog://, indemind://, libcamera://";
#else
  constexpr const char* kAvailable = "synthetic://, replay://, lcmlog://, indemind://";
#endif
  if (uri.scheme() == "libcamera")
    throw Error(fmt::format("source '{}': {}:// is not supported by this build (available: {})",
                            text, uri.scheme(), kAvailable));
  throw Error(fmt::format("source '{}': unknown scheme '{}' (available: {})", text, uri.scheme(),
                          kAvailable));
}

SourceStatus FrameSource::status() const {
  SourceStatus s;
  s.state = SourceStatus::State::kStreaming;
  s.device = info().description;
  return s;
}

}  // namespace dco::drivers
