#pragma once

#include <memory>

#include "dco/drivers/frame_source.hpp"
#include "dco/drivers/source_uri.hpp"

namespace dco::drivers {

// One per scheme; each reads its parameters from the URI and calls uri.finish().
std::unique_ptr<FrameSource> open_synthetic(SourceUri& uri);
std::unique_ptr<FrameSource> open_replay(SourceUri& uri);

}  // namespace dco::drivers
