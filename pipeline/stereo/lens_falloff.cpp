#include "dco/pipeline/stereo/lens_falloff.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <string>

#include <opencv2/core.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "flat_pairs.hpp"

namespace dco::stereo {
namespace {

constexpr int kMinPairs = 500;
// u (a pair's difference of r^2) must spread this much (its standard deviation): a far scene's
// small disparities put both views of a point at nearly one r, where no fall-off shows.
constexpr double kMinUSpread = 0.01;
constexpr double kMinK = -0.5, kMaxK = 0.75;
// A channel whose flat pairs' mean level is below this tells no fall-off: a level step there is
// 6 % and more, as much as the fall-off itself (blue under warm light; the whole of a very dark
// frame). The boxes scene at an eighth of its levels (mean 14) still fits k 0.35 within 0.03, at
// a twelfth (mean 9) 0.15 as 0.04.
constexpr double kMinMeanLevel = 16;
constexpr int kRounds = 3;  // linearised fits, each about the k of the one before

// The normal equations of right = a left + b + c (u left) over one channel's pairs.
struct Normals {
  std::array<std::array<double, 3>, 3> m{};
  std::array<double, 3> rhs{};
  double pairs = 0, u_sum = 0, u_squares = 0;

  void add(double left, double right, double u) {
    const std::array<double, 3> f = {left, 1.0, u * left};
    for (std::size_t i = 0; i < 3; ++i) {
      for (std::size_t j = 0; j < 3; ++j) m[i][j] += f[i] * f[j];
      rhs[i] += f[i] * right;
    }
    pairs += 1, u_sum += u, u_squares += u * u;
  }
};

// Solves the 3x3 system by Cramer's rule; false when it is singular.
bool solve(const Normals& n, std::array<double, 3>& p) {
  const auto& a = n.m;
  const auto det3 = [](const std::array<std::array<double, 3>, 3>& q) {
    return q[0][0] * (q[1][1] * q[2][2] - q[1][2] * q[2][1]) -
           q[0][1] * (q[1][0] * q[2][2] - q[1][2] * q[2][0]) +
           q[0][2] * (q[1][0] * q[2][1] - q[1][1] * q[2][0]);
  };
  const double det = det3(a);
  if (!(std::abs(det) > 0) || !std::isfinite(det)) return false;
  for (std::size_t col = 0; col < 3; ++col) {
    auto q = a;
    for (std::size_t row = 0; row < 3; ++row) q[row][col] = n.rhs[row];
    p[col] = det3(q) / det;
  }
  return true;
}

// The pairs with both levels corrected for the fall-off k0 (V0 = 1 - k0 r^2): about k0, the
// right level over the left one is a (1 - dk u) with u = r_R^2 / V0(r_R) - r_L^2 / V0(r_L), to
// first order in the rest dk of k.
std::array<Normals, 3> collect(ImageView<const std::uint8_t> left,
                               ImageView<const std::uint8_t> right,
                               ImageView<const float> disparity, int step, double k0) {
  std::array<Normals, 3> normals;
  const int w = left.width, h = left.height;
  detail::for_each_flat_pair(
      left, right, disparity, step, [&](int c, int x, int y, int xr, int lv, int rv) {
        const double rl = falloff_radius_squared(w, h, x, y);
        const double rr = falloff_radius_squared(w, h, xr, y);
        const double vl = 1.0 - k0 * rl, vr = 1.0 - k0 * rr;
        normals[static_cast<std::size_t>(c)].add(lv / vl, rv / vr, rr / vr - rl / vl);
      });
  return normals;
}

double fewest_pairs(const std::array<Normals, 3>& normals, int channels) {
  double fewest = 1e300;
  for (int k = 0; k < channels; ++k)
    fewest = std::min(fewest, normals[static_cast<std::size_t>(k)].pairs);
  return fewest;
}

bool fit_step_about(const std::array<Normals, 3>& normals, int channels, double& dk) {
  double weighted = 0, pairs = 0;
  for (int c = 0; c < channels; ++c) {
    const Normals& n = normals[static_cast<std::size_t>(c)];
    if (n.pairs < kMinPairs) return false;
    // Too dim to tell: the lens darkens it as the others, whose fit it takes.
    if (n.m[0][1] / n.pairs < kMinMeanLevel) continue;
    const double mean_u = n.u_sum / n.pairs;
    if (std::sqrt(std::max(0.0, n.u_squares / n.pairs - mean_u * mean_u)) < kMinUSpread)
      return false;
    std::array<double, 3> p{};
    if (!solve(n, p) || !(p[0] >= detail::kMinRightGain && p[0] <= detail::kMaxRightGain))
      return false;
    // right / left ~ a (1 - dk u): c = -a dk.
    weighted += n.pairs * (-p[2] / p[0]);
    pairs += n.pairs;
  }
  if (pairs == 0) return false;  // every channel too dim
  dk = weighted / pairs;
  return std::isfinite(dk);
}

}  // namespace

double falloff_radius_squared(int width, int height, double x, double y) {
  const double cx = 0.5 * (width - 1), cy = 0.5 * (height - 1);
  const double half_diagonal_squared = cx * cx + cy * cy;
  if (!(half_diagonal_squared > 0)) return 0.0;
  return ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / half_diagonal_squared;
}

bool fit_lens_falloff(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                      ImageView<const float> disparity, double& k) {
  const int channels = std::min(left.channels, 3);
  int step = detail::fit_step(left.width, left.height);
  std::array<Normals, 3> normals = collect(left, right, disparity, step, 0.0);
  // As the exposure fit: four times the pixels where the first look gives too few pairs.
  if (const int dense = std::max(1, step / 2);
      fewest_pairs(normals, channels) < kMinPairs && dense < step) {
    step = dense;
    normals = collect(left, right, disparity, step, 0.0);
  }
  // The model is linear in k only about a k known already: a few steps from 0, each about the
  // last (a rendered pair darkened by k 0.35 reads 0.384 after one step, 0.338 after three).
  double fitted = 0;
  for (int round = 0; round < kRounds; ++round) {
    if (round > 0) normals = collect(left, right, disparity, step, fitted);
    double dk = 0;
    if (!fit_step_about(normals, channels, dk)) return false;
    fitted += dk;
    if (!(fitted >= kMinK && fitted <= kMaxK)) return false;
  }
  // Corners brighter than the centre are no lens's doing: what a misfit or noise about 0 gives.
  k = std::max(0.0, fitted);
  return true;
}

int falloff_difference(const LensFalloff& a, const LensFalloff& b) {
  // At a corner (r = 1), where the two corrections differ most.
  const double ga = 1.0 / (1.0 - a.k), gb = 1.0 / (1.0 - b.k);
  const auto level = [](int v, double g) { return std::min(255L, std::lround(v * g)); };
  long most = 0;
  for (int v = 0; v < 256; ++v) most = std::max(most, std::abs(level(v, ga) - level(v, gb)));
  return static_cast<int>(most);
}

void FalloffCorrection::build(const LensFalloff& falloff, int width, int height, int channels) {
  if (built_ && falloff == falloff_ && width == width_ && height == height_ &&
      channels == channels_)
    return;
  built_ = true, falloff_ = falloff, width_ = width, height_ = height, channels_ = channels;
  gain_.create(height, width, CV_32FC(channels));  // allocates when the size changes
  identity_ = falloff.identity();
  if (identity_) return;  // only sized, for a fall-off found later: apply copies
  for (int y = 0; y < height; ++y) {
    float* row = gain_.ptr<float>(y);
    for (int x = 0; x < width; ++x) {
      const auto g =
          static_cast<float>(1.0 / (1.0 - falloff.k * falloff_radius_squared(width, height, x, y)));
      for (int c = 0; c < channels; ++c) row[x * channels + c] = g;
    }
  }
}

void FalloffCorrection::apply(ImageView<const std::uint8_t> image, Image<std::uint8_t>& out) const {
  if (!built_ || image.width != width_ || image.height != height_ || image.channels != channels_)
    throw Error("lens fall-off: the correction is for " + std::to_string(width_) + "x" +
                std::to_string(height_) + "x" + std::to_string(channels_) + " images, not " +
                std::to_string(image.width) + "x" + std::to_string(image.height) + "x" +
                std::to_string(image.channels));
  out.resize(image.width, image.height, image.channels);
  if (identity_) {  // its map was only sized
    out.copy_from(image);
    return;
  }
  // As cv::multiply(image, gain_, out, 1, CV_8U) rounds and saturates (the CUDA pass too), row by
  // row: OpenCV's call allocates a buffer every time.
  const int n = image.width * image.channels;
  for (int y = 0; y < image.height; ++y) {
    const std::uint8_t* in = image.row(y);
    const float* g = gain_.ptr<float>(y);
    std::uint8_t* o = out.row(y);
    for (int i = 0; i < n; ++i)
      o[i] = cv::saturate_cast<std::uint8_t>(static_cast<float>(in[i]) * g[i]);
  }
}

}  // namespace dco::stereo
