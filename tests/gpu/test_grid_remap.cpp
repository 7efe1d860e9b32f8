#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cstdint>
#include <memory>
#include <string>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/gpu/grid_pair_remapper.hpp"
#include "dco/gpu/host_grid.hpp"
#include "remap_cases.hpp"

namespace dco::gpu {
namespace {

std::unique_ptr<PairRemapper> host_remapper(const Rectifier& r) {
  return std::make_unique<GridPairRemapper<HostGrid>>(r.table(true), r.table(false),
                                                      r.input_width(), r.input_height());
}

TEST(GridRemap, RigsAreTheCpuRectifierBitForBit) {
  testing::expect_rigs_rectify_as_cpu(host_remapper);
}

// Maps made up to reach every one of the 1024 fractions and positions on, across and beyond the
// image border, against cv::remap itself.
TEST(GridRemap, EveryFractionAndBorderIsCvRemapBitForBit) {
  constexpr int kSrcW = 37, kSrcH = 23, kW = 64, kH = 48;
  cv::Mat xy(kH, kW, CV_16SC2), frac(kH, kW, CV_16UC1);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const int i = y * kW + x;
      xy.at<cv::Vec2s>(y, x) = cv::Vec2s(static_cast<short>((i * 7) % (kSrcW + 6) - 3),
                                         static_cast<short>((i / 5) % (kSrcH + 6) - 3));
      frac.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(i % 1024);
    }
  const RemapTable table{ImageView<const std::int16_t>(xy.ptr<std::int16_t>(), kW, kH, 2,
                                                       static_cast<int>(xy.step1())),
                         ImageView<const std::uint16_t>(frac.ptr<std::uint16_t>(), kW, kH, 1,
                                                        static_cast<int>(frac.step1()))};
  GridPairRemapper<HostGrid> remapper(table, table, kSrcW, kSrcH);
  for (int channels : {1, 3}) {
    const auto l = testing::raw_image(kSrcW, kSrcH, channels, 1);
    const auto r = testing::raw_image(kSrcW, kSrcH, channels, 2);
    Image<std::uint8_t> cv_l(kW, kH, channels), cv_r(kW, kH, channels), out_l(kW, kH, channels),
        out_r(kW, kH, channels);
    cv::Mat dst_l = as_mat(cv_l.view()), dst_r = as_mat(cv_r.view());
    cv::remap(as_mat(l.cview()), dst_l, xy, frac, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    cv::remap(as_mat(r.cview()), dst_r, xy, frac, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    remapper.remap(l.cview(), r.cview(), out_l.view(), out_r.view());
    EXPECT_TRUE(dco::testing::same_bytes(cv_l, out_l)) << channels << " channels";
    EXPECT_TRUE(dco::testing::same_bytes(cv_r, out_r)) << channels << " channels";
  }
}

TEST(GridRemap, WrongSizesAreAClearError) {
  const Rectifier rectifier(test::pinhole_rig());
  GridPairRemapper<HostGrid> remapper(rectifier.table(true), rectifier.table(false),
                                      rectifier.input_width(), rectifier.input_height());
  Image<std::uint8_t> raw(640, 480), small(320, 240), out_l(640, 480), out_r(640, 480);
  EXPECT_THROW(remapper.remap(small.cview(), raw.cview(), out_l.view(), out_r.view()), Error);
  EXPECT_THROW(remapper.remap(raw.cview(), raw.cview(), small.view(), out_r.view()), Error);
  // A pass-through has no maps.
  EXPECT_THROW(GridPairRemapper<HostGrid>({}, {}, 640, 480), Error);
}

}  // namespace
}  // namespace dco::gpu
