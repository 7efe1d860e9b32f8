#include "dco/pipeline/stereo/exposure_balance.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "flat_pairs.hpp"

namespace dco::stereo {
namespace {

constexpr int kLevels = 256;
constexpr int kMinSpread = 16;    // levels between the darkest and brightest left level used
constexpr int kMinBinPairs = 4;   // pairs a left level needs to count towards the spread
constexpr double kOutlier = 3.0;  // levels off the first line that drop a left level's mean

// The right level's mean at each left level, over one channel's pairs.
struct LevelMeans {
  std::array<std::uint32_t, kLevels> count{};
  std::array<double, kLevels> sum{};
};

// Weighted least squares of right = a * left + b over the left levels' means; levels whose mean
// lies more than kOutlier off `previous` (when given) stay out.
bool fit_line(const LevelMeans& m, const double* previous, double& a, double& b) {
  double n = 0, sl = 0, sr = 0, sll = 0, slr = 0;
  for (int l = 0; l < kLevels; ++l) {
    const double count = m.count[static_cast<std::size_t>(l)];
    if (count == 0) continue;
    const double r = m.sum[static_cast<std::size_t>(l)] / count;
    if (previous != nullptr && std::abs(r - (previous[0] * l + previous[1])) > kOutlier) continue;
    n += count, sl += count * l, sr += count * r, sll += count * l * l, slr += count * l * r;
  }
  const double det = n * sll - sl * sl;
  if (!(n > 0 && det > 0)) return false;
  a = (n * slr - sl * sr) / det;
  b = (sr - a * sl) / n;
  return true;
}

enum class Fit : std::int8_t { kFitted, kTooDim, kFailed };

// kTooDim: the channel's levels spread too little to fit a line to (blue under warm light).
Fit fit_channel(const LevelMeans& m, ChannelLevels& out) {
  std::uint32_t pairs = 0;
  int low = kLevels, high = -1;
  for (int l = 0; l < kLevels; ++l) {
    const std::uint32_t count = m.count[static_cast<std::size_t>(l)];
    pairs += count;
    if (count >= kMinBinPairs) low = std::min(low, l), high = std::max(high, l);
  }
  if (pairs < kMinExposurePairs) return Fit::kFailed;
  if (high - low < kMinSpread) return Fit::kTooDim;
  double first[2];
  double a = 0, b = 0;
  if (!fit_line(m, nullptr, first[0], first[1]) || !fit_line(m, first, a, b)) return Fit::kFailed;
  // right = a * left + b, so a right level v is matched as (v - b) / a.
  if (!(a > 0)) return Fit::kFailed;
  const double gain = 1.0 / a;
  if (!(gain >= detail::kMinRightGain && gain <= detail::kMaxRightGain)) return Fit::kFailed;
  out = {gain, -b / a};
  return Fit::kFitted;
}

long mapped_level(const ChannelLevels& c, int v) {
  return std::clamp<long>(std::lround(c.gain * v + c.offset), 0, kLevels - 1);
}

// The pairs of every `step`-th row and column into each channel's level means.
void collect_pairs(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                   ImageView<const float> disparity, int step, std::array<LevelMeans, 3>& means) {
  detail::for_each_flat_pair(left, right, disparity, step,
                             [&](int k, int, int, int, int lv, int rv) {
                               LevelMeans& m = means[static_cast<std::size_t>(k)];
                               ++m.count[static_cast<std::size_t>(lv)];
                               m.sum[static_cast<std::size_t>(lv)] += rv;
                             });
}

std::uint32_t fewest_pairs(const std::array<LevelMeans, 3>& means, int channels) {
  std::uint32_t fewest = ~0u;
  for (int k = 0; k < channels; ++k) {
    std::uint32_t pairs = 0;
    for (const std::uint32_t n : means[static_cast<std::size_t>(k)].count) pairs += n;
    fewest = std::min(fewest, pairs);
  }
  return fewest;
}

}  // namespace

bool fit_exposure(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                  ImageView<const float> disparity, ExposureMap& map) {
  const int c = std::min(left.channels, 3);
  const int step = detail::fit_step(left.width, left.height);
  std::array<LevelMeans, 3> means;
  collect_pairs(left, right, disparity, step, means);
  // Cameras that differ leave few matches on flat ground (a tenth of a matched pair's): those
  // frames look at four times the pixels, so that the map that brings the matches back is found.
  const int dense_step = std::max(1, step / 2);
  if (fewest_pairs(means, c) < kMinExposurePairs && dense_step < step) {
    means = {};
    collect_pairs(left, right, disparity, dense_step, means);
  }
  ExposureMap fitted;
  fitted.count = c;
  std::array<Fit, 3> fits{};
  int fitting = 0;
  ChannelLevels mean{0.0, 0.0};
  for (int k = 0; k < c; ++k) {
    const auto ks = static_cast<std::size_t>(k);
    fits[ks] = fit_channel(means[ks], fitted.channels[ks]);
    // A channel whose fit fails for another reason (a slope the cameras cannot have) says the
    // frame cannot tell: the map stays as it was.
    if (fits[ks] == Fit::kFailed) return false;
    if (fits[ks] == Fit::kTooDim) continue;
    ++fitting;
    mean.gain += fitted.channels[ks].gain;
    mean.offset += fitted.channels[ks].offset;
  }
  if (fitting == 0) return false;
  // A channel with too little spread to fit (blue under warm light) was exposed as the others
  // were: it takes their mean map rather than leave every channel uncorrected.
  for (int k = 0; k < c; ++k)
    if (fits[static_cast<std::size_t>(k)] == Fit::kTooDim)
      fitted.channels[static_cast<std::size_t>(k)] = {mean.gain / fitting, mean.offset / fitting};
  map = fitted;
  return true;
}

int exposure_difference(const ExposureMap& a, const ExposureMap& b) {
  long most = 0;
  for (int k = 0; k < std::max(a.count, b.count); ++k) {
    const auto ks = static_cast<std::size_t>(k);
    const ChannelLevels ca = k < a.count ? a.channels[ks] : ChannelLevels{};
    const ChannelLevels cb = k < b.count ? b.channels[ks] : ChannelLevels{};
    for (int v = 0; v < kLevels; ++v)
      most = std::max(most, std::abs(mapped_level(ca, v) - mapped_level(cb, v)));
  }
  return static_cast<int>(most);
}

void ExposureTable::build(const ExposureMap& map) {
  count_ = map.count;
  identity_ = true;
  for (int k = 0; k < count_; ++k)
    for (int v = 0; v < kLevels; ++v) {
      const auto out = static_cast<std::uint8_t>(mapped_level(map.channels[std::size_t(k)], v));
      table_[std::size_t(k)][std::size_t(v)] = out;
      identity_ = identity_ && out == v;
    }
}

void ExposureTable::apply(ImageView<const std::uint8_t> right, Image<std::uint8_t>& out) const {
  out.resize(right.width, right.height, right.channels);
  const int c = right.channels;
  const int n = right.width * c;
  for (int y = 0; y < right.height; ++y) {
    const std::uint8_t* in = right.row(y);
    std::uint8_t* o = out.view().row(y);
    if (c == 3 && count_ == 3) {
      for (int i = 0; i < n; i += 3) {
        o[i] = table_[0][in[i]];
        o[i + 1] = table_[1][in[i + 1]];
        o[i + 2] = table_[2][in[i + 2]];
      }
    } else {
      for (int i = 0; i < n; ++i) o[i] = table_[0][in[i]];
    }
  }
}

}  // namespace dco::stereo
