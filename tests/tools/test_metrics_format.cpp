#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "dco/tools/metrics.hpp"

namespace dco::tools {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

std::vector<SceneMetrics> two_scenes() {
  SceneMetrics a, b;
  a.scene = "middlebury2014/Motorcycle";
  a.width = 741, a.height = 497;
  a.gt_pixels = 360593, a.predicted_pixels = 360593;
  a.density = 100;
  a.all = {360593, 10, 5, 1, 0.5};
  a.pred = a.all;
  a.has_nocc = true;
  a.nocc = {319078, 8, 4, 2, 0.25};
  a.nocc_pred = a.nocc;
  a.planes = {20, 25, 30, 35, 40};
  a.occ_err = 4, a.occ_err_pred = 4, a.band_err = 12, a.band_err_pred = 12;
  a.band_front = 9, a.band_behind = 3, a.band_edge = 7, a.band_surface = 5;
  a.time_ms = 30;
  a.has_matches = true;
  a.filled = 30;
  a.matched = {252415, 4, 2, 1, 0.25};
  a.filled_err = {108178, 24, 12, 6, 1.5};
  a.band_matched = 4.5, a.band_filled = 7.5;
  b.scene = "odd \"name\"";
  b.width = 4, b.height = 3;
  b.gt_pixels = 12;
  b.density = 0;
  b.all = {12, 100, 100, 100, 7};  // nothing predicted: pred numbers, time stay NaN
  b.planes = {1, 2, 3, 4, 5};
  b.occ_err = 100, b.band_err = 100;
  return {a, b};
}

TEST(MetricsFormat, TableHasFixedWidthRowsAndAMeanRow) {
  const std::string table = format_metrics_table(two_scenes());
  std::istringstream lines(table);
  std::vector<std::string> rows;
  for (std::string line; std::getline(lines, line);) rows.push_back(line);
  ASSERT_EQ(rows.size(), 5u);  // header, 2 scenes, mean, legend
  EXPECT_THAT(rows[0], HasSubstr("scene"));
  EXPECT_THAT(rows[0], HasSubstr("bad2p"));
  EXPECT_THAT(rows[0], HasSubstr("bandErr"));
  EXPECT_THAT(rows[0], HasSubstr("bandFr"));
  EXPECT_THAT(rows[0], HasSubstr("bandBh"));
  EXPECT_THAT(rows[0], HasSubstr("bandEdge"));
  EXPECT_THAT(rows[0], HasSubstr("bandSurf"));
  EXPECT_THAT(rows[0], HasSubstr("fill%"));
  EXPECT_THAT(rows[0], HasSubstr("bad2F"));
  EXPECT_THAT(rows[0], HasSubstr("bandM"));
  EXPECT_THAT(rows[0], HasSubstr("bandF"));
  EXPECT_THAT(rows[1], HasSubstr("4.50"));
  EXPECT_EQ(rows[1].rfind("middlebury2014/Motorcycle", 0), 0u);
  EXPECT_EQ(rows[3].rfind("mean ", 0), 0u);
  for (int i = 1; i <= 3; ++i) EXPECT_EQ(rows[i].size(), rows[0].size()) << rows[i];
  EXPECT_THAT(rows[1], HasSubstr("100.00"));
  EXPECT_THAT(rows[1], HasSubstr("0.500"));
  EXPECT_THAT(rows[2], HasSubstr(" -"));     // undefined numbers print as '-'
  EXPECT_THAT(rows[3], HasSubstr("50.00"));  // mean density
}

// A value too wide for its column's digits (a 16-bit ground truth read as pixels, one wild
// prediction) must not run into the cell before it.
TEST(MetricsFormat, AValueTooWideForItsCellKeepsTheColumnsApart) {
  std::vector<SceneMetrics> scenes = two_scenes();
  scenes[0].all.avgerr = 65530.0;
  scenes[0].pred.avgerr = -3e38;
  const std::string table = format_metrics_table(scenes);
  std::istringstream lines(table);
  std::vector<std::string> rows;
  for (std::string line; std::getline(lines, line);) rows.push_back(line);
  ASSERT_GE(rows.size(), 4u);
  for (int i = 1; i <= 3; ++i) EXPECT_EQ(rows[i].size(), rows[0].size()) << rows[i];
  EXPECT_THAT(rows[1], HasSubstr(" 6.6e+04"));
  EXPECT_THAT(rows[1], HasSubstr(" -3.0e+38"));
  EXPECT_THAT(rows[1], Not(HasSubstr("65530.000")));
}

TEST(MetricsFormat, JsonHoldsEveryScenePlusTheMean) {
  const std::string json = format_metrics_json(two_scenes());
  EXPECT_EQ(json.front(), '{');
  EXPECT_EQ(json.back(), '}');
  EXPECT_THAT(json, HasSubstr(R"("scene": "middlebury2014/Motorcycle", "width": 741)"));
  EXPECT_THAT(json, HasSubstr(R"("scene": "odd \"name\"")"));
  EXPECT_THAT(
      json,
      HasSubstr(R"("all": {"pixels": 360593, "bad1": 10, "bad2": 5, "bad4": 1, "avgerr": 0.5})"));
  EXPECT_THAT(json, HasSubstr(R"("nocc": null, "nocc_pred": null)"));
  EXPECT_THAT(json, HasSubstr(R"("planes": [20, 25, 30, 35, 40])"));
  EXPECT_THAT(json, HasSubstr(R"("time_ms": null)"));
  EXPECT_THAT(json, HasSubstr(R"("filled": 30, "matched": {"pixels": 252415, "bad1": 4, "bad2": )"
                              R"(2, "bad4": 1, "avgerr": 0.25}, "filled_err": {"pixels": 108178)"));
  EXPECT_THAT(json, HasSubstr(R"("band_matched": 4.5, "band_filled": 7.5})"));
  EXPECT_THAT(json, HasSubstr(R"("matches": null)"));  // the second scene has no sparse map
  EXPECT_THAT(json, HasSubstr(R"("band_err_pred": 12, "band_front": 9, "band_behind": 3, )"
                              R"("band_edge": 7, "band_surface": 5})"));
  EXPECT_THAT(json, HasSubstr(R"("mean": {"scene": "mean")"));
  EXPECT_THAT(json, HasSubstr(R"("density": 50)"));
  EXPECT_THAT(json, Not(HasSubstr("nan")));
  // Braces and brackets balance outside strings.
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < json.size(); ++i) {
    const char c = json[i];
    if (in_string) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        in_string = false;
      continue;
    }
    if (c == '"')
      in_string = true;
    else if (c == '{' || c == '[')
      ++depth;
    else if (c == '}' || c == ']')
      --depth;
    ASSERT_GE(depth, 0);
  }
  EXPECT_EQ(depth, 0);
  EXPECT_FALSE(in_string);
}

