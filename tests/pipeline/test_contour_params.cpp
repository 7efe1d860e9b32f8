#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "dco/core/config.hpp"
#include "dco/core/error.hpp"
#include "dco/core/usable_cpus.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"
#include "support/one_cpu.hpp"

namespace dco::contour {
namespace {

using ::testing::HasSubstr;

std::string validate_error(const ContourParams& p) {
  try {
    validate(p);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ContourParams, DefaultsAreValidAndFollowThePaper) {
  const ContourParams p;
  EXPECT_NO_THROW(validate(p));
  EXPECT_NO_THROW(make_cpu_contour_extractor(p));
  EXPECT_DOUBLE_EQ(p.t_high, 0.06);  // §7.2
  EXPECT_DOUBLE_EQ(p.t_low, 0.03);
  EXPECT_DOUBLE_EQ(p.t_depth, 0.03);
}

TEST(ContourParams, ValidateRejectsEachInvalidField) {
  struct Case {
    const char* name;
    std::function<void(ContourParams&)> change;
    const char* message;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Case> cases = {
      {"preset", [](ContourParams& p) { p.dis_preset = "slow"; }, "dis_preset"},
      {"preset case", [](ContourParams& p) { p.dis_preset = "Fast"; }, "dis_preset"},
      {"parallel flow", [](ContourParams& p) { p.parallel_flow = "yes"; }, "parallel_flow"},
      {"row threads -1", [](ContourParams& p) { p.row_threads = -1; }, "row_threads"},
      {"row threads 17", [](ContourParams& p) { p.row_threads = 17; }, "row_threads"},
      {"projection 0", [](ContourParams& p) { p.projection_distance = 0; }, "projection_distance"},
      {"projection 65", [](ContourParams& p) { p.projection_distance = 65; },
       "projection_distance"},
      {"box even", [](ContourParams& p) { p.box_size = 8; }, "box_size"},
      {"box 0", [](ContourParams& p) { p.box_size = 0; }, "box_size"},
      {"box 257", [](ContourParams& p) { p.box_size = 257; }, "box_size"},
      {"floor < 0", [](ContourParams& p) { p.flow_floor = -1; }, "flow_floor"},
      {"floor NaN", [nan](ContourParams& p) { p.flow_floor = nan; }, "flow_floor"},
      {"floor subnormal", [](ContourParams& p) { p.flow_floor = 1e-39; }, "flow_floor"},
      {"floor under 1e-6", [](ContourParams& p) { p.flow_floor = 5e-7; }, "flow_floor"},
      {"stereo jump 0", [](ContourParams& p) { p.stereo_jump = 0; }, "stereo_jump"},
      {"stereo jump NaN", [nan](ContourParams& p) { p.stereo_jump = nan; }, "stereo_jump"},
      {"lookahead 2", [](ContourParams& p) { p.lookahead = 2; }, "lookahead"},
      {"t_low < 0", [](ContourParams& p) { p.t_low = -0.01; }, "t_low"},
      {"t_high > 1", [](ContourParams& p) { p.t_high = 1.5; }, "t_high"},
      {"t_high NaN", [nan](ContourParams& p) { p.t_high = nan; }, "t_high"},
      {"t_low > t_high", [](ContourParams& p) { p.t_low = 0.1; }, "must not exceed t_high"},
      {"t_depth > 1", [](ContourParams& p) { p.t_depth = 2; }, "t_depth"},
      {"t_depth NaN", [nan](ContourParams& p) { p.t_depth = nan; }, "t_depth"},
  };
  for (const Case& c : cases) {
    ContourParams p;
    c.change(p);
    const std::string error = validate_error(p);
    EXPECT_THAT(error, HasSubstr("contour parameters")) << c.name;
    EXPECT_THAT(error, HasSubstr(c.message)) << c.name;
    EXPECT_THROW(make_cpu_contour_extractor(p), Error) << c.name;
  }
}

TEST(ContourParams, ParallelFlowFollowsTheSettingAndTheCpus) {
  ContourParams p;
  p.parallel_flow = "on";
  EXPECT_TRUE(parallel_flow_fields(p));
  p.parallel_flow = "off";
  EXPECT_FALSE(parallel_flow_fields(p));
  p.parallel_flow = "auto";
  EXPECT_EQ(parallel_flow_fields(p), usable_cpus() >= 4);
  p.parallel_flow = "on";
  p.use_flow = false;  // no flow, no worker
  EXPECT_FALSE(parallel_flow_fields(p));
  p.use_flow = true;
  p.parallel_flow = "auto";
  const testing::OneCpu one;  // auto counts the CPUs this thread may use
  ASSERT_TRUE(one.ok());
  EXPECT_FALSE(parallel_flow_fields(p));
}

TEST(ContourParams, RegisteredUnderContourKeys) {
  ContourParams p;
  ConfigSchema schema;
  register_params(schema, p);
  for (const char* key :
       {"contour.use_flow", "contour.dis_preset", "contour.projection_distance", "contour.box_size",
        "contour.flow_floor", "contour.use_stereo", "contour.stereo_jump", "contour.lookahead",
        "contour.t_high", "contour.t_low", "contour.t_depth", "contour.parallel_flow"})
    EXPECT_TRUE(schema.has(key)) << key;
  schema.load_string("[contour]\nt_high = 0.1\ndis_preset = \"medium\"\nuse_flow = false\n",
                     "test");
  schema.set("contour.box_size=5");
  EXPECT_DOUBLE_EQ(p.t_high, 0.1);
  EXPECT_EQ(p.dis_preset, "medium");
  EXPECT_FALSE(p.use_flow);
  EXPECT_EQ(p.box_size, 5);
  EXPECT_THROW(schema.set("contour.dis_preset=slow"), Error);
  EXPECT_THROW(schema.set("contour.parallel_flow=2"), Error);
  EXPECT_THROW(schema.set("contour.t_depth=2"), Error);
  EXPECT_THROW(schema.set("contour.lookahead=3"), Error);
}

}  // namespace
}  // namespace dco::contour
