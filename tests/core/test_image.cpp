#include "dco/core/image.hpp"

#include <cstdint>
#include <new>

#include <gtest/gtest.h>

namespace dco {
namespace {

bool aligned(const void* p) {
  return reinterpret_cast<std::uintptr_t>(p) % 64 == 0;
}

TEST(Image, DefaultIsEmpty) {
  Image<float> img;
  EXPECT_TRUE(img.empty());
  EXPECT_TRUE(img.view().empty());
  EXPECT_EQ(img.width(), 0);
}

TEST(Image, RowsAre64ByteAligned) {
  Image<std::uint8_t> img(13, 7, 3);
  EXPECT_EQ(img.width(), 13);
  EXPECT_EQ(img.height(), 7);
  EXPECT_EQ(img.channels(), 3);
  EXPECT_EQ(img.stride(), 64);  // 39 bytes of pixels padded to one cache line
  for (int y = 0; y < img.height(); ++y) EXPECT_TRUE(aligned(img.row(y))) << "row " << y;

  Image<float> f(100, 3);
  EXPECT_EQ(f.stride() * sizeof(float) % 64, 0u);
  EXPECT_GE(f.stride(), 100);
  for (int y = 0; y < f.height(); ++y) EXPECT_TRUE(aligned(f.row(y)));
}

TEST(Image, ResizeReusesStorageWhenItFits) {
  Image<float> img;
  EXPECT_TRUE(img.resize(100, 50));
  float* const data = img.data();
  EXPECT_FALSE(img.resize(100, 50));
  EXPECT_FALSE(img.resize(40, 20));
  EXPECT_EQ(img.data(), data);
  EXPECT_EQ(img.width(), 40);
  EXPECT_EQ(img.height(), 20);
  EXPECT_FALSE(img.resize(100, 50));  // back to the original size: still no allocation
  EXPECT_EQ(img.data(), data);
  EXPECT_TRUE(img.resize(200, 100));
  EXPECT_EQ(img.width(), 200);
  EXPECT_TRUE(aligned(img.data()));
}

TEST(Image, AFailedResizeLeavesTheImageAsItWas) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "the sanitizers' allocators abort on a request this large";
#else
  Image<float> img(10, 10);
  img.fill(3.0f);
  const float* const data = img.data();
  // 2^62 bytes: no machine has them, so aligned_alloc returns null.
  EXPECT_THROW(img.resize(1 << 30, 1 << 30), std::bad_alloc);
  EXPECT_EQ(img.data(), data);
  EXPECT_EQ(img.width(), 10);
  EXPECT_EQ(img.height(), 10);
  EXPECT_EQ(img.at(9, 9), 3.0f);
  EXPECT_FALSE(img.resize(5, 5));  // the old storage still serves a smaller size
  EXPECT_EQ(img.data(), data);
  img.fill(1.0f);
  EXPECT_EQ(img.at(4, 4), 1.0f);
#endif
}

TEST(Image, FillAndAt) {
  Image<std::int16_t> img(5, 4, 2);
  img.fill(-3);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 5; ++x) {
      EXPECT_EQ(img.at(x, y, 0), -3);
      EXPECT_EQ(img.at(x, y, 1), -3);
    }
  img.at(4, 3, 1) = 7;
  EXPECT_EQ(img.row(3)[4 * 2 + 1], 7);
  EXPECT_EQ(img.view().at(4, 3, 1), 7);
}

TEST(ImageView, SubViewAliasesParent) {
  Image<int> img(10, 8, 2);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 10; ++x)
      for (int c = 0; c < 2; ++c) img.at(x, y, c) = y * 1000 + x * 10 + c;
  ImageView<int> sub = img.view().sub(3, 2, 4, 5);
  EXPECT_EQ(sub.width, 4);
  EXPECT_EQ(sub.height, 5);
  EXPECT_EQ(sub.channels, 2);
  EXPECT_EQ(sub.stride, img.stride());
  EXPECT_EQ(sub.at(0, 0, 0), 2 * 1000 + 3 * 10);
  EXPECT_EQ(sub.at(3, 4, 1), 6 * 1000 + 6 * 10 + 1);

  ImageView<int> subsub = sub.sub(1, 1, 2, 2);
  EXPECT_EQ(subsub.at(1, 1, 0), 4 * 1000 + 5 * 10);
  subsub.at(0, 0, 1) = -1;  // writes land in the parent
  EXPECT_EQ(img.at(4, 3, 1), -1);

  ImageView<const int> ro = sub;  // mutable -> const conversion
  EXPECT_EQ(ro.at(1, 1, 1), -1);
  EXPECT_TRUE(ro.same_size(4, 5));
  EXPECT_TRUE(ro.same_size(sub));
  EXPECT_FALSE(ro.same_size(subsub));
}

TEST(Image, CopyIsDeepAndMoveTransfers) {
  Image<std::uint8_t> a(6, 3);
  a.fill(9);
  Image<std::uint8_t> b = a;
  EXPECT_NE(b.data(), a.data());
  b.at(0, 0) = 1;
  EXPECT_EQ(a.at(0, 0), 9);

  const std::uint8_t* data = a.data();
  Image<std::uint8_t> c = std::move(a);
  EXPECT_EQ(c.data(), data);
  EXPECT_EQ(c.width(), 6);
  EXPECT_TRUE(a.empty());  // NOLINT(bugprone-use-after-move): moved-from is empty by contract

  b = std::move(c);
  EXPECT_EQ(b.data(), data);
  EXPECT_EQ(b.at(5, 2), 9);
}

TEST(Image, CopyFromStridedView) {
  Image<float> big(20, 10);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 20; ++x) big.at(x, y) = static_cast<float>(x + 100 * y);
  Image<float> small(5, 4);
  small.copy_from(big.cview().sub(7, 3, 5, 4));
  EXPECT_EQ(small.at(0, 0), 7 + 300);
  EXPECT_EQ(small.at(4, 3), 11 + 600);
}

}  // namespace
}  // namespace dco
