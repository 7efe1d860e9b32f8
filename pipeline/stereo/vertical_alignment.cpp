#include "dco/pipeline/stereo/vertical_alignment.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

namespace dco::stereo {
namespace {

constexpr double kSamples = 4096;         // pixels a step looks at: one offset needs few
constexpr double kSearchSamples = 16384;  // and a search (a sequence's first frame only)
constexpr int kMinStep = 8;               // vertical grey step (levels over two rows) a pair needs
constexpr double kOutlier = 40.0;         // levels apart that leave a pair out
constexpr int kSearchSteps = 3;           // Gauss-Newton steps after a search
constexpr int kTrackSteps = 1;            // and from the offset in force (one per frame)
constexpr int kMinSearchSamples = 50;     // samples a search needs

struct Sampler {
  ImageView<const std::uint8_t> left, right;
  ImageView<const float> disparity;
  const ExposureMap& levels;
  int step;

  // The exposure map of channel k (a grey map serves every channel).
  const ChannelLevels& map_of(int k) const {
    return levels.channels[static_cast<std::size_t>(std::min(k, levels.count - 1))];
  }

  // Right level of channel k at (x, y), bilinear, rows and columns clamped to the image.
  double right_at(double x, double y, int k) const {
    const int c = right.channels;
    const double fx = std::floor(x), fy = std::floor(y);
    const int x0 = std::clamp(static_cast<int>(fx), 0, right.width - 1);
    const int x1 = std::min(x0 + 1, right.width - 1);
    const int y0 = std::clamp(static_cast<int>(fy), 0, right.height - 1);
    const int y1 = std::clamp(static_cast<int>(fy) + 1, 0, right.height - 1);
    const double tx = x - fx, ty = y - fy;
    const std::uint8_t* r0 = right.row(y0);
    const std::uint8_t* r1 = right.row(y1);
    const double top = r0[x0 * c + k] + tx * (r0[x1 * c + k] - r0[x0 * c + k]);
    const double bottom = r1[x0 * c + k] + tx * (r1[x1 * c + k] - r1[x0 * c + k]);
    const ChannelLevels& m = map_of(k);
    return m.gain * (top + ty * (bottom - top)) + m.offset;
  }

  // Right level of channel k at a whole pixel, clamped to the image.
  double right_level(int x, int y, int k) const {
    const int xc = std::clamp(x, 0, right.width - 1), yc = std::clamp(y, 0, right.height - 1);
    const ChannelLevels& m = map_of(k);
    return m.gain * right.row(yc)[xc * right.channels + k] + m.offset;
  }

