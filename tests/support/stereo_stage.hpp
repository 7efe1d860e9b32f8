#pragma once

// The stereo stage as dco-depth and the pipeline make it (camera alignment included), over a
// synthetic scene's disparity range, with one switch of its parameters set: for tests that
// compare the stage with and without a step.

#include <memory>

#include <gtest/gtest.h>

#include "dco/core/image.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "support/same_bytes.hpp"

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

// The synthetic hand, grey and colour, 3 frames, through the stage with the step off and on: the
// same bytes each frame. `each` (optional) then checks the stage with the step on.
inline void expect_step_keeps_the_bytes(bool stereo::StereoParams::*member,
                                        void (*each)(const stereo::StereoMatcher&) = nullptr) {
  for (const bool color : {false, true}) {
    synthetic::SceneConfig config = synthetic::preset("hand", 320, 180);
    config.color = color;
    const synthetic::SceneRenderer scene(config);
    StereoStage off = stereo_stage(config, member, false), on = stereo_stage(config, member, true);
    synthetic::StereoSample s;
    for (int i = 0; i < 3; ++i) {
      scene.render(i, s);
      off.matcher->compute(s.left.cview(), s.right.cview(), off.disparity);
      on.matcher->compute(s.left.cview(), s.right.cview(), on.disparity);
      EXPECT_TRUE(same_bytes(off.disparity.cview(), on.disparity.cview()))
          << (color ? "colour" : "grey") << " frame " << i;
      if (each != nullptr) each(*on.matcher);
    }
  }
}

}  // namespace dco::testing
