// SIMD versions of the stereo stage's per-pixel row kernels (half-size means, census, cross arms,
// the AD-census matching cost for one disparity or a block of them) and the name of the target in
// use. Compiled once per Highway target and dispatched at run time; each loop covers whole
// vectors and leaves the last partial vector to the scalar range functions, so any width is
// handled and the results equal dco::kernels::scalar bit for bit.

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "dco/kernels/stereo_kernels.hpp"
#include "scalar_ranges.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "stereo_cost_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dco::kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void HalfMeansRow(const std::uint8_t* HWY_RESTRICT a, const std::uint8_t* HWY_RESTRICT b, int count,
                  std::uint8_t* HWY_RESTRICT out) {
  // The even and odd bytes of both rows apart, their sums in 16-bit lanes (each half of the
  // vector widened on its own), rounded, shifted and narrowed back.
  const hn::ScalableTag<std::uint8_t> d8;
  const hn::Half<decltype(d8)> dh;
  const hn::Rebind<std::int16_t, decltype(dh)> d16;  // sums up to 4 * 255 + 2
  const int n = static_cast<int>(hn::Lanes(d8));
  const auto two = hn::Set(d16, std::int16_t{2});
  const auto means = [&](auto ae, auto ao, auto be, auto bo) {
    const auto sum = hn::Add(hn::Add(hn::PromoteTo(d16, ae), hn::PromoteTo(d16, ao)),
                             hn::Add(hn::PromoteTo(d16, be), hn::PromoteTo(d16, bo)));
    return hn::DemoteTo(dh, hn::ShiftRight<2>(hn::Add(sum, two)));
  };
  int x = 0;
  for (; x + n <= count; x += n) {
    hn::Vec<decltype(d8)> ae, ao, be, bo;
    hn::LoadInterleaved2(d8, a + 2 * x, ae, ao);
    hn::LoadInterleaved2(d8, b + 2 * x, be, bo);
    const auto low = means(hn::LowerHalf(dh, ae), hn::LowerHalf(dh, ao), hn::LowerHalf(dh, be),
                           hn::LowerHalf(dh, bo));
    const auto high = means(hn::UpperHalf(dh, ae), hn::UpperHalf(dh, ao), hn::UpperHalf(dh, be),
                            hn::UpperHalf(dh, bo));
    hn::StoreU(hn::Combine(d8, high, low), d8, out + x);
  }
  detail::half_means_range(a, b, x, count, out);
}

