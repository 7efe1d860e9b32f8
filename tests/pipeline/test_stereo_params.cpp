#include "dco/pipeline/stereo/stereo_params.hpp"

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "dco/core/config.hpp"
#include "dco/core/error.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"

namespace dco::stereo {
namespace {

using ::testing::HasSubstr;

struct Case {
  const char* name;
  std::function<void(StereoParams&)> change;
  const char* message;  // part of the error that names the field
};

std::string validate_error(const StereoParams& p) {
  try {
    validate(p);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(StereoParams, DefaultsAreValid) {
  EXPECT_NO_THROW(validate(StereoParams{}));
  EXPECT_NO_THROW(make_cpu_stereo_matcher(StereoParams{}));
}

TEST(StereoParams, ValidateRejectsEachInvalidField) {
  const std::vector<Case> cases = {
      {"max_disparity 0", [](StereoParams& p) { p.max_disparity = 0; }, "max_disparity"},
      {"max_disparity -3", [](StereoParams& p) { p.max_disparity = -3; }, "max_disparity"},
      {"resolution quarter", [](StereoParams& p) { p.internal_resolution = "quarter"; },
       "internal_resolution"},
      {"resolution case", [](StereoParams& p) { p.internal_resolution = "Half"; },
       "internal_resolution"},
      {"resolution empty", [](StereoParams& p) { p.internal_resolution = ""; },
       "internal_resolution"},
      {"search range partial", [](StereoParams& p) { p.search_range = "partial"; }, "search_range"},
      {"row_threads -1", [](StereoParams& p) { p.row_threads = -1; }, "row_threads"},
      {"row_threads 17", [](StereoParams& p) { p.row_threads = 17; }, "row_threads"},
      {"lambda_ad 0", [](StereoParams& p) { p.lambda_ad = 0; }, "lambda_ad"},
      {"lambda_census < 0", [](StereoParams& p) { p.lambda_census = -1; }, "lambda_census"},
      {"gamma_l < 0", [](StereoParams& p) { p.gamma_l = -0.1; }, "gamma_l"},
      {"epsilon 0", [](StereoParams& p) { p.epsilon = 0; }, "epsilon"},
      {"census width even", [](StereoParams& p) { p.census_width = 8; }, "census"},
      {"census height even", [](StereoParams& p) { p.census_height = 6; }, "census"},
      {"census width 0", [](StereoParams& p) { p.census_width = 0; }, "census"},
      {"census width negative odd", [](StereoParams& p) { p.census_width = -3; }, "census"},
      {"census too large 9x9", [](StereoParams& p) { p.census_height = 9; }, "census"},
      {"census too large 67x1",
       [](StereoParams& p) {
         p.census_width = 67;
         p.census_height = 1;
       },
       "census"},
      {"census 1x1",
       [](StereoParams& p) {
         p.census_width = 1;
         p.census_height = 1;
       },
       "census"},
      {"arm_max 1", [](StereoParams& p) { p.arm_max = 1; }, "arm_max"},
      {"arm_max 256", [](StereoParams& p) { p.arm_max = 256; }, "arm_max"},
      {"arm_short > arm_max", [](StereoParams& p) { p.arm_short = 35; }, "arm_short"},
      {"arm_short < 0", [](StereoParams& p) { p.arm_short = -1; }, "arm_short"},
      {"tau1 0", [](StereoParams& p) { p.tau1 = 0; }, "tau"},
      {"tau2 0", [](StereoParams& p) { p.tau2 = 0; }, "tau2"},
      {"tau2 > tau1", [](StereoParams& p) { p.tau2 = 21; }, "tau2"},
      {"tau1 256", [](StereoParams& p) { p.tau1 = 256; }, "255"},
      {"passes 0", [](StereoParams& p) { p.aggregation_passes = 0; }, "aggregation_passes"},
      {"passes 9", [](StereoParams& p) { p.aggregation_passes = 9; }, "aggregation_passes"},
      {"lr_max_diff -1", [](StereoParams& p) { p.lr_max_diff = -1; }, "lr_max_diff"},
      {"lr_max_diff 17", [](StereoParams& p) { p.lr_max_diff = 17; }, "lr_max_diff"},
      {"lr_max_diff INT_MAX",
       [](StereoParams& p) { p.lr_max_diff = std::numeric_limits<int>::max(); }, "lr_max_diff"},
      {"vote_iterations 17", [](StereoParams& p) { p.vote_iterations = 17; }, "vote_iterations"},
      {"vote_tolerance 17", [](StereoParams& p) { p.vote_tolerance = 17; }, "vote_tolerance"},
      {"vote_min_count 100001", [](StereoParams& p) { p.vote_min_count = 100001; },
       "vote_min_count"},
      {"max_neighbour_jump 65", [](StereoParams& p) { p.max_neighbour_jump = 65; },
       "max_neighbour_jump"},
      {"speckle_size 100001", [](StereoParams& p) { p.speckle_size = 100001; }, "speckle_size"},
      {"speckle_range 65", [](StereoParams& p) { p.speckle_range = 65; }, "speckle_range"},
      {"uniqueness 1", [](StereoParams& p) { p.uniqueness = 1.0; }, "uniqueness"},
      {"uniqueness < 0", [](StereoParams& p) { p.uniqueness = -0.01; }, "uniqueness"},
      {"vote_iterations -1", [](StereoParams& p) { p.vote_iterations = -1; }, "vote_iterations"},
      {"vote_min_count 0", [](StereoParams& p) { p.vote_min_count = 0; }, "vote_min_count"},
      {"vote_tolerance -1", [](StereoParams& p) { p.vote_tolerance = -1; }, "vote_tolerance"},
      {"vote_min_ratio > 1", [](StereoParams& p) { p.vote_min_ratio = 1.01; }, "vote_min_ratio"},
      {"vote_min_ratio < 0", [](StereoParams& p) { p.vote_min_ratio = -0.1; }, "vote_min_ratio"},
      {"max_neighbour_jump -2", [](StereoParams& p) { p.max_neighbour_jump = -2; },
       "max_neighbour_jump"},
      {"boundary_hole_reach 17", [](StereoParams& p) { p.boundary_hole_reach = 17; },
       "boundary_hole_reach"},
      {"boundary_hole_ratio 0", [](StereoParams& p) { p.boundary_hole_ratio = 0; },
       "boundary_hole_ratio"},
  };
  for (const Case& c : cases) {
    StereoParams p;
    c.change(p);
    const std::string error = validate_error(p);
    EXPECT_THAT(error, HasSubstr(c.message)) << c.name;
    EXPECT_THAT(error, HasSubstr("stereo parameters")) << c.name;
    EXPECT_THROW(make_cpu_stereo_matcher(p), Error) << c.name;
  }
}

TEST(StereoParams, ValidateAcceptsTheEdgesOfEachRange) {
  const std::vector<std::function<void(StereoParams&)>> edges = {
      [](StereoParams& p) { p.max_disparity = 1; },
      [](StereoParams& p) { p.internal_resolution = "full"; },
      [](StereoParams& p) { p.internal_resolution = "half"; },
      [](StereoParams& p) { p.gamma_l = 0; },
      [](StereoParams& p) {
        p.census_width = 13;  // 65 pixels: 64 comparisons
        p.census_height = 5;
      },
      [](StereoParams& p) {
        p.census_width = 1;
        p.census_height = 3;
      },
      [](StereoParams& p) {
        p.census_width = 1;
        p.census_height = 65;
      },
      [](StereoParams& p) {
        p.arm_max = 2;
        p.arm_short = 2;
      },
      [](StereoParams& p) { p.arm_max = 255; },
      [](StereoParams& p) { p.arm_short = 0; },
      [](StereoParams& p) { p.arm_short = p.arm_max; },
      [](StereoParams& p) { p.tau2 = p.tau1; },
      [](StereoParams& p) { p.tau1 = p.tau2 = 1; },
      [](StereoParams& p) { p.aggregation_passes = 1; },
      [](StereoParams& p) { p.aggregation_passes = 8; },
      [](StereoParams& p) { p.lr_max_diff = 0; },
      [](StereoParams& p) { p.uniqueness = 0; },
      [](StereoParams& p) { p.uniqueness = 0.999; },
      [](StereoParams& p) { p.vote_iterations = 0; },
      [](StereoParams& p) { p.vote_min_count = 1; },
      [](StereoParams& p) { p.vote_min_ratio = 0; },
      [](StereoParams& p) { p.vote_min_ratio = 1; },
      [](StereoParams& p) { p.vote_tolerance = 0; },
      [](StereoParams& p) { p.max_neighbour_jump = -1; },
      [](StereoParams& p) { p.max_neighbour_jump = 0; },
      [](StereoParams& p) { p.boundary_hole_reach = 0; },
      [](StereoParams& p) { p.boundary_hole_reach = 16; },
      [](StereoParams& p) { p.boundary_hole_ratio = 1; },
  };
  for (std::size_t i = 0; i < edges.size(); ++i) {
    StereoParams p;
    edges[i](p);
    EXPECT_EQ(validate_error(p), "") << "edge case " << i;
  }
}

TEST(InternalScale, AutoHalvesAbove640Pixels) {
  StereoParams p;
  EXPECT_EQ(internal_scale(p, 320), 1);
  EXPECT_EQ(internal_scale(p, 639), 1);
  EXPECT_EQ(internal_scale(p, 640), 1);
  EXPECT_EQ(internal_scale(p, 641), 2);
  EXPECT_EQ(internal_scale(p, 1280), 2);
  p.internal_resolution = "full";
  EXPECT_EQ(internal_scale(p, 320), 1);
  EXPECT_EQ(internal_scale(p, 1280), 1);
  p.internal_resolution = "half";
  EXPECT_EQ(internal_scale(p, 320), 2);
  EXPECT_EQ(internal_scale(p, 1280), 2);
}

TEST(RegisterParams, EveryFieldIsReachableFromConfig) {
  StereoParams p;
  const int default_passes = p.aggregation_passes;
  ConfigSchema schema;
  register_params(schema, p);
  for (const char* key : {"max_disparity",
                          "internal_resolution",
                          "use_color",
                          "lambda_ad",
                          "lambda_census",
                          "gamma_l",
                          "epsilon",
                          "census_width",
                          "census_height",
                          "arm_max",
                          "arm_short",
                          "tau1",
                          "tau2",
                          "smooth_arms",
                          "aggregation_passes",
                          "lr_max_diff",
                          "uniqueness",
                          "max_neighbour_jump",
                          "vote_iterations",
                          "vote_min_count",
                          "vote_min_ratio",
                          "vote_tolerance",
                          "vote_fill",
                          "subpixel"})
    EXPECT_TRUE(schema.has(std::string("stereo.") + key)) << key;

  schema.set("stereo.lambda_ad=12.5");
  schema.set("stereo.census_width=7");
  schema.set("stereo.internal_resolution=half");
  schema.set("stereo.use_color=false");
  EXPECT_EQ(p.lambda_ad, 12.5);
  EXPECT_EQ(p.census_width, 7);
  EXPECT_EQ(p.internal_resolution, "half");
  EXPECT_FALSE(p.use_color);
  EXPECT_NO_THROW(validate(p));

  EXPECT_THROW(schema.set("stereo.internal_resolution=quarter"), Error);
  EXPECT_THROW(schema.set("stereo.aggregation_passes=9"), Error);
  EXPECT_THROW(schema.set("stereo.uniqueness=1.0"), Error);
  EXPECT_EQ(p.aggregation_passes, default_passes);  // a rejected value changes nothing
}

}  // namespace
}  // namespace dco::stereo
