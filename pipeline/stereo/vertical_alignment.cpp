#include "dco/pipeline/stereo/vertical_alignment.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

#include "dco/core/image_turn.hpp"

namespace dco::stereo {
namespace {

constexpr double kSamples = 4096;         // pixels a step looks at: one offset needs few
constexpr double kSearchSamples = 16384;  // and a search (a sequence's first frame only)
constexpr int kMinStep = 8;               // vertical grey step (levels over two rows) a pair needs
constexpr double kOutlier = 40.0;         // levels apart that leave a pair out
constexpr int kTrackSteps = 1;            // Gauss-Newton steps from the rows in force
constexpr int kMinSearchSamples = 50;     // samples a search needs
constexpr int kQuarters = 4;              // column bands of a search, for the roll
constexpr int kMinQuarterSamples = 12;    // samples a band's mode needs
constexpr int kRefineSteps = 3;           // Lucas-Kanade steps of a searched window
constexpr int kLineRounds = 2;            // least-squares lines through the samples near the last
constexpr double kLineBand = 0.25;        // rows from the line that make a sample near it
// Share of the samples' squared column spread (in half widths) below which the roll is not fitted.
constexpr double kMinRollSpread = 0.05;

// Where a pixel of the right image brought onto the left's rows lies in the right image as it
// came (the inverse of align_rows), with u = (x - xc) / xc in [-1, 1] across the columns.
struct Geometry {
  double xc, yc, c, s, offset;
  Geometry(int width, int height, const RowAlignment& a)
      : xc(0.5 * (width - 1)),
        yc(0.5 * (height - 1)),
        c(std::cos(a.roll)),
        s(std::sin(a.roll)),
        offset(a.offset) {}
  double x(double x, double y) const { return xc + c * (x - xc) - s * (y - yc); }
  double y(double x, double y) const { return yc + s * (x - xc) + c * (y - yc) + offset; }
  double u(double x) const { return xc > 0 ? (x - xc) / xc : 0.0; }
};

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
    const int x1 = std::clamp(static_cast<int>(fx) + 1, 0, right.width - 1);
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

struct BestRow {
  double u, row;
};

// The window's place (px, py) in the right image refined from a whole-pixel start by
// Lucas-Kanade steps on its bilinear samples: unbiased between whole rows, where a parabola
// through whole-row costs leans towards them. False when the steps leave the pixel around the
// start or the window's gradients do not fix both ways.
template <int kRadius>
bool refine_window(const Sampler& s, int x, int y, int g, double& px, double& py) {
  constexpr int kSide = 2 * kRadius + 3;  // the window and a pixel around it, for the gradients
  constexpr int kWindow = 2 * kRadius + 1;
  constexpr double n = kWindow * kWindow;
  const int c = std::min(s.left.channels, 3);
  const double x0 = px, y0 = py;
  // The left window, its mean and spread: it is brought to the right one's, since levels that
  // differ between the cameras (no exposure map yet) would otherwise pull the window along its
  // gradients.
  std::array<double, kWindow * kWindow> l{};
  double ls = 0, lss = 0;
  for (int j = 0; j < kWindow; ++j)
    for (int i = 0; i < kWindow; ++i) {
      const double v = s.left.row(y + j - kRadius)[(x + i - kRadius) * c + g];
      l[std::size_t(j * kWindow + i)] = v;
      ls += v, lss += v * v;
    }
  const double lvar = lss / n - (ls / n) * (ls / n);
  if (!(lvar > 0)) return false;
  std::array<double, kSide * kSide> r{};
  for (int step = 0; step < kRefineSteps; ++step) {
    for (int j = 0; j < kSide; ++j)
      for (int i = 0; i < kSide; ++i)
        r[std::size_t(j * kSide + i)] = s.right_at(px + i - kRadius - 1, py + j - kRadius - 1, g);
    const auto at = [&](int a, int b) { return r[std::size_t(b * kSide + a)]; };
    double rs = 0, rss = 0;
    for (int j = 1; j + 1 < kSide; ++j)
      for (int i = 1; i + 1 < kSide; ++i) rs += at(i, j), rss += at(i, j) * at(i, j);
    const double rvar = rss / n - (rs / n) * (rs / n);
    if (!(rvar > 0)) return false;
    const double scale = std::sqrt(rvar / lvar);
    double gxx = 0, gxy = 0, gyy = 0, bx = 0, by = 0;
    for (int j = 1; j + 1 < kSide; ++j)
      for (int i = 1; i + 1 < kSide; ++i) {
        const double gx = 0.5 * (at(i + 1, j) - at(i - 1, j));
        const double gy = 0.5 * (at(i, j + 1) - at(i, j - 1));
        const double left = l[std::size_t((j - 1) * kWindow + i - 1)];
        const double e = (left - ls / n) * scale + rs / n - at(i, j);
        gxx += gx * gx, gxy += gx * gy, gyy += gy * gy, bx += gx * e, by += gy * e;
      }
    const double det = gxx * gyy - gxy * gxy;
    if (!(det > 1e-6 * (gxx * gyy)) || !(gxx > 0) || !(gyy > 0)) return false;
    px += (gyy * bx - gxy * by) / det;
    py += (gxx * by - gxy * bx) / det;
    if (!(std::abs(px - x0) <= 1.0 && std::abs(py - y0) <= 1.0)) return false;
  }
  return true;
}

// The search's window of rows either way of a sample's match.
constexpr int kSearchRows = static_cast<int>(kMaxVerticalOffset) + 1;

// For sampled matched pixels with grey steps both ways, the row offset (-5 .. +5) at which a 5x5
// window of the right image, within two columns of the match (as the roll in force places it),
// differs least from the left's: the best whole row and column, then refine_window.
std::vector<BestRow> best_rows(const Sampler& s, const Geometry& g0) {
  std::vector<BestRow> rows;
  const int c = std::min(s.left.channels, 3);
  const int w = s.left.width, h = s.left.height;
  // Rows: a row past kMaxVerticalOffset either way, since a best row on the window's edge says
  // nothing (the minimum may lie beyond it) and is dropped: offsets up to the limit keep theirs.
  constexpr int kRadius = 2, kColumns = 2, kRows = kSearchRows;
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
      const int xr = static_cast<int>(std::lround(g0.x(at, y)));
      double best = -1;
      int best_dx = 0, best_dy = 0;
      for (int dy = -kRows; dy <= kRows; ++dy)
        for (int dx = -kColumns; dx <= kColumns; ++dx) {
          double sum = 0;
          for (int j = -kRadius; j <= kRadius; ++j)
            for (int i = -kRadius; i <= kRadius; ++i) {
              const double l = s.left.row(y + j)[(x + i) * c + g];
              sum += std::abs(l - s.right_level(xr + dx + i, y + j + dy, g));
            }
          if (best < 0 || sum < best) best = sum, best_dx = dx, best_dy = dy;
        }
      if (std::abs(best_dy) == kRows) continue;  // at the window's edge: no minimum inside it
      double px = xr + best_dx, py = y + best_dy;
      if (!refine_window<kRadius>(s, x, y, g, px, py)) continue;
      rows.push_back({g0.u(at), py - y});
    }
  }
  return rows;
}