void CensusRow(const std::uint8_t* const* rows, int width, int window_w, int window_h,
               std::uint64_t* out) {
  // Neighbour i of N sets bit N - 1 - i (pixel::census_bits). The comparisons run on byte lanes,
  // a vector of pixels at a time, each into the byte of the descriptors that holds its bit; the
  // eight bytes of each pixel are then put together by three rounds of zips, 16 pixels at a time.
  const hn::ScalableTag<std::uint8_t> d8;
  const hn::FixedTag<std::uint8_t, 16> b8;
  const hn::RepartitionToWide<decltype(b8)> b16;
  const hn::RepartitionToWide<decltype(b16)> b32;
  const hn::RepartitionToWide<decltype(b32)> b64;
  const int n = static_cast<int>(hn::Lanes(d8));
  const int rx = window_w / 2;
  // pixel::census_bits compares grey levels as ints: unsigned bytes compare the same (one
  // instruction on AVX-512, NEON and SVE; Highway flips the top bit where the ISA has only
  // signed compares).
  const auto grey = [&](const std::uint8_t* p) { return hn::LoadU(d8, p); };
  HWY_ALIGN std::uint8_t bytes[8][HWY_MAX_BYTES];
  // kW, kH > 0: the window's size known at compile time, so the loops unroll and every bit's
  // place is a constant (0: window_w, window_h).
  const auto vector_at = [&]<int kW, int kH>(int x) {
    const int ww = kW > 0 ? kW : window_w;
    const int wh = kH > 0 ? kH : window_h;
    const int cx = ww / 2, cy = wh / 2;
    const auto centre = grey(rows[cy] + x);
    // The bits come in falling order, so each byte is complete before the next one starts: one
    // accumulator, stored when its byte is done.
    for (int k = 0; k < 8; ++k) hn::Store(hn::Zero(d8), d8, bytes[k]);
    auto acc = hn::Zero(d8);
    int bit = ww * wh - 2;
#pragma GCC unroll 16
    for (int j = 0; j < wh; ++j) {
#pragma GCC unroll 16
      for (int dx = -cx; dx <= cx; ++dx) {
        if (j == cy && dx == 0) continue;
        const auto below = hn::Lt(grey(rows[j] + x + dx), centre);
        acc = hn::Or(acc, hn::IfThenElseZero(
                              below, hn::Set(d8, static_cast<std::uint8_t>(1u << (bit & 7)))));
        if ((bit & 7) == 0) {
          hn::Store(acc, d8, bytes[bit >> 3]);
          acc = hn::Zero(d8);
        }
        --bit;
      }
    }
    for (int p = 0; p < n; p += 16) {
      // (No arrays of vectors: SVE vectors are sizeless.)
      const auto v0 = hn::Load(b8, bytes[0] + p), v1 = hn::Load(b8, bytes[1] + p);
      const auto v2 = hn::Load(b8, bytes[2] + p), v3 = hn::Load(b8, bytes[3] + p);
      const auto v4 = hn::Load(b8, bytes[4] + p), v5 = hn::Load(b8, bytes[5] + p);
      const auto v6 = hn::Load(b8, bytes[6] + p), v7 = hn::Load(b8, bytes[7] + p);
      // Bytes 2k and 2k + 1 of pixels p .. p + 7 (lo) and p + 8 .. p + 15 (hi).
      const auto lo01 = hn::ZipLower(b16, v0, v1), hi01 = hn::ZipUpper(b16, v0, v1);
      const auto lo23 = hn::ZipLower(b16, v2, v3), hi23 = hn::ZipUpper(b16, v2, v3);
      const auto lo45 = hn::ZipLower(b16, v4, v5), hi45 = hn::ZipUpper(b16, v4, v5);
      const auto lo67 = hn::ZipLower(b16, v6, v7), hi67 = hn::ZipUpper(b16, v6, v7);
      // Bytes 0-3 and 4-7 of four pixels, then both halves of two pixels.
      const auto store = [&](hn::Vec<decltype(b32)> low, hn::Vec<decltype(b32)> high, int first) {
        hn::StoreU(hn::ZipLower(b64, low, high), b64, out + x + p + first);
        hn::StoreU(hn::ZipUpper(b64, low, high), b64, out + x + p + first + 2);
      };
      store(hn::ZipLower(b32, lo01, lo23), hn::ZipLower(b32, lo45, lo67), 0);
      store(hn::ZipUpper(b32, lo01, lo23), hn::ZipUpper(b32, lo45, lo67), 4);
      store(hn::ZipLower(b32, hi01, hi23), hn::ZipLower(b32, hi45, hi67), 8);
      store(hn::ZipUpper(b32, hi01, hi23), hn::ZipUpper(b32, hi45, hi67), 12);
    }
  };
  // The default window (StereoParams: 9 x 7) unrolled, any other as it comes.
  const auto vector = [&](int at) {
    if (window_w == 9 && window_h == 7)
      vector_at.template operator()<9, 7>(at);
    else
      vector_at.template operator()<0, 0>(at);
  };
  const int begin = std::min(rx, width);
  int x = begin;
  if (n >= 16) {
    for (; x + n + rx <= width; x += n) vector(x);
    // The rest but the clamped end: one more vector, overlapping pixels already done (the same
    // values again), so that few pixels are left to the scalar loop.
    if (x < width - rx && width - rx - n >= begin) {
      vector(width - rx - n);
      x = width - rx;
    }
  }
  // Columns near the ends read clamped neighbours.
  detail::census_range(rows, width, window_w, window_h, 0, begin, out);
  detail::census_range(rows, width, window_w, window_h, x, width, out);
}

const char* TargetName() {
  return hwy::TargetName(HWY_TARGET);
}

// Per pixel of packed pixels: whether every channel of |a - b| (as bytes) is below `tau`
// (broadcast bytes). Compared byte by byte, so no channel has to be shifted out; the unused bytes
// of a packed pixel are 0 in both, so they always pass.
template <class D, class V8>
hn::Mask<D> AllChannelsBelow(D di, V8 diff8, V8 tau) {
  const hn::Repartition<std::uint8_t, D> du8;
  const auto below = hn::BitCast(di, hn::VecFromMask(du8, hn::Lt(diff8, tau)));
  return hn::Eq(below, hn::Set(di, -1));
}

// Arm lengths of the anchors anchor[0 .. lanes), each stepping `step` elements per pixel, with
// `limit` steps allowed in every lane and, with kLaneLimits, lane_limit[k] in lane k. Lanes stop
// one by one; the loop ends when all have.
template <bool kLaneLimits, class D>
hn::Vec<D> ArmLengths(D di, const std::uint32_t* anchor, std::ptrdiff_t step, int limit,
                      const ArmParams& p, hn::Vec<D> lane_limit) {
  const hn::Repartition<std::uint8_t, D> du8;
  const auto* base = reinterpret_cast<const std::int32_t*>(anchor);
  const auto a = hn::LoadU(di, base);
  const auto a8 = hn::BitCast(du8, a);
  // The thresholds are validated to 1 .. 255, so they fit a byte.
  const auto tau1 = hn::Set(du8, static_cast<std::uint8_t>(p.tau1));
  const auto tau2 = hn::Set(du8, static_cast<std::uint8_t>(p.tau2));
  auto prev8 = a8;
  auto len = hn::Zero(di);
  auto active = hn::Eq(a, a);
  for (int i = 1; i <= limit; ++i) {
    const auto q8 = hn::BitCast(du8, hn::LoadU(di, base + step * i));
    const auto to_anchor = hn::Sub(hn::Max(q8, a8), hn::Min(q8, a8));
    const auto to_prev = hn::Sub(hn::Max(q8, prev8), hn::Min(q8, prev8));
    active = hn::And(active, hn::And(AllChannelsBelow(di, to_anchor, tau1),
                                     AllChannelsBelow(di, to_prev, tau1)));
    if (i > p.arm_short) active = hn::And(active, AllChannelsBelow(di, to_anchor, tau2));
    if constexpr (kLaneLimits) active = hn::And(active, hn::Lt(hn::Set(di, i - 1), lane_limit));
    if (hn::AllFalse(di, active)) break;
    len = hn::IfThenElse(active, hn::Set(di, i), len);
    prev8 = hn::BitCast(du8, hn::IfThenElse(active, hn::BitCast(di, q8), hn::BitCast(di, prev8)));
  }
  return len;
}

