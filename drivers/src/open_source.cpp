#include <fmt/format.h>

#include "dco/core/error.hpp"
#include "sources.hpp"

namespace dco::drivers {

std::unique_ptr<FrameSource> open_source(std::string_view text) {
  SourceUri uri(text);
  if (uri.scheme() == "synthetic") return open_synthetic(uri);
  if (uri.scheme() == "replay") return open_replay(uri);
  if (uri.scheme() == "indemind" || uri.scheme() == "libcamera" || uri.scheme() == "lcmlog")
    throw Error(
        fmt::format("source '{}': {}:// is not supported by this build (available: "
                    "synthetic://, replay://)",
                    text, uri.scheme()));
  throw Error(fmt::format("source '{}': unknown scheme '{}' (available: synthetic://, replay://)",
                          text, uri.scheme()));
}

}  // namespace dco::drivers
