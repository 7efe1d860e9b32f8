#include "dco/kernels/canny_kernels.hpp"
#include "for_each_target.hpp"

#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <hwy/targets.h>

namespace dco::kernels {
namespace {

struct Rows {
  std::vector<float> above, row, below, gate;
  std::vector<std::uint8_t> direction;

  Rows(std::mt19937& rng, int w) {
    // Few distinct values, so equal neighbours (the >= / > tie rule) happen often.
    std::uniform_int_distribution<int> level(0, 8);
    std::uniform_int_distribution<int> dir(0, 3);
    for (auto* v : {&above, &row, &below, &gate}) {
      v->resize(static_cast<std::size_t>(w));
      for (float& e : *v) e = 0.01f * static_cast<float>(level(rng));
    }
    direction.resize(static_cast<std::size_t>(w));
    for (auto& e : direction) e = static_cast<std::uint8_t>(dir(rng));
  }

  CannyRow view(bool gated) const {
    CannyRow r;
    r.above = above.data();
    r.row = row.data();
    r.below = below.data();
    r.direction = direction.data();
    r.gate = gated ? gate.data() : nullptr;
    r.width = static_cast<int>(row.size());
    return r;
  }
};

TEST(CannyKernels, ClassifyRowMatchesScalar) {
  std::mt19937 rng(9);
  const CannyLevels levels{0.03f, 0.06f, 0.03f};
  for_each_target([&] {
    for (const int w : {1, 2, 3, 4, 7, 16, 17, 18, 33, 64, 66, 131, 257})
      for (const bool gated : {false, true}) {
        const Rows rows(rng, w);
        std::vector<std::uint8_t> expected(static_cast<std::size_t>(w), 7),
            actual(expected.size(), 7);
        scalar::canny_classify_row(rows.view(gated), levels, expected.data());
        canny_classify_row(rows.view(gated), levels, actual.data());
        ASSERT_EQ(actual, expected) << "w " << w << " gated " << gated;
      }
  });
}

TEST(CannyKernels, GateRowMatchesScalarAndTheRule) {
  // Gate values on both sides of depth and at it exactly; in place too (out = classes).
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> pick(0, 2), level(0, 6);
  const std::uint8_t classes_of[3] = {kCannyNone, kCannyWeak, kCannyStrong};
  const float depth = 0.03f;
  for_each_target([&] {
    for (const int w : {0, 1, 3, 15, 16, 17, 31, 64, 65, 130, 257}) {
      std::vector<std::uint8_t> classes(static_cast<std::size_t>(w));
      std::vector<float> gate(classes.size());
      for (auto& c : classes) c = classes_of[pick(rng)];
      for (float& g : gate) g = 0.01f * static_cast<float>(level(rng));
      std::vector<std::uint8_t> expected(classes.size(), 7), actual(classes.size(), 7);
      scalar::canny_gate_row(classes.data(), gate.data(), depth, w, expected.data());
      canny_gate_row(classes.data(), gate.data(), depth, w, actual.data());
      ASSERT_EQ(actual, expected) << "w " << w;
      for (int x = 0; x < w; ++x)
        ASSERT_EQ(expected[x], gate[x] < depth ? kCannyNone : classes[x])
            << "w " << w << " x " << x;
      canny_gate_row(classes.data(), gate.data(), depth, w, classes.data());
      ASSERT_EQ(classes, expected) << "in place, w " << w;
    }
  });
}

TEST(CannyKernels, ClassifiesByDirectionThresholdsAndGate) {
  // Column 2 is 0.1 (above high) with neighbours 0.05 to its left and right and 0.2 above it.
  std::vector<float> above(5, 0.0f), row = {0, 0.05f, 0.1f, 0.05f, 0}, below(5, 0.0f);
  std::vector<float> gate(5, 1.0f);
  above[2] = 0.2f;
  std::vector<std::uint8_t> direction(5, 0), out(5);
  CannyRow r{above.data(), row.data(), below.data(), direction.data(), nullptr, 5};
  const CannyLevels levels{0.03f, 0.06f, 0.03f};
  canny_classify_row(r, levels, out.data());
  EXPECT_EQ(out[2], kCannyStrong);  // a maximum along x
  EXPECT_EQ(out[1], kCannyNone);    // not a maximum
  EXPECT_EQ(out[0], kCannyNone);    // border
  direction[2] = 2;                 // compare along y: 0.2 above wins
  canny_classify_row(r, levels, out.data());
  EXPECT_EQ(out[2], kCannyNone);
  direction[2] = 0;
  row[2] = 0.05f, row[1] = row[3] = 0.04f;  // a maximum between low and high
  canny_classify_row(r, levels, out.data());
  EXPECT_EQ(out[2], kCannyWeak);
  r.gate = gate.data();
  gate[2] = 0.02f;  // below T_depth: gated away
  canny_classify_row(r, levels, out.data());
  EXPECT_EQ(out[2], kCannyNone);
}

}  // namespace
}  // namespace dco::kernels