// Largest arm_max (validated) and the most lanes of any target, for the padded row ends.
constexpr int kMaxArm = 255;
constexpr int kMaxLanes = HWY_MAX_BYTES;

// The four arms of row y, for the packed (32-bit) and the grey (8-bit) kernels alike: `lengths`
// is their ArmLengths or GreyArmLengths. Vectors at 0, n, 2n, ...; the last one moves left to end
// at the row end, so it recomputes a few pixels (to the same values) instead of leaving a partial
// vector. Near the row ends the lanes have limits of their own and a vector would read past the
// row: such vectors read a zero-padded copy of the row's end, the lanes stopping at their limits.
template <class D, class Pixel, class Lengths>
void RowArms(D d, const Pixel* image, std::ptrdiff_t stride, int width, int height, int y,
             const ArmParams& p, const Lengths& lengths, std::uint8_t* left, std::uint8_t* right,
             std::uint8_t* up, std::uint8_t* down) {
  using T = hn::TFromD<D>;
  const int n = static_cast<int>(hn::Lanes(d));
  if (width < n) {
    detail::arms_range(image, stride, width, height, y, p, 0, width, left, right, up, down);
    return;
  }
  const Pixel* row = image + y * stride;
  HWY_ALIGN Pixel padded[2 * kMaxArm + 2 * kMaxLanes];
  HWY_ALIGN T limits[kMaxLanes];
  const auto store = [&](hn::Vec<D> len, std::uint8_t* out) {
    const hn::Rebind<std::uint8_t, D> du8;
    if constexpr (sizeof(T) == 1)
      hn::StoreU(len, d, out);
    else
      hn::StoreU(hn::DemoteTo(du8, len), du8, out);
  };
  const auto vector_at = [&](int x0) { return std::min(x0, width - n); };
  // Vertical arms: every lane has the row's limit.
  const int up_limit = std::min(p.arm_max, y);
  const int down_limit = std::min(p.arm_max, height - 1 - y);
  for (int x0 = 0; x0 < width; x0 += n) {
    const int x = vector_at(x0);
    store(lengths.template operator()<false>(row + x, -stride, up_limit, hn::Zero(d)), up + x);
    store(lengths.template operator()<false>(row + x, stride, down_limit, hn::Zero(d)), down + x);
  }
  const int reach = std::min(width, p.arm_max + 2 * n);  // pixels a border vector may read
  std::fill(padded, padded + p.arm_max, Pixel{0});
  std::copy(row, row + reach, padded + p.arm_max);
  for (int x0 = 0; x0 < width; x0 += n) {
    const int x = vector_at(x0);
    if (x >= p.arm_max) {
      store(lengths.template operator()<false>(row + x, -1, p.arm_max, hn::Zero(d)), left + x);
      continue;
    }
    for (int k = 0; k < n; ++k) limits[k] = static_cast<T>(std::min(p.arm_max, x + k));
    store(lengths.template operator()<true>(padded + p.arm_max + x, -1,
                                            std::min(p.arm_max, x + n - 1), hn::Load(d, limits)),
          left + x);
  }
  const int base = width - reach;  // padded[k] = row[base + k]
  std::copy(row + base, row + width, padded);
  std::fill(padded + reach, padded + reach + p.arm_max, Pixel{0});
  for (int x0 = 0; x0 < width; x0 += n) {
    const int x = vector_at(x0);
    if (x + n - 1 + p.arm_max <= width - 1) {
      store(lengths.template operator()<false>(row + x, 1, p.arm_max, hn::Zero(d)), right + x);
      continue;
    }
    for (int k = 0; k < n; ++k) limits[k] = static_cast<T>(std::min(p.arm_max, width - 1 - x - k));
    store(lengths.template operator()<true>(padded + (x - base), 1, p.arm_max, hn::Load(d, limits)),
          right + x);
  }
}

