#include "dco/pipeline/stereo/disparity_selection.hpp"

#include <algorithm>
#include <cassert>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "dco/kernels/stereo_kernels.hpp"
#include "dco/kernels/stereo_pixel.hpp"

namespace dco::stereo {

void WinnerTakesAll::reset(int width, int height) {
  // The left state's 3.7 MB per 640x360 frame are not filled here: disparity 0 sets them as it
  // goes, and the first batch loads none of them.
  for (Image<std::uint16_t>* img : {&best_, &second_, &below_, &above_, &prev1_, &prev2_, &runmin_})
    img->resize(width, height);
  disp_.resize(width, height);
  best_right_.resize(width, height);
  best_right_.fill(kNoCost);
  disp_right_.resize(width, height);
  disp_right_.fill(kInvalidDisparity);
}

void WinnerTakesAll::update(ImageView<const std::uint32_t> slice, int d) {
  for (int y = 0; y < slice.height; ++y) update_slice_row(slice.row(y), y, d);
}

void WinnerTakesAll::update_slice_row(const std::uint32_t* costs, int y, int d) {
  update_slice_columns(costs, y, d, 0, best_.width());
}

void WinnerTakesAll::update_slice_columns(const std::uint32_t* costs, int y, int d, int begin,
                                          int end) {
  narrowed_.resize(static_cast<std::size_t>(best_.width()));
  assert(std::all_of(costs + begin, costs + end, [](std::uint32_t c) { return c < kNoCost; }));
  std::copy(costs + begin, costs + end, narrowed_.begin() + begin);
  update_columns(narrowed_.data(), 0, 1, y, d, begin, end);
}

void WinnerTakesAll::update_row(const std::uint16_t* costs, std::ptrdiff_t stride, int count, int y,
                                int d) {
  update_columns(costs, stride, count, y, d, 0, best_.width());
}

void WinnerTakesAll::update_columns(const std::uint16_t* costs, std::ptrdiff_t stride, int count,
                                    int y, int d, int begin, int end) {
  static_assert(kNoCost == kernels::kNoCost);
  assert(0 <= begin && begin <= end && end <= best_.width());
  kernels::wta_update_range(costs, stride, count, begin, end, d, state_row(y));
}

void WinnerTakesAll::skip_row(int y, int d, int count) {
  skip_columns(y, d, count, 0, best_.width());
}

void WinnerTakesAll::skip_columns(int y, int d, int count, int begin, int end) {
  assert(0 <= begin && begin <= end && end <= best_.width());
  kernels::wta_skip_range(count, begin, end, d, state_row(y));
}

kernels::WtaRow WinnerTakesAll::state_row(int y) {
  return {best_.row(y),  second_.row(y), below_.row(y), above_.row(y),      prev1_.row(y),
          prev2_.row(y), runmin_.row(y), disp_.row(y),  best_right_.row(y), disp_right_.row(y)};
}

struct SpeckleFilter::Buffer {
  // Per pixel: bit 0 joins the right neighbour, bit 1 the one below (both valid, step within
  // max_diff); then kLarge once the pixel's island is known to exceed max_size, kSeen once a
  // search reached it.
  std::vector<std::uint8_t> links;
  std::vector<std::uint8_t> rich;    // pixels with at least max_size joined neighbours
  std::vector<std::int32_t> island;  // the pixels of the island being searched
};
SpeckleFilter::SpeckleFilter() : buffer_(std::make_unique<Buffer>()) {}
SpeckleFilter::~SpeckleFilter() = default;
SpeckleFilter::SpeckleFilter(SpeckleFilter&&) noexcept = default;
SpeckleFilter& SpeckleFilter::operator=(SpeckleFilter&&) noexcept = default;

namespace {

constexpr std::uint8_t kRight = 1, kDown = 2, kLarge = 4, kSeen = 8;

// The row loops below take restrict pointers and keep the first and last column apart, so
// that the compiler vectorises them.

// 1 where both are valid and step by at most max_diff.
inline std::uint8_t joined(std::int16_t a, std::int16_t b, int max_diff) {
  return static_cast<std::uint8_t>((a != kInvalidDisparity) & (b != kInvalidDisparity) &
                                   (std::abs(a - b) <= max_diff));
}

// kRight and kDown of one row, and kSeen on its invalid pixels (no island to search);
// `below` is null on the last row.
void link_row(const std::int16_t* __restrict d, const std::int16_t* __restrict below, int w,
              int max_diff, std::uint8_t* __restrict out) {
  for (int x = 0; x + 1 < w; ++x)
    out[x] = static_cast<std::uint8_t>(joined(d[x], d[x + 1], max_diff) |
                                       ((d[x] == kInvalidDisparity) << 3));
  out[w - 1] = static_cast<std::uint8_t>((d[w - 1] == kInvalidDisparity) << 3);
  if (below)
    for (int x = 0; x < w; ++x)
      out[x] = static_cast<std::uint8_t>(out[x] | (joined(d[x], below[x], max_diff) << 1));
}

// 1 where a pixel has at least `limit` joined neighbours; `up` is the row above's links.
void rich_row(const std::uint8_t* __restrict l, const std::uint8_t* __restrict up, int w,
              std::uint8_t limit, std::uint8_t* __restrict out) {
  const auto count = [&](int x, int left) {
    return static_cast<std::uint8_t>((l[x] & kRight) + ((l[x] >> 1) & 1) + left +
                                     ((up[x] >> 1) & 1));
  };
  out[0] = count(0, 0) >= limit;
  for (int x = 1; x < w; ++x) out[x] = count(x, l[x - 1] & kRight) >= limit;
}

// 1 where a pixel is rich or joined to a rich one.
void large_row(const std::uint8_t* __restrict l, const std::uint8_t* __restrict up,
               const std::uint8_t* __restrict r, const std::uint8_t* __restrict r_up,
               const std::uint8_t* __restrict r_down, int w, std::uint8_t* __restrict out) {
  const auto vertical = [&](int x) {
    return static_cast<std::uint8_t>(r[x] | (((l[x] >> 1) & 1) & r_down[x]) |
                                     (((up[x] >> 1) & 1) & r_up[x]));
  };
  if (w == 1) {
    out[0] = vertical(0);
    return;
  }
  out[0] = static_cast<std::uint8_t>(vertical(0) | (l[0] & r[1] & kRight));
  for (int x = 1; x + 1 < w; ++x)
    out[x] = static_cast<std::uint8_t>(vertical(x) | (l[x] & r[x + 1] & kRight) |
                                       (l[x - 1] & r[x - 1] & kRight));
  out[w - 1] = static_cast<std::uint8_t>(vertical(w - 1) | (l[w - 2] & r[w - 2] & kRight));
}

bool every_byte_settled(const std::uint8_t* p) {
  std::uint64_t v;
  std::memcpy(&v, p, sizeof v);
  v &= 0x0c0c0c0c0c0c0c0cull;  // kLarge | kSeen per byte; a byte left at 0 is unsettled
  return ((v - 0x0101010101010101ull) & ~v & 0x8080808080808080ull) == 0;
}

}  // namespace

void SpeckleFilter::apply(ImageView<std::int16_t> disparity, int max_size, int max_diff) {
  // cv::filterSpeckles' islands (4-connected, |step| <= max_diff between valid pixels; those of
  // at most max_size pixels become invalid), found faster: OpenCV floods every island in full;
  // here most pixels are settled by their links alone (a pixel with max_size joined neighbours,
  // or joined to one, lies on an island larger than max_size), and a search from any other pixel
  // stops as soon as its island outgrows max_size, marking what it saw as large.
  const int w = disparity.width, h = disparity.height;
  if (w <= 0 || h <= 0) return;
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  std::vector<std::uint8_t>& links = buffer_->links;
  links.resize(n);
  const auto link_at = [&](int y) { return links.data() + static_cast<std::size_t>(y) * w; };
  for (int y = 0; y < h; ++y)
    link_row(disparity.row(y), y + 1 < h ? disparity.row(y + 1) : nullptr, w, max_diff, link_at(y));
  const auto at = [&](int x, int y) -> std::uint8_t& { return link_at(y)[x]; };
  if (max_size <= 4) {
    // A pixel with max_size joined neighbours lies on an island of more than max_size pixels, and
    // so does every pixel joined to it. Rows beyond the map read as a row of zeros.
    std::vector<std::uint8_t>& rich = buffer_->rich;
    rich.resize(n + 2 * static_cast<std::size_t>(w));
    std::uint8_t* zeros = rich.data() + n;
    std::uint8_t* large = zeros + w;
    std::fill(zeros, zeros + w, std::uint8_t{0});
    const auto rich_at = [&](int y) {
      return y >= 0 && y < h ? rich.data() + static_cast<std::size_t>(y) * w : zeros;
    };
    const auto links_or_zeros = [&](int y) { return y >= 0 ? link_at(y) : zeros; };
    for (int y = 0; y < h; ++y)
      rich_row(link_at(y), links_or_zeros(y - 1), w, static_cast<std::uint8_t>(max_size),
               rich_at(y));
    for (int y = 0; y < h; ++y) {
      std::uint8_t* l = link_at(y);
      large_row(l, links_or_zeros(y - 1), rich_at(y), rich_at(y - 1), rich_at(y + 1), w, large);
      for (int x = 0; x < w; ++x) l[x] = static_cast<std::uint8_t>(l[x] | (large[x] << 2));
    }
  }
  std::vector<std::int32_t>& island = buffer_->island;
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* settled = link_at(y);
    for (int x = 0; x < w; ++x) {
      // Eight settled pixels (kLarge or kSeen in every byte) at a time.
      while (x + 8 <= w && every_byte_settled(settled + x)) x += 8;
      if (x >= w) break;
      if (settled[x] & (kLarge | kSeen)) continue;
      // Breadth first over the island, until it is complete or larger than max_size.
      island.clear();
      island.push_back(y * w + x);
      at(x, y) |= kSeen;
      bool large = false;
      for (std::size_t head = 0; head < island.size() && !large; ++head) {
        const int px = island[head] % w, py = island[head] / w;
        const std::uint8_t l = at(px, py);
        const int next[4][2] = {{px + 1, py}, {px, py + 1}, {px - 1, py}, {px, py - 1}};
        const bool link[4] = {(l & kRight) != 0, (l & kDown) != 0,
                              px > 0 && (at(px - 1, py) & kRight) != 0,
                              py > 0 && (at(px, py - 1) & kDown) != 0};
        for (int k = 0; k < 4 && !large; ++k) {
          if (!link[k]) continue;
          std::uint8_t& reached = at(next[k][0], next[k][1]);
          if (reached & kLarge) {
            large = true;
          } else if (!(reached & kSeen)) {
            reached |= kSeen;
            island.push_back(next[k][1] * w + next[k][0]);
            large = island.size() > static_cast<std::size_t>(max_size);
          }
        }
      }
      for (const std::int32_t i : island) {
        if (large)
          links[static_cast<std::size_t>(i)] |= kLarge;
        else
          disparity.row(i / w)[i % w] = kInvalidDisparity;
      }
    }
  }
}

