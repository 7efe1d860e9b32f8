#include "dco/kernels/photometric_kernels.hpp"
#include "for_each_target.hpp"
#include "kernel_test_rows.hpp"

#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace dco::kernels {
namespace {

const std::vector<int>& kWidths = kLaneWidths;

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(PhotometricKernels, DerivativeRowMatchesScalarAndTheDifferences) {
  std::mt19937 rng(11);
  for_each_target([&] {
    for (const int w : kWidths) {
      const RandomGreyRows input(rng, w);
      const auto& rows = input.rows;
      const auto& pointers = input.pointers;
      std::vector<float> expected[6], actual[6];
      for (int k = 0; k < 6; ++k) {
        expected[k].assign(static_cast<std::size_t>(w), -1.0f);
        actual[k].assign(static_cast<std::size_t>(w), -2.0f);
      }
      const auto rows_of = [](std::vector<float>* v) {
        return DerivativeRows{v[0].data(), v[1].data(), v[2].data(),
                              v[3].data(), v[4].data(), v[5].data()};
      };
      scalar::derivative_row(pointers, w, rows_of(expected));
      derivative_row(pointers, w, rows_of(actual));
      for (int k = 0; k < 6; ++k) ASSERT_TRUE(same_bits(actual[k], expected[k])) << "w " << w;
      // The central differences where no column is clamped.
      for (int x = 2; x + 2 < w; ++x) {
        const auto at = [&](int r, int c) { return static_cast<float>(rows[r][c]); };
        EXPECT_EQ(actual[1][x], 0.5f * (at(2, x + 1) - at(2, x - 1)));
        EXPECT_EQ(actual[2][x], 0.5f * (at(3, x) - at(1, x)));
        EXPECT_EQ(actual[3][x], 0.25f * ((at(2, x + 2) - 2.0f * at(2, x)) + at(2, x - 2)));
      }
    }
  });
}

TEST(PhotometricKernels, TermsRowMatchesScalarForSmoothAndScatteredShifts) {
  std::mt19937 rng(12);
  const pixel::PhotometricWeights weights{20.0f, 2.0f, 20.0f};
  for_each_target([&] {
    for (const int w : kWidths)
      for (const int kind : {0, 1, 2}) {
        std::vector<float> left[6], right[6];
        for (int k = 0; k < 6; ++k) {
          left[k] = random_floats(rng, w, k == 0 ? 0.0f : -60.0f, k == 0 ? 255.0f : 60.0f);
          right[k] = random_floats(rng, w, k == 0 ? 0.0f : -60.0f, k == 0 ? 255.0f : 60.0f);
        }
        // 0: a smooth map (the contiguous loads), 1: disparities scattered over the row and
        // beyond it (the gathers and the clamps), 2: whole-pixel disparities.
        std::vector<float> d = kind == 1 ? random_floats(rng, w, -3.0f, 2.0f * w + 5.0f)
                                         : random_floats(rng, w, 4.0f, 4.9f);
        if (kind == 2)
          for (float& e : d) e = static_cast<float>(static_cast<int>(e));
        const std::vector<float> up = random_floats(rng, w, 0.0f, 8.0f);
        const std::vector<float> down = random_floats(rng, w, 0.0f, 8.0f);
        PhotometricTermRows in{};
        for (int k = 0; k < 6; ++k) in.left[k] = left[k].data(), in.right[k] = right[k].data();
        in.d = d.data(), in.d_up = up.data(), in.d_down = down.data(), in.width = w;
        std::vector<float> ea(d.size()), er(d.size()), es(d.size());
        std::vector<float> aa(d.size()), ar(d.size()), as(d.size());
        scalar::photometric_terms_row(in, weights, ea.data(), er.data(), es.data());
        photometric_terms_row(in, weights, aa.data(), ar.data(), as.data());
        ASSERT_TRUE(same_bits(aa, ea)) << "w " << w << " kind " << kind;
        ASSERT_TRUE(same_bits(ar, er)) << "w " << w << " kind " << kind;
        ASSERT_TRUE(same_bits(as, es)) << "w " << w << " kind " << kind;
        for (int x = 0; x < w; ++x) {
          EXPECT_GE(aa[x], 0.0f);
          EXPECT_GT(as[x], 0.0f);
        }
      }
  });
}

TEST(PhotometricKernels, CouplingsAndSorRowsMatchScalar) {
  std::mt19937 rng(13);
  for_each_target([&] {
    for (const int w : kWidths)
      for (const bool up : {false, true})
        for (const bool down : {false, true})
          for (const int first : {0, 1}) {
            const std::vector<float> a = random_floats(rng, w, 0.0f, 5.0f);
            const std::vector<float> s = random_floats(rng, w, 0.0f, 50.0f);
            const std::vector<float> s_down = random_floats(rng, w, 0.0f, 50.0f);
            const std::vector<float> wy_up = random_floats(rng, w, 0.0f, 50.0f);
            const CouplingRow c{a.data(), s.data(), down ? s_down.data() : nullptr,
                                up ? wy_up.data() : nullptr, w};
            std::vector<float> ewx(a.size()), ewy(a.size()), einv(a.size());
            std::vector<float> awx(a.size()), awy(a.size()), ainv(a.size());
            scalar::photometric_couplings_row(c, ewx.data(), ewy.data(), einv.data());
            photometric_couplings_row(c, awx.data(), awy.data(), ainv.data());
            ASSERT_TRUE(same_bits(awx, ewx) && same_bits(awy, ewy) && same_bits(ainv, einv))
                << "w " << w;
            if (w > 0) {
              EXPECT_EQ(awx[static_cast<std::size_t>(w - 1)], 0.0f);
              if (!down) {
                EXPECT_EQ(awy[0], 0.0f);
              }
            }

            const std::vector<float> rhs = random_floats(rng, w, 0.0f, 400.0f);
            const std::vector<float> d_up = random_floats(rng, w, 0.0f, 40.0f);
            const std::vector<float> d_down = random_floats(rng, w, 0.0f, 40.0f);
            const SorRow row{rhs.data(),
                             einv.data(),
                             ewx.data(),
                             ewy.data(),
                             up ? wy_up.data() : nullptr,
                             up ? d_up.data() : nullptr,
                             down ? d_down.data() : nullptr,
                             w};
            const std::vector<float> d0 = random_floats(rng, w, 0.0f, 40.0f);
            std::vector<float> expected = d0, actual = d0, scratch(a.size());
            scalar::sor_row(row, first, 1.6f, expected.data());
            sor_row(row, first, 1.6f, actual.data(), scratch.data());
            ASSERT_TRUE(same_bits(actual, expected)) << "w " << w << " first " << first;
            for (int x = 0; x < w; ++x) {
              if (x % 2 != first) {
                EXPECT_EQ(actual[x], d0[x]) << "the other colour stays";
              }
            }
          }
  });
}

// A pixel whose right image agrees with the left at its disparity gets no pull. On a ramp of
// slope g the right image's sample reads g s more than the left where the disparity that aligns
// them is s larger: the term's minimum lies there.
TEST(PhotometricPixel, DataTermPullsTowardsTheShiftThatAlignsARamp) {
  const pixel::PhotometricWeights weights{20.0f, 2.0f, 20.0f};
  const float g = 8.0f;
  const pixel::Derivatives left{100.0f, g, 0.0f, 0.0f, 0.0f, 0.0f};
  float a = 0, rhs = 0;
  pixel::photometric_data_term(left, left, 10.0f, weights, a, rhs);
  EXPECT_GT(a, 0.0f);
  EXPECT_FLOAT_EQ(rhs, (a + pixel::kPhotometricTiny) * 10.0f);
  // The right image's sample is 0.25 px "ahead": the aligning disparity is 10.25.
  const pixel::Derivatives right{100.0f + 0.25f * g, g, 0.0f, 0.0f, 0.0f, 0.0f};
  pixel::photometric_data_term(left, right, 10.0f, weights, a, rhs);
  EXPECT_NEAR(rhs / a, 10.25f, 1e-4f);
}

// Flat ground says nothing of the disparity: with no neighbour to pull it either (alpha 0) an SOR
// step keeps the pixel's value rather than sending it towards 0.
TEST(PhotometricPixel, APixelWithoutDataOrNeighboursKeepsItsDisparity) {
  const pixel::PhotometricWeights weights{0.0f, 2.0f, 20.0f};
  const pixel::Derivatives flat{100.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  float a = 1, rhs = 0;
  pixel::photometric_data_term(flat, flat, 12.5f, weights, a, rhs);
  EXPECT_EQ(a, 0.0f);
  const float inverse = pixel::photometric_inverse_diagonal(a, 0.0f, 0.0f, 0.0f, 0.0f);
  EXPECT_NEAR(
      pixel::sor_step(12.5f, rhs, inverse, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 1.6f),
      12.5f, 1e-3f);
}

}  // namespace
}  // namespace dco::kernels
