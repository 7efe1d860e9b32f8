#pragma once

// The stereo stage as dco-depth and the pipeline make it (camera alignment included), over a
// synthetic scene's disparity range, with one switch of its parameters set: for tests that
// compare the stage with and without a step.

#include <memory>

#include "dco/core/image.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"

namespace dco::testing {

struct StereoStage {
  std::unique_ptr<stereo::StereoMatcher> matcher;
  Image<float> disparity;
};

// `member` is a bool of StereoParams (e.g. &StereoParams::exposure_balance), set to `on`.
inline StereoStage stereo_stage(const synthetic::SceneConfig& config,
                                bool stereo::StereoParams::*member, bool on) {
  stereo::StereoParams params;
  params.max_disparity = synthetic::covering_max_disparity(config);
  params.*member = on;
  return {stereo::make_stereo_matcher({}, params), {}};
}

}  // namespace dco::testing
