#pragma once

// A reference of kernels::occlusion_fill_row written from its rule, for the kernel tests and the
// densifier's direct-solve check.

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace dco::kernels {

// The occlusion rule from the list of the row's hole runs: a run fits when the jump between
// its neighbours (far on the left) is at least 2 px and its width is from jump - a to
// jump + 4 a, a = max(2, jump / 4); its strip is its first `jump` (rounded) pixels. A run that
// does not fit alone is tried from the previous run's start when that run has no strip and at
// most 4 matches separate them (and it dropped no hints). Without `strips` no run holds one.
// Returns, per pixel, the far value it is pulled to; kNoHint for a hole that drops its hole hint: a
// run's holes from 2 past its strip on, and every hole of a run without a strip whose left
// neighbour is the nearer by 2 px or more; else 0. Counts the merged runs.
inline constexpr float kNoHint = -1.0f;
inline std::vector<float> occlusion_targets(const std::vector<float>& sparse, int* merged = nullptr,
                                            bool strips = true) {
  const auto known = [&](int i) {
    return sparse[i] > 0.0f && sparse[i] < std::numeric_limits<float>::infinity();
  };
  const int w = static_cast<int>(sparse.size());
  std::vector<std::pair<int, int>> runs;  // [start, end), both neighbours known
  for (int x = 1; x < w; ++x) {
    if (known(x) || !known(x - 1)) continue;
    int end = x;
    while (end < w && !known(end)) ++end;
    if (end < w) runs.emplace_back(x, end);
  }
  const auto strip = [&](int start, int end) {
    const float jump = sparse[end] - sparse[start - 1];
    const float a = std::max(2.0f, 0.25f * jump);
    const auto width = static_cast<float>(end - start);
    if (!(jump >= 2.0f) || width < jump - a || width > jump + 4.0f * a) return 0;
    return std::min(end - start, static_cast<int>(std::lround(jump)));
  };
  std::vector<float> target(sparse.size(), 0.0f);
  std::vector<bool> mergeable(runs.size(), false);  // no strip, no dropped hints
  for (std::size_t i = 0; i < runs.size(); ++i) {
    auto [start, end] = runs[i];
    const int own_start = start;
    int count = strips ? strip(start, end) : 0;
    if (strips && count == 0 && i > 0 && mergeable[i - 1] && start - runs[i - 1].second <= 4) {
      start = runs[i - 1].first;
      count = strip(start, end);
      if (merged != nullptr && count > 0) ++*merged;
    }
    for (int x = start; x < start + count; ++x) target[x] = sparse[start - 1];
    if (count > 0) {
      for (int x = start + count + 2; x < end; ++x)
        if (!known(x)) target[x] = kNoHint;
    } else if (sparse[own_start - 1] - sparse[end] >= 2.0f) {
      for (int x = own_start; x < end; ++x) target[x] = kNoHint;
    } else {
      mergeable[i] = true;
    }
  }
  return target;
}

}  // namespace dco::kernels