void CrossArmsRow(const std::uint32_t* image, std::ptrdiff_t stride, int width, int height, int y,
                  const ArmParams& p, std::uint8_t* left, std::uint8_t* right, std::uint8_t* up,
                  std::uint8_t* down) {
  const hn::ScalableTag<std::int32_t> di;
  const auto lengths = [&]<bool kLaneLimits>(const std::uint32_t* anchor, std::ptrdiff_t step,
                                             int limit, hn::Vec<decltype(di)> lane_limit) {
    return ArmLengths<kLaneLimits>(di, anchor, step, limit, p, lane_limit);
  };
  RowArms(di, image, stride, width, height, y, p, lengths, left, right, up, down);
}

// Arm lengths of the grey anchors anchor[0 .. lanes), each stepping `step` bytes per pixel, with
// `limit` steps allowed in every lane and, with kLaneLimits, lane_limit[k] in lane k. Lanes stop
// one by one; the loop ends when all have.
template <bool kLaneLimits, class D>
hn::Vec<D> GreyArmLengths(D d, const std::uint8_t* anchor, std::ptrdiff_t step, int limit,
                          const ArmParams& p, hn::Vec<D> lane_limit) {
  const auto a = hn::LoadU(d, anchor);
  // The thresholds are validated to 1 .. 255 and arm_max to at most 255, so all fit a byte.
  const auto tau1 = hn::Set(d, static_cast<std::uint8_t>(p.tau1));
  const auto tau2 = hn::Set(d, static_cast<std::uint8_t>(p.tau2));
  auto prev = a;
  auto len = hn::Zero(d);
  auto active = hn::Eq(a, a);
  for (int i = 1; i <= limit; ++i) {
    const auto q = hn::LoadU(d, anchor + step * i);
    const auto to_anchor = hn::Sub(hn::Max(q, a), hn::Min(q, a));
    const auto to_prev = hn::Sub(hn::Max(q, prev), hn::Min(q, prev));
    active = hn::And(active, hn::And(hn::Lt(to_anchor, tau1), hn::Lt(to_prev, tau1)));
    if (i > p.arm_short) active = hn::And(active, hn::Lt(to_anchor, tau2));
    if constexpr (kLaneLimits)
      active = hn::And(active, hn::Lt(hn::Set(d, static_cast<std::uint8_t>(i - 1)), lane_limit));
    if (hn::AllFalse(d, active)) break;
    len = hn::IfThenElse(active, hn::Set(d, static_cast<std::uint8_t>(i)), len);
    prev = hn::IfThenElse(active, q, prev);
  }
  return len;
}

void GreyCrossArmsRow(const std::uint8_t* image, std::ptrdiff_t stride, int width, int height,
                      int y, const ArmParams& p, std::uint8_t* left, std::uint8_t* right,
                      std::uint8_t* up, std::uint8_t* down) {
  const hn::ScalableTag<std::uint8_t> d;
  const auto lengths = [&]<bool kLaneLimits>(const std::uint8_t* anchor, std::ptrdiff_t step,
                                             int limit, hn::Vec<decltype(d)> lane_limit) {
    return GreyArmLengths<kLaneLimits>(d, anchor, step, limit, p, lane_limit);
  };
  RowArms(d, image, stride, width, height, y, p, lengths, left, right, up, down);
}

// Per 32-bit lane, the sum of its four bytes. On x86 two multiply-adds with ones do it: bytes to
// 16-bit pair sums (at most 510), then pairs to 32-bit sums, all exact.
template <class D>
HWY_INLINE hn::Vec<D> SumOfBytes(D du, hn::Vec<D> v) {
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  if constexpr (hn::MaxLanes(D()) == 16)
    return hn::Vec<D>{
        _mm512_madd_epi16(_mm512_maddubs_epi16(v.raw, _mm512_set1_epi8(1)), _mm512_set1_epi16(1))};
#elif HWY_TARGET == HWY_AVX2
  if constexpr (hn::MaxLanes(D()) == 8)
    return hn::Vec<D>{
        _mm256_madd_epi16(_mm256_maddubs_epi16(v.raw, _mm256_set1_epi8(1)), _mm256_set1_epi16(1))};
#endif
  const auto byte_mask = hn::Set(du, 0xffu);
  return hn::Add(hn::Add(hn::And(v, byte_mask), hn::And(hn::ShiftRight<8>(v), byte_mask)),
                 hn::Add(hn::And(hn::ShiftRight<16>(v), byte_mask), hn::ShiftRight<24>(v)));
}

