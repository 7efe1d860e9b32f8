#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace dco::bench {

// The median of `v` (0 when empty); of an even count, the mean of the two middle values.
inline double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  return (*std::max_element(v.begin(), mid) + *mid) / 2;
}

}  // namespace dco::bench