// The most common value: the fullest eighth of a row, then the mean of the values within a
// quarter row of it. Samples whose matches were wrong spread over the whole window; the right
// ones gather.
double mode(const std::vector<double>& values) {
  constexpr int kBins = 2 * kSearchRows * 8;  // -5 .. +5 rows in eighths
  std::array<int, kBins> count{};
  const auto bin = [](double v) {
    return std::clamp(static_cast<int>((v + kSearchRows) * 8.0), 0, kBins - 1);
  };
  for (const double v : values) ++count[static_cast<std::size_t>(bin(v))];
  const int peak = static_cast<int>(std::max_element(count.begin(), count.end()) - count.begin());
  const double centre = (peak + 0.5) / 8.0 - kSearchRows;
  double sum = 0;
  int n = 0;
  for (const double v : values)
    if (std::abs(v - centre) <= 0.25) sum += v, ++n;
  return sum / n;
}

// A weighted least-squares line v = offset + slope * u.
struct LineFit {
  double n = 0, su = 0, sv = 0, suu = 0, suv = 0;
  void add(double u, double v, double w = 1) {
    n += w, su += w * u, sv += w * v, suu += w * u * u, suv += w * u * v;
  }
  // False when the points do not spread along u.
  bool solve(double& offset, double& slope) const {
    const double spread = suu * n - su * su;
    if (!(spread > 0)) return false;
    slope = (suv * n - su * sv) / spread;
    offset = (sv - slope * su) / n;
    return true;
  }
};

