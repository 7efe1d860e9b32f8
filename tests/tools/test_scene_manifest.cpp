#include "dco/tools/scene_manifest.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "support/temp_dir.hpp"

namespace dco::tools {
namespace {

using dco::testing::TempDir;
using ::testing::HasSubstr;

const std::filesystem::path kDataDir = DCO_DATA_DIR;
const std::filesystem::path kManifest = kDataDir / "stereo_scenes.tsv";

constexpr const char* kHeader =
    "scene\tleft\tright\tgt\tgt_format\tgt_divisor\tnocc_mask\tmax_disp\n";

std::vector<Scene> load_real_manifest() {
  return load_scene_manifest(kManifest, kDataDir);
}

Scene real_scene(const std::string& name) {
  for (Scene& s : load_real_manifest())
    if (s.name == name) return s;
  ADD_FAILURE() << "no scene " << name;
  return {};
}

// Summary of a decoded GT map.
struct GtSummary {
  std::int64_t known = 0, unknown = 0;
  float min = INFINITY, max = -INFINITY;
  double known_fraction() const { return static_cast<double>(known) / (known + unknown); }
};

GtSummary summarize(const Image<float>& gt) {
  GtSummary s;
  for (int y = 0; y < gt.height(); ++y)
    for (int x = 0; x < gt.width(); ++x) {
      const float d = gt.at(x, y);
      if (d == INFINITY) {
        ++s.unknown;
        continue;
      }
      EXPECT_TRUE(std::isfinite(d) && d > 0) << "at " << x << "," << y << ": " << d;
      ++s.known;
      s.min = std::min(s.min, d);
      s.max = std::max(s.max, d);
    }
  return s;
}

// Every known value is a whole multiple of 1/divisor (the PNG encodings are integers).
bool all_multiples_of(const Image<float>& gt, float step) {
  for (int y = 0; y < gt.height(); ++y)
    for (int x = 0; x < gt.width(); ++x) {
      const float d = gt.at(x, y);
      if (d != INFINITY && std::fmod(d, step) != 0) return false;
    }
  return true;
}

std::string error_of(const std::filesystem::path& tsv) {
  try {
    load_scene_manifest(tsv, "/data");
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(SceneManifest, RealManifestListsTheEightScenes) {
  const std::vector<Scene> scenes = load_real_manifest();
  std::vector<std::string> names;
  std::vector<int> max_disps;
  for (const Scene& s : scenes) names.push_back(s.name), max_disps.push_back(s.max_disp);
  EXPECT_THAT(names,
              ::testing::ElementsAre("middlebury2014/Motorcycle", "middlebury2003/Teddy",
                                     "middlebury2001/Tsukuba", "middlebury2005/art",
                                     "middlebury2005/dolls", "middlebury2006/aloe",
                                     "kitti2015/000046", "sceneflow_flyingthings3d/A-0032-0006"));
  EXPECT_THAT(max_disps, ::testing::ElementsAre(80, 64, 16, 128, 128, 128, 96, 144));
}

TEST(SceneManifest, RealManifestResolvesFormatsAndPaths) {
  for (const Scene& s : load_real_manifest()) {
    SCOPED_TRACE(s.name);
    EXPECT_TRUE(std::filesystem::exists(s.left)) << s.left;
    EXPECT_TRUE(std::filesystem::exists(s.right)) << s.right;
    EXPECT_TRUE(std::filesystem::exists(s.gt)) << s.gt;
    // Every scene keeps its files in a folder named like the scene, under the data root.
    EXPECT_EQ(s.left.string().rfind((kDataDir / s.name).string() + "/", 0), 0u) << s.left;
    EXPECT_EQ(s.nocc_mask.has_value(), s.name == "middlebury2014/Motorcycle");
  }
  const Scene teddy = real_scene("middlebury2003/Teddy");
  EXPECT_EQ(teddy.gt_format, GroundTruthFormat::kPng);
  EXPECT_EQ(teddy.gt_divisor, 4);
  EXPECT_EQ(teddy.left, kDataDir / "middlebury2003/Teddy/im2.png");
  EXPECT_EQ(real_scene("kitti2015/000046").gt_divisor, 256);
  const Scene motorcycle = real_scene("middlebury2014/Motorcycle");
  EXPECT_EQ(motorcycle.gt_format, GroundTruthFormat::kPfm);
  EXPECT_EQ(*motorcycle.nocc_mask, kDataDir / "middlebury2014/Motorcycle/mask0nocc.png");
}

TEST(SceneManifest, FileStemReplacesSlashes) {
  EXPECT_EQ(real_scene("middlebury2014/Motorcycle").file_stem(), "middlebury2014_Motorcycle");
  EXPECT_EQ(real_scene("sceneflow_flyingthings3d/A-0032-0006").file_stem(),
            "sceneflow_flyingthings3d_A-0032-0006");
}

TEST(SceneManifest, ColumnsMayComeInAnyOrderWithCommentsAndCrlf) {
  TempDir dir;
  const auto tsv =
      dir.write("s.tsv",
                "# comment\r\n"
                "\n"
                "max_disp\tscene\tgt\tleft\tright\tnocc_mask\tgt_divisor\tgt_format\textra\r\n"
                "32\ta/b\tg.png\tl.png\tr.png\tm.png\t2.5\tpng\tignored\r\n");
  const std::vector<Scene> scenes = load_scene_manifest(tsv, "/data");
  ASSERT_EQ(scenes.size(), 1u);
  EXPECT_EQ(scenes[0].name, "a/b");
  EXPECT_EQ(scenes[0].max_disp, 32);
  EXPECT_EQ(scenes[0].gt_divisor, 2.5);
  EXPECT_EQ(scenes[0].gt, std::filesystem::path("/data/g.png"));
  EXPECT_EQ(scenes[0].left, std::filesystem::path("/data/l.png"));
  EXPECT_EQ(scenes[0].nocc_mask, std::filesystem::path("/data/m.png"));
}

TEST(SceneManifest, MalformedRowsNameFileAndLine) {
  TempDir dir;
  const std::string ok_row = "a\tl.png\tr.png\tg.pfm\tpfm\t1\t-\t64\n";
  struct Case {
    std::string content;
    std::string expected;  // after "FILE:"
  };
  const std::vector<Case> cases = {
      {std::string(kHeader) + "# comment\n" + ok_row + "b\tl.png\tr.png\tg.exr\texr\t1\t-\t64\n",
       "4: unknown gt_format 'exr'"},
      {std::string(kHeader) + "a\tl.png\tr.png\tg.pfm\tpfm\t1\t-\n", "2: 7 tab-separated fields"},
      {std::string(kHeader) + "a\tl.png\tr.png\tg.png\tpng\tfour\t-\t64\n",
       "2: gt_divisor 'four' is not a number"},
      {std::string(kHeader) + "a\tl.png\tr.png\tg.png\tpng\t0\t-\t64\n",
       "2: gt_divisor must be within 1e-6..1e6"},
      {std::string(kHeader) + "a\tl.png\tr.png\tg.png\tpng\t1e-50\t-\t64\n",
       "2: gt_divisor must be within 1e-6..1e6"},
      {std::string(kHeader) + "a\tl.png\tr.png\tg.pfm\tpfm\t4\t-\t64\n",
       "2: gt_divisor must be 1 for pfm"},
      {std::string(kHeader) + "a\tl.png\tr.png\tg.pfm\tpfm\t1\t-\t-3\n",
       "2: max_disp must be within 1..16384"},
      {std::string(kHeader) + "a\tl.png\tr.png\tg.pfm\tpfm\t1\t-\t2147483647\n",
       "2: max_disp must be within 1..16384"},
      {std::string(kHeader) + "a\tl.png\tr.png\tg.pfm\tpfm\t1\t-\t64px\n",
       "2: max_disp '64px' is not a number"},
      {std::string(kHeader) + "a\t\tr.png\tg.pfm\tpfm\t1\t-\t64\n", "2: column 'left' is empty"},
      {std::string(kHeader) + ok_row + ok_row, "3: scene 'a' listed twice"},
      {std::string(kHeader) + "x/y\tl.png\tr.png\tg.pfm\tpfm\t1\t-\t64\n" +
           "x_y\tl.png\tr.png\tg.pfm\tpfm\t1\t-\t64\n",
       "3: scenes 'x/y' and 'x_y' both have the file name 'x_y'"},
      {"# only a comment\nscene\tleft\tright\tgt\tgt_format\tgt_divisor\tmax_disp\n",
       "2: header has no column 'nocc_mask'"},
  };
  for (const Case& c : cases) {
    const auto tsv = dir.write("bad.tsv", c.content);
    EXPECT_THAT(error_of(tsv), HasSubstr(tsv.string() + ":" + c.expected)) << c.content;
  }
  EXPECT_THAT(error_of(dir.write("empty.tsv", "# nothing\n")), HasSubstr("no header row"));
  EXPECT_THAT(error_of(dir.path() / "missing.tsv"), HasSubstr("cannot open scene manifest"));
}

TEST(GroundTruth, TeddyPngIsQuarterPixels) {
  const GroundTruth gt = load_ground_truth(real_scene("middlebury2003/Teddy"));
  ASSERT_EQ(gt.disparity.width(), 450);
  ASSERT_EQ(gt.disparity.height(), 375);
  EXPECT_TRUE(gt.nocc.empty());
  const GtSummary s = summarize(gt.disparity);
  EXPECT_FLOAT_EQ(s.min, 12.5f);
  EXPECT_FLOAT_EQ(s.max, 52.75f);
  EXPECT_NEAR(s.known_fraction(), 0.98, 0.01);
  EXPECT_TRUE(all_multiples_of(gt.disparity, 0.25f));
}

TEST(GroundTruth, TsukubaPgmIsSixteenthPixelsWithIntegerValues) {
  const GroundTruth gt = load_ground_truth(real_scene("middlebury2001/Tsukuba"));
  ASSERT_EQ(gt.disparity.width(), 384);
  ASSERT_EQ(gt.disparity.height(), 288);
  EXPECT_TRUE(gt.nocc.empty());
  const GtSummary s = summarize(gt.disparity);
  EXPECT_EQ(s.min, 5.0f);
  EXPECT_EQ(s.max, 14.0f);
  EXPECT_NEAR(s.known_fraction(), 0.79, 0.02);
  EXPECT_TRUE(all_multiples_of(gt.disparity, 1.0f));
  EXPECT_EQ(gt.disparity.at(0, 0), INFINITY);  // the border band has no GT
}

TEST(GroundTruth, MotorcyclePfmComesWithItsNoccMask) {
  const GroundTruth gt = load_ground_truth(real_scene("middlebury2014/Motorcycle"));
  ASSERT_EQ(gt.disparity.width(), 741);
  ASSERT_EQ(gt.disparity.height(), 497);
  ASSERT_EQ(gt.nocc.width(), 741);
  ASSERT_EQ(gt.nocc.height(), 497);
  const GtSummary s = summarize(gt.disparity);
  EXPECT_NEAR(s.min, 9.2, 0.1);
  EXPECT_NEAR(s.max, 62.9, 0.1);

  // SOURCE.txt: 319078 pixels 255, 41515 pixels 128, 7684 pixels 0 (= no GT). Mask 0 and unknown GT
  // coincide only when the PFM rows were flipped to top-to-bottom.
  std::int64_t non_occluded = 0, occluded = 0, no_gt = 0, mismatched = 0;
  for (int y = 0; y < gt.nocc.height(); ++y)
    for (int x = 0; x < gt.nocc.width(); ++x) {
      const std::uint8_t m = gt.nocc.at(x, y);
      non_occluded += m == 255, occluded += m == 128, no_gt += m == 0;
      mismatched += (m == 0) != (gt.disparity.at(x, y) == INFINITY);
    }
  EXPECT_EQ(non_occluded, 319078);
  EXPECT_EQ(occluded, 41515);
  EXPECT_EQ(no_gt, 7684);
  EXPECT_EQ(s.unknown, 7684);
  EXPECT_EQ(mismatched, 0);
}

TEST(GroundTruth, OnlyMotorcycleHasANoccMask) {
  for (const Scene& scene : load_real_manifest()) {
    SCOPED_TRACE(scene.name);
    const GroundTruth gt = load_ground_truth(scene);
    EXPECT_EQ(!gt.nocc.empty(), scene.name == "middlebury2014/Motorcycle");
    EXPECT_GT(summarize(gt.disparity).known, 0);
  }
}

TEST(GroundTruth, OtherScenesDecodeToTheirDocumentedRanges) {
  struct Expected {
    const char* scene;
    int width, height;
    float min_at_least, max_at_most;
    double known_fraction, tolerance;
  };
  // Ranges and densities as documented in each folder's SOURCE.txt.
  const Expected cases[] = {
      {"kitti2015/000046", 1242, 375, 4.8f, 65.8f, 0.12, 0.03},
      {"sceneflow_flyingthings3d/A-0032-0006", 960, 540, 1.1f, 130.5f, 1.0, 0.0},
      {"middlebury2005/art", 695, 555, 0.5f, 128.0f, 0.9, 0.1},
      {"middlebury2006/aloe", 641, 555, 0.5f, 128.0f, 0.97, 0.01},
  };
  for (const Expected& e : cases) {
    SCOPED_TRACE(e.scene);
    const GroundTruth gt = load_ground_truth(real_scene(e.scene));
    EXPECT_EQ(gt.disparity.width(), e.width);
    EXPECT_EQ(gt.disparity.height(), e.height);
    const GtSummary s = summarize(gt.disparity);
    EXPECT_GE(s.min, e.min_at_least);
    EXPECT_LE(s.max, e.max_at_most);
    EXPECT_NEAR(s.known_fraction(), e.known_fraction, e.tolerance);
  }
  // KITTI is 16-bit: 1/256 px steps; the 2005 set is 8-bit RGB with the value in every channel.
  EXPECT_TRUE(
      all_multiples_of(load_ground_truth(real_scene("kitti2015/000046")).disparity, 1.0f / 256));
  EXPECT_TRUE(
      all_multiples_of(load_ground_truth(real_scene("middlebury2005/art")).disparity, 0.5f));
}

TEST(GroundTruth, MissingFileIsAnError) {
  Scene scene;
  scene.name = "x";
  scene.gt = "/nonexistent/gt.png";
  scene.gt_format = GroundTruthFormat::kPng;
  EXPECT_THROW(load_ground_truth(scene), Error);
  scene.gt = "/nonexistent/gt.pfm";
  scene.gt_format = GroundTruthFormat::kPfm;
  EXPECT_THROW(load_ground_truth(scene), Error);
}

// OpenCV reads by content and throws from some decoders: a corrupt file is a clear error too.
TEST(GroundTruth, CorruptPngIsAnError) {
  TempDir dir;
  Scene scene;
  scene.name = "x";
  scene.gt = dir.write("gt.png", std::string("Pf\n7 0\n-1\n") + std::string(64, '\0'));
  scene.gt_format = GroundTruthFormat::kPng;
  try {
    load_ground_truth(scene);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("cannot decode ground truth"));
  }
}

}  // namespace
}  // namespace dco::tools