void MatchingCostRow(const CostRow& row, const CostTableView& t, int d, std::uint32_t* out) {
  const hn::ScalableTag<std::uint32_t> du;
  const hn::RebindToSigned<decltype(du)> di;
  const hn::Repartition<std::uint8_t, decltype(du)> du8;
  const hn::Repartition<std::uint64_t, decltype(du)> du64;
  const hn::Rebind<std::uint8_t, decltype(du)> du8n;  // one byte per 32-bit lane
  const int n = static_cast<int>(hn::Lanes(du));
  const int half = static_cast<int>(hn::Lanes(du64));
  const int w = row.width;
  const int first = std::min(d, w);
  std::fill(out, out + first, t.unmatched);
  const auto ad_size = hn::Set(di, t.ad_size);
  const auto census_size = hn::Set(di, t.census_size);
  const auto* ad_table = reinterpret_cast<const std::int32_t*>(t.ad);
  const auto* census_table = reinterpret_cast<const std::int32_t*>(t.census);
  int x = first;
  for (; x + n <= w; x += n) {
    // Sum of absolute channel differences: per-byte |a - b|, then the bytes of each word added.
    const auto a = hn::BitCast(du8, hn::LoadU(du, row.left + x));
    const auto b = hn::BitCast(du8, hn::LoadU(du, row.right + x - d));
    const auto diff = hn::BitCast(du, hn::Sub(hn::Max(a, b), hn::Min(a, b)));
    const auto ad = SumOfBytes(du, diff);
    // Hamming distances of the 64-bit descriptors, narrowed to one 32-bit lane per pixel.
    const auto lo = hn::PopulationCount(
        hn::Xor(hn::LoadU(du64, row.census_left + x), hn::LoadU(du64, row.census_right + x - d)));
    const auto hi = hn::PopulationCount(hn::Xor(hn::LoadU(du64, row.census_left + x + half),
                                                hn::LoadU(du64, row.census_right + x - d + half)));
    const auto hd = hn::ConcatEven(du, hn::BitCast(du, hi), hn::BitCast(du, lo));
    const auto arm = hn::BitCast(di, hn::PromoteTo(du, hn::LoadU(du8n, row.shortest_arm + x)));
    const auto ad_cost =
        hn::GatherIndex(di, ad_table, hn::Add(hn::Mul(arm, ad_size), hn::BitCast(di, ad)));
    const auto census_cost =
        hn::GatherIndex(di, census_table, hn::Add(hn::Mul(arm, census_size), hn::BitCast(di, hd)));
    hn::StoreU(hn::BitCast(du, hn::Add(ad_cost, census_cost)), du, out + x);
  }
  detail::matched_cost_range(row, t, d, x, w, out);
}

// Lane i: entry index[i] & (2n - 1) of the 2n-entry table whose first half is `lo` and second
// half `hi`. AVX-512 has this as one instruction; elsewhere two lookups and a select.
template <class D>
HWY_INLINE hn::Vec<D> TwoTableLookup(D du, hn::Vec<D> lo, hn::Vec<D> hi, hn::Vec<D> index) {
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  if constexpr (hn::MaxLanes(D()) == 16)
    return hn::Vec<D>{_mm512_permutex2var_epi32(lo.raw, index.raw, hi.raw)};
#endif
  const int n = static_cast<int>(hn::Lanes(du));
  const auto idx =
      hn::IndicesFromVec(du, hn::And(index, hn::Set(du, static_cast<std::uint32_t>(n - 1))));
  return hn::IfThenElse(hn::TestBit(index, hn::Set(du, static_cast<std::uint32_t>(n))),
                        hn::TableLookupLanes(hi, idx), hn::TableLookupLanes(lo, idx));
}

// One vector of matching distances of left pixel x: lane j pairs it with right pixel
// right[n - 1 - j] (the lanes run over the disparities, so the right image is read backwards).
// `a` is the left pixel's packed channels in every lane, `cl` its census descriptor; `ad` gets the
// sums of absolute channel differences, `hd` the Hamming distances of the descriptors.
// With kGrey (one channel: every packed pixel is its grey level, the other bytes zero) the sum
// of the bytes' differences is the difference of the words.
template <bool kGrey = false, class D>
HWY_INLINE void MatchDistances(D du, hn::Vec<D> a, hn::Vec<hn::Repartition<std::uint64_t, D>> cl,
                               const std::uint32_t* right, const std::uint64_t* census_right,
                               hn::Vec<D>& ad, hn::Vec<D>& hd) {
  const hn::Repartition<std::uint8_t, D> du8;
  const hn::Repartition<std::uint64_t, D> du64;
  const int half = static_cast<int>(hn::Lanes(du64));
  const auto b = hn::Reverse(du, hn::LoadU(du, right));
  if constexpr (kGrey) {
    ad = hn::Sub(hn::Max(a, b), hn::Min(a, b));
  } else {
    const auto a8 = hn::BitCast(du8, a);
    const auto b8 = hn::BitCast(du8, b);
    ad = SumOfBytes(du, hn::BitCast(du, hn::Sub(hn::Max(a8, b8), hn::Min(a8, b8))));
  }
  const auto lo =
      hn::PopulationCount(hn::Xor(cl, hn::Reverse(du64, hn::LoadU(du64, census_right + half))));
  const auto hi =
      hn::PopulationCount(hn::Xor(cl, hn::Reverse(du64, hn::LoadU(du64, census_right))));
  hd = hn::ConcatEven(du, hn::BitCast(du, hi), hn::BitCast(du, lo));
}