TEST(MetricsFormat, ComparisonOfKeyNumbers) {
  const std::vector<SceneMetrics> scenes = two_scenes();
  SceneMetrics a = scenes[0], b = scenes[0];
  b.density = 80, b.pred.bad2 = 10, b.all.bad2 = 0, b.occ_err = 8, b.band_err = 24, b.time_ms = 60;
  const std::vector<KeyComparison> rows = compare_key_metrics(a, b);
  ASSERT_EQ(rows.size(), 6u);
  EXPECT_EQ(rows[0].metric, "density");
  EXPECT_DOUBLE_EQ(rows[0].difference, 20);
  EXPECT_DOUBLE_EQ(rows[0].ratio, 1.25);
  EXPECT_EQ(rows[1].metric, "bad2_pred");
  EXPECT_DOUBLE_EQ(rows[1].ratio, 0.5);
  EXPECT_EQ(rows[2].metric, "bad2_all");
  EXPECT_TRUE(std::isnan(rows[2].ratio));  // division by zero is not defined
  EXPECT_EQ(rows[3].metric, "occ_err");
  EXPECT_EQ(rows[4].metric, "band_err");
  EXPECT_DOUBLE_EQ(rows[4].difference, -12);
  EXPECT_EQ(rows[5].metric, "time_ms");
  EXPECT_DOUBLE_EQ(rows[5].ratio, 0.5);

  const std::string table = format_comparison_table(rows, "dco", "sgbm-wls");
  EXPECT_THAT(table, HasSubstr("dco"));
  EXPECT_THAT(table, HasSubstr("sgbm-wls"));
  EXPECT_THAT(table, HasSubstr("+20.00"));
  EXPECT_THAT(table, HasSubstr("-12.00"));
  EXPECT_THAT(table, HasSubstr("1.250"));

  const std::string json = format_comparison_json(rows, "dco", "sgbm-wls");
  EXPECT_THAT(
      json,
      HasSubstr(R"("density": {"dco": 100, "sgbm-wls": 80, "difference": 20, "ratio": 1.25})"));
  EXPECT_THAT(
      json, HasSubstr(R"("bad2_all": {"dco": 5, "sgbm-wls": 0, "difference": 5, "ratio": null})"));
}

}  // namespace
}  // namespace dco::tools