// The offset and roll of a line through the most common best row of each quarter of the columns
// (weighted by their samples); the offset alone from all of them when fewer than two quarters
// have enough. False when too few samples.
bool search_rows(const std::vector<BestRow>& rows, int width, RowAlignment& a) {
  if (static_cast<int>(rows.size()) < kMinSearchSamples) return false;
  std::array<std::vector<double>, kQuarters> band;
  std::array<double, kQuarters> u_sum{};
  for (const BestRow& r : rows) {
    const int q = std::clamp(static_cast<int>((r.u + 1.0) * 0.5 * kQuarters), 0, kQuarters - 1);
    band[static_cast<std::size_t>(q)].push_back(r.row);
    u_sum[static_cast<std::size_t>(q)] += r.u;
  }
  LineFit modes;
  int used = 0;
  for (std::size_t q = 0; q < band.size(); ++q) {
    const double n = static_cast<double>(band[q].size());
    if (n < kMinQuarterSamples) continue;
    modes.add(u_sum[q] / n, mode(band[q]), n);
    ++used;
  }
  double offset = 0, slope = 0;  // slope: rows per half width
  if (used < 2 || !modes.solve(offset, slope)) {
    std::vector<double> all;
    all.reserve(rows.size());
    for (const BestRow& r : rows) all.push_back(r.row);
    a.offset = mode(all);
    return true;
  }
  // Then every sample near that line, not only the modes: a least-squares line through them.
  for (int i = 0; i < kLineRounds; ++i) {
    LineFit near;
    for (const BestRow& r : rows)
      if (std::abs(r.row - (offset + slope * r.u)) <= kLineBand) near.add(r.u, r.row);
    if (near.n < kMinSearchSamples || !near.solve(offset, slope)) break;
  }
  a.offset = offset;
  a.roll = std::atan(slope / (0.5 * (width - 1)));
  return true;
}

}  // namespace

bool fit_row_alignment(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                       ImageView<const float> disparity, const ExposureMap& levels, bool search,
                       RowAlignment& alignment) {
  const double pixels = static_cast<double>(left.width) * left.height;
  const auto step_for = [&](double samples) {
    return std::max(2, static_cast<int>(std::ceil(std::sqrt(pixels / samples))));
  };
  RowAlignment a = alignment;
  const double half = 0.5 * (left.width - 1);
  if (search) {
    // Each sample's own best row in a small window, then the most common ones: the matches of a
    // pair that is off vertically fit the rows they were made on, so they cannot tell the way
    // out by themselves, and steps from the search would pull it back there (bench/RESULTS.md).
    const Sampler wide{left, right, disparity, levels, step_for(kSearchSamples)};
    if (!search_rows(best_rows(wide, Geometry(left.width, left.height, alignment)), left.width, a))
      return false;
  } else {
    const Sampler s{left, right, disparity, levels, step_for(kSamples)};
    for (int i = 0; i < kTrackSteps; ++i) {
      // Unknowns: the offset and the roll as rows at the side edges (edge = tan(roll) * half).
      const Geometry g(left.width, left.height, a);
      double jj = 0, jju = 0, jjuu = 0, jr = 0, jru = 0;
      int used = 0;
      s.each([&](double at, int y, double l, int k) {
        const double xr = g.x(at, y), yr = g.y(at, y);
        const double r = l - s.right_at(xr, yr, k);
        if (std::abs(r) > kOutlier) return;
        // The roll's own column shift is left out: the next matches take it up.
        const double j = 0.5 * (s.right_at(xr, yr + 1, k) - s.right_at(xr, yr - 1, k));
        const double u = g.u(at);
        jj += j * j, jju += j * j * u, jjuu += j * j * u * u, jr += j * r, jru += j * r * u;
        ++used;
      });
      if (used < kMinAlignmentPairs || !(jj > 0)) return false;
      const double det = jj * jjuu - jju * jju;
      double d_offset = jr / jj, d_edge = 0;
      if (jjuu > kMinRollSpread * jj && det > 1e-9 * jj * jjuu) {
        d_offset = (jjuu * jr - jju * jru) / det;
        d_edge = (jj * jru - jju * jr) / det;
      }
      a.offset += std::clamp(d_offset, -1.0, 1.0);  // one row at most per step
      a.roll = std::atan(std::tan(a.roll) + std::clamp(d_edge, -1.0, 1.0) / half);
    }
  }
  const double edge = std::abs(std::tan(a.roll)) * half;
  if (!(std::abs(a.offset) <= kMaxVerticalOffset) || !(edge <= kMaxVerticalOffset)) return false;
  alignment = a;
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

void align_rows(ImageView<const std::uint8_t> right, const RowAlignment& alignment,
                Image<std::uint8_t>& out) {
  if (alignment.roll == 0) {
    shift_rows(right, alignment.offset, out);
    return;
  }
  turn_about_centre(right, alignment.roll, alignment.offset, out);
}

}  // namespace dco::stereo