// The AD term from its arm's table row in registers (16 lanes): the row is constant from
// `flat_from` (< 96) on, so its first six vectors hold every value once the index is clamped.
template <class D>
HWY_INLINE hn::Vec<D> AdCostFromRegisters(D du, const std::uint32_t* ad_row, hn::Vec<D> ad,
                                          hn::Vec<D> flat_from) {
  const int n = static_cast<int>(hn::Lanes(du));
  const auto clamped = hn::Min(ad, flat_from);
  const auto v01 = TwoTableLookup(du, hn::LoadU(du, ad_row), hn::LoadU(du, ad_row + n), clamped);
  const auto v23 =
      TwoTableLookup(du, hn::LoadU(du, ad_row + 2 * n), hn::LoadU(du, ad_row + 3 * n), clamped);
  const auto v45 =
      TwoTableLookup(du, hn::LoadU(du, ad_row + 4 * n), hn::LoadU(du, ad_row + 5 * n), clamped);
  return hn::IfThenElse(
      hn::TestBit(clamped, hn::Set(du, static_cast<std::uint32_t>(4 * n))), v45,
      hn::IfThenElse(hn::TestBit(clamped, hn::Set(du, static_cast<std::uint32_t>(2 * n))), v23,
                     v01));
}

// The census term from its arm's table row in registers (16 lanes: 65 entries are four vectors
// and one more entry).
template <class D>
HWY_INLINE hn::Vec<D> CensusCostFromRegisters(D du, const std::uint32_t* census_row,
                                              hn::Vec<D> hd) {
  const int n = static_cast<int>(hn::Lanes(du));
  const auto low = TwoTableLookup(du, hn::LoadU(du, census_row), hn::LoadU(du, census_row + n), hd);
  const auto high =
      TwoTableLookup(du, hn::LoadU(du, census_row + 2 * n), hn::LoadU(du, census_row + 3 * n), hd);
  return hn::IfThenElse(
      hn::Eq(hd, hn::Set(du, static_cast<std::uint32_t>(4 * n))), hn::Set(du, census_row[4 * n]),
      hn::IfThenElse(hn::TestBit(hd, hn::Set(du, static_cast<std::uint32_t>(2 * n))), high, low));
}

// BlockCosts for pixels from..to - 1 when a batch is one vector of 16 lanes and every right
// pixel a lane reads lies inside the row (from >= d0 + 15): the same operations as its general
// loop, with the row's pointers in locals and, with kRunning, the running sum carried in a
// register rather than read back from the row just stored.
template <bool kRunning, bool kAdInRegisters, bool kGrey>
HWY_NOINLINE void BlockCostsOneVector(const CostRow& row, const CostTableView& t, int d0, int from,
                                      int to, std::uint32_t* HWY_RESTRICT out) {
  const hn::ScalableTag<std::uint32_t> du;
  const hn::RebindToSigned<decltype(du)> di;
  const hn::Repartition<std::uint64_t, decltype(du)> du64;
  constexpr int n = 16;
  const std::uint32_t* HWY_RESTRICT left = row.left;
  const std::uint32_t* HWY_RESTRICT right = row.right;
  const std::uint64_t* HWY_RESTRICT census_left = row.census_left;
  const std::uint64_t* HWY_RESTRICT census_right = row.census_right;
  const std::uint8_t* HWY_RESTRICT shortest_arm = row.shortest_arm;
  const std::uint32_t* HWY_RESTRICT census_table = t.census;
  const int census_size = t.census_size;
  const std::uint32_t* HWY_RESTRICT ad_table = t.ad;
  const int ad_size = t.ad_size;
  const auto flat_from = hn::Set(du, static_cast<std::uint32_t>(t.ad_flat_from));
  auto sum = hn::Zero(du);
  if constexpr (kRunning) sum = hn::LoadU(du, out + from * n);
  for (int x = from; x < to; ++x) {
    const int arm = shortest_arm[x];
    const int first = x - d0 - (n - 1);  // the right pixel of the batch's last disparity
    hn::Vec<decltype(du)> ad, hd;
    MatchDistances<kGrey>(du, hn::Set(du, left[x]), hn::Set(du64, census_left[x]), right + first,
                          census_right + first, ad, hd);
    hn::Vec<decltype(du)> ad_cost;
    if constexpr (kAdInRegisters) {
      ad_cost = AdCostFromRegisters(du, ad_table + arm * ad_size, ad, flat_from);
    } else {
      ad_cost = hn::BitCast(
          du, hn::GatherIndex(di, reinterpret_cast<const std::int32_t*>(ad_table),
                              hn::Add(hn::Set(di, arm * ad_size), hn::BitCast(di, ad))));
    }
    const auto cost =
        hn::Add(ad_cost, CensusCostFromRegisters(du, census_table + arm * census_size, hd));
    if constexpr (kRunning) {
      sum = hn::Add(sum, cost);
      hn::StoreU(sum, du, out + (x + 1) * n);
    } else {
      hn::StoreU(cost, du, out + x * n);
    }
  }
}