  // Calls pair(x_right, y, left level, channel) for every sampled matched pixel with a vertical
  // grey step.
  template <class Pair>
  void each(Pair&& pair) const {
    const int c = std::min(left.channels, 3);
    for (int y = 1; y + 1 < left.height; y += step) {
      const float* d = disparity.row(y);
      const std::uint8_t* up = left.row(y - 1);
      const std::uint8_t* row = left.row(y);
      const std::uint8_t* down = left.row(y + 1);
      for (int x = 0; x < left.width; x += step) {
        const double at = x - static_cast<double>(d[x]);
        if (!(at >= 0.0 && at <= right.width - 1.0)) continue;  // no match (+inf, NaN) or outside
        for (int k = 0; k < c; ++k) {
          const int i = x * c + k;
          if (std::abs(down[i] - up[i]) < kMinStep) continue;
          pair(at, y, static_cast<double>(row[i]), k);
        }
      }
    }
  }
};

// For sampled matched pixels with grey steps both ways, the row offset (-3 .. +3, to a tenth by
// a parabola) at which a 5x5 window of the right image, within two columns of the match, differs
// least from the left's.
std::vector<double> best_rows(const Sampler& s) {
  std::vector<double> rows;
  const int c = std::min(s.left.channels, 3);
  const int w = s.left.width, h = s.left.height;
  constexpr int kRadius = 2, kColumns = 2, kRows = 3;
  for (int y = kRadius + 1; y + kRadius + 1 < h; y += s.step) {
    const float* d = s.disparity.row(y);
    for (int x = kRadius + 1; x + kRadius + 1 < w; x += s.step) {
      const double at = x - static_cast<double>(d[x]);
      if (!(at >= 0.0 && at <= w - 1.0)) continue;
      const std::uint8_t* up = s.left.row(y - 1);
      const std::uint8_t* down = s.left.row(y + 1);
      const std::uint8_t* row = s.left.row(y);
      const int g = (c == 3 ? 1 : 0);  // green, or the grey level
      if (std::abs(down[x * c + g] - up[x * c + g]) < kMinStep ||
          std::abs(row[(x + 1) * c + g] - row[(x - 1) * c + g]) < kMinStep)
        continue;
      const int xr = static_cast<int>(std::lround(at));
      std::array<double, 2 * kRows + 1> cost{};
      for (int dy = -kRows; dy <= kRows; ++dy) {
        double best = -1;
        for (int dx = -kColumns; dx <= kColumns; ++dx) {
          double sum = 0;
          for (int j = -kRadius; j <= kRadius; ++j)
            for (int i = -kRadius; i <= kRadius; ++i) {
              const double l = s.left.row(y + j)[(x + i) * c + g];
              sum += std::abs(l - s.right_level(xr + dx + i, y + j + dy, g));
            }
          if (best < 0 || sum < best) best = sum;
        }
        cost[static_cast<std::size_t>(dy + kRows)] = best;
      }
      const auto lowest = std::min_element(cost.begin(), cost.end());
      const int k = static_cast<int>(lowest - cost.begin());
      if (k == 0 || k == 2 * kRows) continue;  // at the window's edge: no minimum inside it
      const double a = cost[std::size_t(k - 1)], b = cost[std::size_t(k)],
                   e = cost[std::size_t(k + 1)];
      const double curve = a - 2 * b + e;
      const double sub = curve > 0 ? 0.5 * (a - e) / curve : 0.0;
      rows.push_back(k - kRows + std::clamp(sub, -0.5, 0.5));
    }
  }
  return rows;
}

// The most common value: the fullest eighth of a row, then the mean of the values within a
// quarter row of it. Samples whose matches were wrong spread over the whole window; the right
// ones gather.
double mode(const std::vector<double>& values) {
  constexpr int kBins = 48;  // -3 .. +3 rows in eighths
  std::array<int, kBins> count{};
  const auto bin = [](double v) {
    return std::clamp(static_cast<int>((v + 3.0) * 8.0), 0, kBins - 1);
  };
  for (const double v : values) ++count[static_cast<std::size_t>(bin(v))];
  const int peak = static_cast<int>(std::max_element(count.begin(), count.end()) - count.begin());
  const double centre = (peak + 0.5) / 8.0 - 3.0;
  double sum = 0;
  int n = 0;
  for (const double v : values)
    if (std::abs(v - centre) <= 0.25) sum += v, ++n;
  return sum / n;
}

}  // namespace

bool fit_vertical_offset(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                         ImageView<const float> disparity, const ExposureMap& levels, bool search,
                         double& offset) {
  const double pixels = static_cast<double>(left.width) * left.height;
  const auto step_for = [&](double samples) {
    return std::max(2, static_cast<int>(std::ceil(std::sqrt(pixels / samples))));
  };
  const Sampler s{left, right, disparity, levels, step_for(kSamples)};
  double v = offset;
  if (search) {
    // Each sample's own best row in a small window, then the most common one: the matches of a pair
    // that is off vertically fit the offset they were made at, so they cannot tell the way out
    // by themselves (bench/RESULTS.md).
    const Sampler wide{left, right, disparity, levels, step_for(kSearchSamples)};
    const std::vector<double> rows = best_rows(wide);
    if (static_cast<int>(rows.size()) < kMinSearchSamples) return false;
    v = mode(rows);
  }
  for (int i = 0; i < (search ? kSearchSteps : kTrackSteps); ++i) {
    double jr = 0, jj = 0;
    int used = 0;
    s.each([&](double xr, int y, double l, int k) {
      const double r = l - s.right_at(xr, y + v, k);
      if (std::abs(r) > kOutlier) return;
      const double j = 0.5 * (s.right_at(xr, y + v + 1, k) - s.right_at(xr, y + v - 1, k));
      jr += j * r, jj += j * j, ++used;
    });
    if (used < kMinAlignmentPairs || !(jj > 0)) return false;
    v += std::clamp(jr / jj, -1.0, 1.0);  // one row at most per step
  }
  if (!(std::abs(v) <= kMaxVerticalOffset)) return false;
  offset = v;
  return true;
}

void shift_rows(ImageView<const std::uint8_t> right, double offset, Image<std::uint8_t>& out) {
  out.resize(right.width, right.height, right.channels);
  const int whole = static_cast<int>(std::floor(offset));
  const int w1 = static_cast<int>(std::lround((offset - whole) * 256.0));  // weight of row + 1
  const int n = right.width * right.channels;
  for (int y = 0; y < right.height; ++y) {
    const std::uint8_t* a = right.row(std::clamp(y + whole, 0, right.height - 1));
    const std::uint8_t* b = right.row(std::clamp(y + whole + 1, 0, right.height - 1));
    std::uint8_t* o = out.view().row(y);
    for (int i = 0; i < n; ++i)
      o[i] = static_cast<std::uint8_t>((a[i] * (256 - w1) + b[i] * w1 + 128) >> 8);
  }
}

}  // namespace dco::stereo
