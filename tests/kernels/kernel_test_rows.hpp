#pragma once

// Inputs the row kernels' tests share: row widths around the lane counts of every target and
// random rows.

#include <cstdint>
#include <random>
#include <vector>

namespace dco::kernels {

// Widths around the lane counts of every target (4 .. 16 float lanes, SVE up to 64), odd ones,
// and rows too short for an interior.
inline const std::vector<int> kLaneWidths = {1,  2,  3,  4,  5,  8,  9,  15, 16,  17, 18,
                                             31, 32, 33, 34, 47, 64, 65, 66, 130, 257};

inline std::vector<float> random_floats(std::mt19937& rng, int n, float lo, float hi) {
  std::uniform_real_distribution<float> dist(lo, hi);
  std::vector<float> v(static_cast<std::size_t>(n));
  for (float& e : v) e = dist(rng);
  return v;
}

// Five rows of random grey levels (rows y - 2 .. y + 2 of a 5-row kernel) and their pointers.
struct RandomGreyRows {
  std::vector<std::uint8_t> rows[5];
  const std::uint8_t* pointers[5];

  RandomGreyRows(std::mt19937& rng, int width) {
    std::uniform_int_distribution<int> grey(0, 255);
    for (int k = 0; k < 5; ++k) {
      rows[k].resize(static_cast<std::size_t>(width));
      for (auto& e : rows[k]) e = static_cast<std::uint8_t>(grey(rng));
      pointers[k] = rows[k].data();
    }
  }
};

}  // namespace dco::kernels