// Costs of the row's pixels [from, to) in the block layout; with kRunning, their running sums
// along the row instead: out[(x + 1) * count + k] = out[x * count + k] + cost (out[from * count ..
// (from + 1) * count) = 0), the prefix sums the horizontal aggregation needs, without a pass of
// their own.
template <bool kRunning>
void BlockCosts(const CostRow& row, const CostTableView& t, int d0, int count, int from, int to,
                std::uint32_t* out) {
  const hn::ScalableTag<std::uint32_t> du;
  const hn::RebindToSigned<decltype(du)> di;
  const hn::Repartition<std::uint64_t, decltype(du)> du64;
  const int n = static_cast<int>(hn::Lanes(du));
  const int vector_end = count - count % n;
  const auto unmatched = hn::Set(du, t.unmatched);
  const auto lanes = hn::Iota(di, 0);  // hoisted: Iota is not a single instruction everywhere
  const auto* ad_table = reinterpret_cast<const std::int32_t*>(t.ad);
  const auto* census_table = reinterpret_cast<const std::int32_t*>(t.census);
  // With 16 lanes the census row of one arm (65 entries) is four vectors and one more entry, so
  // lane permutes replace the second gather.
  const bool census_in_registers = n >= 16 && t.census_size == 4 * n + 1;
  // Likewise the AD row when it is constant past its first six vectors (grey images: the
  // exponential saturates near 80 grey levels): the index is clamped to where it turns constant.
  const bool ad_in_registers =
      n >= 16 && t.ad_flat_from > 0 && t.ad_flat_from < 6 * n && t.ad_size >= 6 * n;
  const auto flat_from = hn::Set(du, static_cast<std::uint32_t>(t.ad_flat_from));
  // The right pixels -(n - 1) .. n - 1 of the row, those before its start (and past its end) as
  // zero: a vector whose right pixels start before the row reads them from here, and its lanes
  // there become `unmatched`. Filled once per call, so the vector loads never wait on the
  // stores that filled them. Only a call that starts near the row's start needs it (a vector's
  // right pixels precede the row only for x < d0 + count - 1 + n - 1).
  HWY_ALIGN std::uint32_t right_head[2 * HWY_MAX_BYTES / 4];
  HWY_ALIGN std::uint64_t census_head[2 * HWY_MAX_BYTES / 4];
  const int head_size = from < d0 + count + n ? 2 * n - 1 : 0;
  for (int i = 0; i < head_size; ++i) {
    const int xi = i - (n - 1);
    const bool inside = xi >= 0 && xi < row.width;
    right_head[i] = inside ? row.right[xi] : 0u;
    census_head[i] = inside ? row.census_right[xi] : 0u;
  }
  if constexpr (kRunning) std::fill(out + from * count, out + (from + 1) * count, 0u);
  // Past the row's first d0 + n - 1 pixels, a batch of one vector takes the fast loop.
  const bool one_vector = n == 16 && count == n && census_in_registers;
  const int general_end = one_vector ? std::clamp(d0 + n - 1, from, to) : to;
  for (int x = from; x < general_end; ++x) {
    std::uint32_t* dst = out + (kRunning ? x + 1 : x) * count;
    const std::uint32_t* before = out + x * count;  // kRunning: the sums up to x - 1
    const auto emit = [&](hn::Vec<decltype(du)> cost, int k) {
      if constexpr (kRunning) cost = hn::Add(cost, hn::LoadU(du, before + k));
      hn::StoreU(cost, du, dst + k);
    };
    if (x < d0) {
      for (int k = 0; k < vector_end; k += n) emit(unmatched, k);
      for (int k = vector_end; k < count; ++k) dst[k] = t.unmatched + (kRunning ? before[k] : 0u);
      continue;
    }
    const auto a = hn::Set(du, row.left[x]);
    const auto cl = hn::Set(du64, row.census_left[x]);
    const int arm = row.shortest_arm[x];
    const std::uint32_t* ad_row = t.ad + arm * t.ad_size;
    const std::uint32_t* census_row = t.census + arm * t.census_size;
    for (int k = 0; k < vector_end; k += n) {
      // Lane j of this vector is disparity d0 + k + j and right pixel xr - j.
      const int xr = x - d0 - k;
      if (xr < 0) {
        emit(unmatched, k);
        continue;
      }
      // The right pixels xr - (n - 1) .. xr; from the head copy when some precede the row.
      const bool partial = xr < n - 1;
      const std::uint32_t* right = partial ? right_head + xr : row.right + xr - (n - 1);
      const std::uint64_t* census_right =
          partial ? census_head + xr : row.census_right + xr - (n - 1);
      hn::Vec<decltype(du)> ad, hd;
      MatchDistances(du, a, cl, right, census_right, ad, hd);
      const auto ad_cost =
          ad_in_registers ? AdCostFromRegisters(du, ad_row, ad, flat_from)
                          : hn::BitCast(du, hn::GatherIndex(di, ad_table,
                                                            hn::Add(hn::Set(di, arm * t.ad_size),
                                                                    hn::BitCast(di, ad))));
      const auto census_cost =
          census_in_registers
              ? CensusCostFromRegisters(du, census_row, hd)
              : hn::BitCast(du, hn::GatherIndex(di, census_table,
                                                hn::Add(hn::Set(di, arm * t.census_size),
                                                        hn::BitCast(di, hd))));
      auto cost = hn::Add(ad_cost, census_cost);
      if (partial)
        cost = hn::IfThenElse(hn::RebindMask(du, hn::Gt(lanes, hn::Set(di, xr))), unmatched, cost);
      emit(cost, k);
    }
    if constexpr (kRunning) {
      for (int k = vector_end; k < count; ++k)
        dst[k] = before[k] + (x >= d0 + k ? detail::matched_cost(row, t, x, d0 + k) : t.unmatched);
    } else {
      detail::block_cost_range(row, t, x, d0, count, vector_end, count, out);
    }
  }
  if (general_end < to) {
    // A table of 256 AD entries is one channel's (CostTables: 255 channels + 1).
    const bool grey = t.ad_size == 256;
    if (ad_in_registers && grey)
      BlockCostsOneVector<kRunning, true, true>(row, t, d0, general_end, to, out);
    else if (ad_in_registers)
      BlockCostsOneVector<kRunning, true, false>(row, t, d0, general_end, to, out);
    else
      BlockCostsOneVector<kRunning, false, false>(row, t, d0, general_end, to, out);
  }
}