void left_right_check(ImageView<std::int16_t> left, ImageView<const std::int16_t> right,
                      int max_diff, std::vector<std::int32_t>& scratch) {
  assert(right.same_size(left));
  if (scratch.size() < static_cast<std::size_t>(left.width))
    scratch.resize(static_cast<std::size_t>(left.width));
  for (int y = 0; y < left.height; ++y)
    kernels::left_right_check_row(left.row(y), right.row(y), left.width, max_diff, scratch.data());
}

void uniqueness_check(ImageView<std::int16_t> disparity, ImageView<const std::uint16_t> best,
                      ImageView<const std::uint16_t> second, double ratio) {
  const double keep = 1.0 - ratio;  // kept when best <= keep * second
  for (int y = 0; y < disparity.height; ++y)
    kernels::uniqueness_check_row(disparity.row(y), best.row(y), second.row(y), disparity.width,
                                  keep);
}

void discontinuity_check(ImageView<std::int16_t> disparity, int max_jump,
                         Image<std::int16_t>& scratch) {
  assert(max_jump >= -1);
  const int w = disparity.width;
  const int h = disparity.height;
  // Row y of scratch: the largest value among the 8-neighbourhood (and the pixel) of each pixel
  // of row y before the check. Unreliable neighbours (-1) never exceed a reliable value by more
  // than max_jump >= -1, so the largest one decides kernels::pixel::behind_jump.
  scratch.resize(w, 3);
  std::int16_t* column_max = scratch.row(0);
  std::int16_t* previous = scratch.row(1);  // row y - 1 before the check
  std::int16_t* current = scratch.row(2);   // row y before the check
  std::copy(disparity.row(0), disparity.row(0) + w, current);
  for (int y = 0; y < h; ++y) {
    std::int16_t* out = disparity.row(y);
    const std::int16_t* above = y > 0 ? previous : current;
    const std::int16_t* below = y + 1 < h ? disparity.row(y + 1) : current;  // not yet checked
    for (int x = 0; x < w; ++x) column_max[x] = std::max(std::max(above[x], current[x]), below[x]);
    std::swap(previous, current);
    std::copy(below, below + w, current);  // row y + 1 before the check (unused past the end)
    const auto check = [&](int x, int nearest) {
      out[x] =
          out[x] != kInvalidDisparity && nearest - out[x] > max_jump ? kInvalidDisparity : out[x];
    };
    check(0, std::max(column_max[0], column_max[std::min(1, w - 1)]));
    for (int x = 1; x < w - 1; ++x)
      check(x, std::max(std::max(column_max[x - 1], column_max[x]), column_max[x + 1]));
    if (w > 1) check(w - 1, std::max(column_max[w - 2], column_max[w - 1]));
  }
}

}  // namespace dco::stereo