void BlockMatchingCostRow(const CostRow& row, const CostTableView& t, int d0, int count,
                          std::uint32_t* out) {
  BlockCosts<false>(row, t, d0, count, 0, row.width, out);
}

void BlockMatchingCostSumsRange(const CostRow& row, const CostTableView& t, int d0, int count,
                                int begin, int end, std::uint32_t* prefix) {
  BlockCosts<true>(row, t, d0, count, begin, end, prefix);
}

}  // namespace HWY_NAMESPACE
}  // namespace dco::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dco::kernels {

HWY_EXPORT(TargetName);
HWY_EXPORT(HalfMeansRow);
HWY_EXPORT(CensusRow);
HWY_EXPORT(CrossArmsRow);
HWY_EXPORT(GreyCrossArmsRow);
HWY_EXPORT(MatchingCostRow);
HWY_EXPORT(BlockMatchingCostRow);
HWY_EXPORT(BlockMatchingCostSumsRange);

const char* simd_target() {
  return HWY_DYNAMIC_DISPATCH(TargetName)();
}

void half_means_row(const std::uint8_t* a, const std::uint8_t* b, int count, std::uint8_t* out) {
  HWY_DYNAMIC_DISPATCH(HalfMeansRow)(a, b, count, out);
}

void census_row(const std::uint8_t* const* rows, int width, int window_w, int window_h,
                std::uint64_t* out) {
  HWY_DYNAMIC_DISPATCH(CensusRow)(rows, width, window_w, window_h, out);
}

void cross_arms_row(const std::uint32_t* image, std::ptrdiff_t stride, int width, int height, int y,
                    const ArmParams& params, std::uint8_t* left, std::uint8_t* right,
                    std::uint8_t* up, std::uint8_t* down) {
  HWY_DYNAMIC_DISPATCH(CrossArmsRow)
  (image, stride, width, height, y, params, left, right, up, down);
}

void grey_cross_arms_row(const std::uint8_t* image, std::ptrdiff_t stride, int width, int height,
                         int y, const ArmParams& params, std::uint8_t* left, std::uint8_t* right,
                         std::uint8_t* up, std::uint8_t* down) {
  HWY_DYNAMIC_DISPATCH(GreyCrossArmsRow)
  (image, stride, width, height, y, params, left, right, up, down);
}

void matching_cost_row(const CostRow& row, const CostTableView& tables, int d, std::uint32_t* out) {
  HWY_DYNAMIC_DISPATCH(MatchingCostRow)(row, tables, d, out);
}

void block_matching_cost_row(const CostRow& row, const CostTableView& tables, int d0, int count,
                             std::uint32_t* out) {
  HWY_DYNAMIC_DISPATCH(BlockMatchingCostRow)(row, tables, d0, count, out);
}

void block_matching_cost_sums_row(const CostRow& row, const CostTableView& tables, int d0,
                                  int count, std::uint32_t* prefix) {
  HWY_DYNAMIC_DISPATCH(BlockMatchingCostSumsRange)(row, tables, d0, count, 0, row.width, prefix);
}

void block_matching_cost_sums_range(const CostRow& row, const CostTableView& tables, int d0,
                                    int count, int begin, int end, std::uint32_t* prefix) {
  HWY_DYNAMIC_DISPATCH(BlockMatchingCostSumsRange)(row, tables, d0, count, begin, end, prefix);
}

}  // namespace dco::kernels
#endif  // HWY_ONCE
