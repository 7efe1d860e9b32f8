// SIMD versions of the stereo stage's cost aggregation row kernels: sums over the cross-based
// support regions along rows and columns, their means, and the block layout's transposes.
// Compiled once per Highway target and dispatched at run time; each loop covers whole vectors and
// leaves the last partial vector to the scalar range functions, so any width is handled and the
// results equal dco::kernels::scalar bit for bit.

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "dco/kernels/stereo_kernels.hpp"
#include "scalar_ranges.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "stereo_aggregation_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dco::kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void HorizontalSumsRow(const std::uint32_t* in, const std::uint8_t* left, const std::uint8_t* right,
                       int width, std::uint32_t* prefix, std::uint32_t* out) {
  // The running sum carries from lane to lane, so it stays scalar; the window ends are gathers.
  detail::prefix_sums(in, width, prefix);
  const hn::ScalableTag<std::int32_t> di;
  const hn::Rebind<std::uint8_t, decltype(di)> du8n;
  const int n = static_cast<int>(hn::Lanes(di));
  const auto* p = reinterpret_cast<const std::int32_t*>(prefix);
  const auto one = hn::Set(di, 1);
  const auto lanes = hn::Iota(di, 0);  // hoisted: Iota is not a single instruction everywhere
  int x = 0;
  for (; x + n <= width; x += n) {
    const auto xs = hn::Add(lanes, hn::Set(di, x));
    const auto l = hn::PromoteTo(di, hn::LoadU(du8n, left + x));
    const auto r = hn::PromoteTo(di, hn::LoadU(du8n, right + x));
    const auto end = hn::GatherIndex(di, p, hn::Add(hn::Add(xs, r), one));
    const auto begin = hn::GatherIndex(di, p, hn::Sub(xs, l));
    hn::StoreU(hn::Sub(end, begin), di, reinterpret_cast<std::int32_t*>(out) + x);
  }
  detail::horizontal_range(prefix, left, right, x, width, out);
}

void AccumulateRow(const std::uint32_t* above, std::uint32_t* row, int width) {
  const hn::ScalableTag<std::uint32_t> du;
  const int n = static_cast<int>(hn::Lanes(du));
  int x = 0;
  for (; x + n <= width; x += n)
    hn::StoreU(hn::Add(hn::LoadU(du, row + x), hn::LoadU(du, above + x)), du, row + x);
  for (; x < width; ++x) row[x] += above[x];
}

void VerticalSumsRow(const std::uint32_t* column_sums, std::ptrdiff_t stride, int y,
                     const std::uint8_t* up, const std::uint8_t* down, int width,
                     std::uint32_t* out) {
  const hn::ScalableTag<std::int32_t> di;
  const hn::Rebind<std::uint8_t, decltype(di)> du8n;
  const int n = static_cast<int>(hn::Lanes(di));
  const auto* base = reinterpret_cast<const std::int32_t*>(column_sums);
  const auto vy = hn::Set(di, y);
  const auto vstride = hn::Set(di, static_cast<std::int32_t>(stride));
  const auto zero = hn::Zero(di);
  const auto lanes = hn::Iota(di, 0);
  int x = 0;
  for (; x + n <= width; x += n) {
    const auto xs = hn::Add(lanes, hn::Set(di, x));
    const auto top =
        hn::Sub(hn::Sub(vy, hn::PromoteTo(di, hn::LoadU(du8n, up + x))), hn::Set(di, 1));
    const auto bottom = hn::Add(vy, hn::PromoteTo(di, hn::LoadU(du8n, down + x)));
    const auto below_sum = hn::GatherIndex(di, base, hn::Add(hn::Mul(bottom, vstride), xs));
    // Above row 0 the running sum is 0: read row 0 there and drop it.
    const auto inside = hn::Gt(top, hn::Set(di, -1));
    const auto above_sum =
        hn::GatherIndex(di, base, hn::Add(hn::Mul(hn::Max(top, zero), vstride), xs));
    hn::StoreU(hn::Sub(below_sum, hn::IfThenElseZero(inside, above_sum)), di,
               reinterpret_cast<std::int32_t*>(out) + x);
  }
  detail::vertical_range(column_sums, stride, y, up, down, x, width, out);
}

void RegionMeanRow(std::uint32_t* row, const std::uint32_t* reciprocal, int width) {
  const hn::ScalableTag<std::uint32_t> du;
  const hn::Repartition<std::uint64_t, decltype(du)> du64;
  const int n = static_cast<int>(hn::Lanes(du));
  const auto half = hn::Set(du64, std::uint64_t{1} << 30);
  int x = 0;
  for (; x + n <= width; x += n) {
    const auto v = hn::LoadU(du, row + x);
    const auto r = hn::LoadU(du, reciprocal + x);
    // 32x32 -> 64-bit products of the even lanes, then of the odd lanes moved down.
    const auto even = hn::ShiftRight<31>(hn::Add(hn::MulEven(v, r), half));
    const auto v_odd = hn::BitCast(du, hn::ShiftRight<32>(hn::BitCast(du64, v)));
    const auto r_odd = hn::BitCast(du, hn::ShiftRight<32>(hn::BitCast(du64, r)));
    const auto odd = hn::ShiftRight<31>(hn::Add(hn::MulEven(v_odd, r_odd), half));
    hn::StoreU(hn::OddEven(hn::BitCast(du, hn::ShiftLeft<32>(odd)), hn::BitCast(du, even)), du,
               row + x);
  }
  detail::mean_range(row, reciprocal, x, width);
}

void RegionReciprocalRow(const std::uint32_t* size, int width, std::uint32_t* out) {
  // A 32-bit division per pixel costs more than the rest of building the support regions; in
  // double precision it vectorises. The numerator is below 2^32 + 2^31 and exact, as is n; a
  // quotient that is not whole lies at least 1 / n < 2^-21 below the next integer, more than half
  // a unit in the last place of a double below 2^33, so the rounded quotient truncates to the
  // exact one.
  const hn::ScalableTag<double> dd;
  const hn::RebindToSigned<decltype(dd)> di64;
  const hn::RebindToUnsigned<decltype(dd)> du64;
  const hn::Rebind<std::uint32_t, decltype(dd)> du32;
  const int n = static_cast<int>(hn::Lanes(dd));
  const auto base = hn::Set(du64, std::uint64_t{1} << 31);
  int x = 0;
  for (; x + n <= width; x += n) {
    const auto s = hn::PromoteTo(du64, hn::LoadU(du32, size + x));
    const auto numerator = hn::Add(base, hn::ShiftRight<1>(s));
    const auto q = hn::Div(hn::ConvertTo(dd, hn::BitCast(di64, numerator)),
                           hn::ConvertTo(dd, hn::BitCast(di64, s)));
    hn::StoreU(hn::TruncateTo(du32, hn::BitCast(du64, hn::ConvertTo(di64, q))), du32, out + x);
  }
  detail::reciprocal_range(size, x, width, out);
}

// BlockWindowSumsRow for blocks of one vector: the same sums without the loop over vectors.
template <bool kAbove>
HWY_NOINLINE void BlockWindowSumsOneVector(const std::uint32_t* HWY_RESTRICT prefix,
                                           const std::uint8_t* HWY_RESTRICT left,
                                           const std::uint8_t* HWY_RESTRICT right, int width,
                                           const std::uint32_t* HWY_RESTRICT above,
                                           std::uint32_t* HWY_RESTRICT out) {
  const hn::ScalableTag<std::uint32_t> du;
  constexpr int n = 16;
  for (int x = 0; x < width; ++x) {
    auto sum = hn::Sub(hn::LoadU(du, prefix + (x + right[x] + 1) * n),
                       hn::LoadU(du, prefix + (x - left[x]) * n));
    if constexpr (kAbove) sum = hn::Add(sum, hn::LoadU(du, above + x * n));
    hn::StoreU(sum, du, out + x * n);
  }
}

void BlockWindowSumsRow(const std::uint32_t* prefix, const std::uint8_t* left,
                        const std::uint8_t* right, int width, int block, const std::uint32_t* above,
                        std::uint32_t* out) {
  const hn::ScalableTag<std::uint32_t> du;
  const int n = static_cast<int>(hn::Lanes(du));
  if (n == 16 && block == n) {
    if (above != nullptr)
      BlockWindowSumsOneVector<true>(prefix, left, right, width, above, out);
    else
      BlockWindowSumsOneVector<false>(prefix, left, right, width, above, out);
    return;
  }
  const int vector_end = block - block % n;
  for (int x = 0; x < width; ++x) {
    const std::uint32_t* hi = prefix + (x + right[x] + 1) * block;
    const std::uint32_t* lo = prefix + (x - left[x]) * block;
    std::uint32_t* dst = out + x * block;
    if (above != nullptr) {
      const std::uint32_t* up = above + x * block;
      for (int k = 0; k < vector_end; k += n)
        hn::StoreU(
            hn::Add(hn::Sub(hn::LoadU(du, hi + k), hn::LoadU(du, lo + k)), hn::LoadU(du, up + k)),
            du, dst + k);
    } else {
      for (int k = 0; k < vector_end; k += n)
        hn::StoreU(hn::Sub(hn::LoadU(du, hi + k), hn::LoadU(du, lo + k)), du, dst + k);
    }
  }
  detail::block_horizontal_range(prefix, left, right, width, block, vector_end, block, above, out);
}

void BlockHorizontalSumsRow(const std::uint32_t* in, const std::uint8_t* left,
                            const std::uint8_t* right, int width, int block, std::uint32_t* prefix,
                            const std::uint32_t* above, std::uint32_t* out) {
  const hn::ScalableTag<std::uint32_t> du;
  const int n = static_cast<int>(hn::Lanes(du));
  const int vector_end = block - block % n;
  // The running sums stay in a register along x (a store and reload per pixel would put the
  // store-forwarding latency on the critical path).
  for (int k = 0; k < vector_end; k += n) {
    auto sum = hn::Zero(du);
    hn::StoreU(sum, du, prefix + k);
    for (int x = 0; x < width; ++x) {
      sum = hn::Add(sum, hn::LoadU(du, in + x * block + k));
      hn::StoreU(sum, du, prefix + (x + 1) * block + k);
    }
  }
  detail::block_prefix_range(in, width, block, vector_end, block, prefix);
  BlockWindowSumsRow(prefix, left, right, width, block, above, out);
}

// (v * r + 2^30) >> 31 per 32-bit lane in 64-bit arithmetic (kernels::pixel::region_mean).
template <class D>
HWY_INLINE hn::Vec<D> RegionMean(D du, hn::Vec<D> v, hn::Vec<D> r) {
  const hn::Repartition<std::uint64_t, D> du64;
  const auto half = hn::Set(du64, std::uint64_t{1} << 30);
  const auto even = hn::ShiftRight<31>(hn::Add(hn::MulEven(v, r), half));
  const auto v_odd = hn::BitCast(du, hn::ShiftRight<32>(hn::BitCast(du64, v)));
  const auto odd = hn::ShiftRight<31>(hn::Add(hn::MulEven(v_odd, r), half));
  return hn::OddEven(hn::BitCast(du, hn::ShiftLeft<32>(odd)), hn::BitCast(du, even));
}

// BlockVerticalSumsRow for blocks of one vector, region means taken: the same means without the
// loop over vectors.
HWY_NOINLINE void BlockVerticalMeansOneVector(const std::uint32_t* const* column_rows, int y,
                                              const std::uint8_t* HWY_RESTRICT up,
                                              const std::uint8_t* HWY_RESTRICT down, int width,
                                              const std::uint32_t* HWY_RESTRICT reciprocal,
                                              std::uint32_t* HWY_RESTRICT out) {
  const hn::ScalableTag<std::uint32_t> du;
  constexpr int n = 16;
  for (int x = 0; x < width; ++x) {
    const int top = y - up[x] - 1;
    auto sum = hn::LoadU(du, column_rows[y + down[x]] + x * n);
    if (top >= 0) sum = hn::Sub(sum, hn::LoadU(du, column_rows[top] + x * n));
    hn::StoreU(RegionMean(du, sum, hn::Set(du, reciprocal[x])), du, out + x * n);
  }
}

void BlockVerticalSumsRow(const std::uint32_t* const* column_rows, int y, const std::uint8_t* up,
                          const std::uint8_t* down, int width, int block,
                          const std::uint32_t* reciprocal, std::uint32_t* out) {
  const hn::ScalableTag<std::uint32_t> du;
  const int n = static_cast<int>(hn::Lanes(du));
  if (n == 16 && block == n && reciprocal != nullptr) {
    BlockVerticalMeansOneVector(column_rows, y, up, down, width, reciprocal, out);
    return;
  }
  const int vector_end = block - block % n;
  const auto finish = [&](hn::Vec<decltype(du)> sum, int x) {
    return reciprocal != nullptr ? RegionMean(du, sum, hn::Set(du, reciprocal[x])) : sum;
  };
  for (int x = 0; x < width; ++x) {
    const int top = y - up[x] - 1;
    const std::uint32_t* below = column_rows[y + down[x]] + x * block;
    std::uint32_t* dst = out + x * block;
    if (top >= 0) {
      const std::uint32_t* above = column_rows[top] + x * block;
      for (int k = 0; k < vector_end; k += n)
        hn::StoreU(finish(hn::Sub(hn::LoadU(du, below + k), hn::LoadU(du, above + k)), x), du,
                   dst + k);
    } else {
      for (int k = 0; k < vector_end; k += n)
        hn::StoreU(finish(hn::LoadU(du, below + k), x), du, dst + k);
    }
  }
  detail::block_vertical_range(column_rows, y, up, down, width, block, vector_end, block,
                               reciprocal, out);
}

#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
// BlocksToRows for blocks of 16 (block == 16, count <= 16), 16 pixels at a time: each pixel's
// 16 values narrowed into the 16-bit lanes of one 256-bit vector, then the 16x16 matrix
// transposed in registers: the 8x8 transpose of 16-bit lanes (interleaves of 16, 32 and 64 bits)
// on pixels 0..7 and on 8..15 does both 128-bit halves (values 0..7 and 8..15) at once, and
// joining the halves gives each value's row of 16 pixels; only the first `count` rows are
// stored. Returns the pixels done.
int BlocksToRows16(const std::uint32_t* HWY_RESTRICT blocks, int width, int count,
                   std::uint16_t* HWY_RESTRICT rows, std::ptrdiff_t row_stride) {
  const hn::FixedTag<std::int32_t, 16> di;
  const hn::FixedTag<std::uint16_t, 16> d16;
  const hn::Repartition<std::uint32_t, decltype(d16)> d32;
  const hn::Repartition<std::uint64_t, decltype(d16)> d64;
  using V = hn::Vec<decltype(d16)>;
  const auto pixel = [&](int x) {
    return hn::DemoteTo(d16, hn::LoadU(di, reinterpret_cast<const std::int32_t*>(blocks) + x * 16));
  };
  const auto lo32 = [&](V a, V b) {
    return hn::BitCast(d16, hn::InterleaveLower(d32, hn::BitCast(d32, a), hn::BitCast(d32, b)));
  };
  const auto hi32 = [&](V a, V b) {
    return hn::BitCast(d16, hn::InterleaveUpper(d32, hn::BitCast(d32, a), hn::BitCast(d32, b)));
  };
  const auto lo64 = [&](V a, V b) {
    return hn::BitCast(d16, hn::InterleaveLower(d64, hn::BitCast(d64, a), hn::BitCast(d64, b)));
  };
  const auto hi64 = [&](V a, V b) {
    return hn::BitCast(d16, hn::InterleaveUpper(d64, hn::BitCast(d64, a), hn::BitCast(d64, b)));
  };
  // Pixels x0 .. x0 + 7 into c[j]: value j of each in the lower half, value j + 8 in the upper.
  const auto eight = [&](int x0, V* c) {
    V t[8], u[8];
    for (int i = 0; i < 4; ++i) {
      const V a = pixel(x0 + 2 * i), b = pixel(x0 + 2 * i + 1);
      t[2 * i] = hn::InterleaveLower(d16, a, b);
      t[2 * i + 1] = hn::InterleaveUpper(d16, a, b);
    }
    for (int i = 0; i < 2; ++i) {
      u[4 * i] = lo32(t[4 * i], t[4 * i + 2]);
      u[4 * i + 1] = hi32(t[4 * i], t[4 * i + 2]);
      u[4 * i + 2] = lo32(t[4 * i + 1], t[4 * i + 3]);
      u[4 * i + 3] = hi32(t[4 * i + 1], t[4 * i + 3]);
    }
    for (int i = 0; i < 4; ++i) {
      c[2 * i] = lo64(u[i], u[i + 4]);
      c[2 * i + 1] = hi64(u[i], u[i + 4]);
    }
  };
  int x = 0;
  for (; x + 16 <= width; x += 16) {
    V first[8], second[8];
    eight(x, first);
    eight(x + 8, second);
    for (int j = 0; j < std::min(count, 8); ++j)
      hn::StoreU(hn::ConcatLowerLower(d16, second[j], first[j]), d16, rows + j * row_stride + x);
    for (int j = 8; j < count; ++j)
      hn::StoreU(hn::ConcatUpperUpper(d16, second[j - 8], first[j - 8]), d16,
                 rows + j * row_stride + x);
  }
  return x;
}
#endif

void BlocksToRows(const std::uint32_t* blocks, int width, int block, int count, std::uint16_t* rows,
                  std::ptrdiff_t row_stride) {
  int x_begin = 0;
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  if (block == 16) x_begin = BlocksToRows16(blocks, width, count, rows, row_stride);
#endif
  // 4x4 tiles transposed in registers (32-bit then 64-bit interleaves), then narrowed to 16 bits
  // (the values are below kNoCost, so the saturating narrowing is exact).
  const hn::FixedTag<std::uint32_t, 4> d;
  const hn::Repartition<std::uint64_t, decltype(d)> d64;
  const hn::RebindToSigned<decltype(d)> di;
  const hn::Rebind<std::uint16_t, decltype(d)> d16;
  const int x_end = width - width % 4;
  const int k_end = count - count % 4;
  const auto narrow = [&](hn::Vec<decltype(d64)> v) {
    return hn::DemoteTo(d16, hn::BitCast(di, v));
  };
  for (int x = x_begin; x < x_end; x += 4) {
    const std::uint32_t* src = blocks + x * block;
    for (int k = 0; k < k_end; k += 4) {
      const auto r0 = hn::LoadU(d, src + k);
      const auto r1 = hn::LoadU(d, src + block + k);
      const auto r2 = hn::LoadU(d, src + 2 * block + k);
      const auto r3 = hn::LoadU(d, src + 3 * block + k);
      const auto t0 = hn::BitCast(d64, hn::InterleaveLower(d, r0, r1));
      const auto t1 = hn::BitCast(d64, hn::InterleaveLower(d, r2, r3));
      const auto t2 = hn::BitCast(d64, hn::InterleaveUpper(d, r0, r1));
      const auto t3 = hn::BitCast(d64, hn::InterleaveUpper(d, r2, r3));
      std::uint16_t* dst = rows + k * row_stride + x;
      hn::StoreU(narrow(hn::InterleaveLower(d64, t0, t1)), d16, dst);
      hn::StoreU(narrow(hn::InterleaveUpper(d64, t0, t1)), d16, dst + row_stride);
      hn::StoreU(narrow(hn::InterleaveLower(d64, t2, t3)), d16, dst + 2 * row_stride);
      hn::StoreU(narrow(hn::InterleaveUpper(d64, t2, t3)), d16, dst + 3 * row_stride);
    }
  }
  detail::blocks_to_rows_rest(blocks, width, block, count, x_end, k_end, rows, row_stride);
}

}  // namespace HWY_NAMESPACE
}  // namespace dco::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dco::kernels {

HWY_EXPORT(HorizontalSumsRow);
HWY_EXPORT(AccumulateRow);
HWY_EXPORT(VerticalSumsRow);
HWY_EXPORT(RegionMeanRow);
HWY_EXPORT(RegionReciprocalRow);
HWY_EXPORT(BlockHorizontalSumsRow);
HWY_EXPORT(BlockWindowSumsRow);
HWY_EXPORT(BlockVerticalSumsRow);
HWY_EXPORT(BlocksToRows);

void block_window_sums_row(const std::uint32_t* prefix, const std::uint8_t* left,
                           const std::uint8_t* right, int width, int block,
                           const std::uint32_t* above, std::uint32_t* out) {
  HWY_DYNAMIC_DISPATCH(BlockWindowSumsRow)(prefix, left, right, width, block, above, out);
}

void horizontal_sums_row(const std::uint32_t* in, const std::uint8_t* left,
                         const std::uint8_t* right, int width, std::uint32_t* prefix,
                         std::uint32_t* out) {
  HWY_DYNAMIC_DISPATCH(HorizontalSumsRow)(in, left, right, width, prefix, out);
}

void accumulate_row(const std::uint32_t* above, std::uint32_t* row, int width) {
  HWY_DYNAMIC_DISPATCH(AccumulateRow)(above, row, width);
}

void vertical_sums_row(const std::uint32_t* column_sums, std::ptrdiff_t stride, int y,
                       const std::uint8_t* up, const std::uint8_t* down, int width,
                       std::uint32_t* out) {
  HWY_DYNAMIC_DISPATCH(VerticalSumsRow)(column_sums, stride, y, up, down, width, out);
}

void region_mean_row(std::uint32_t* row, const std::uint32_t* reciprocal, int width) {
  HWY_DYNAMIC_DISPATCH(RegionMeanRow)(row, reciprocal, width);
}

void region_reciprocal_row(const std::uint32_t* size, int width, std::uint32_t* out) {
  HWY_DYNAMIC_DISPATCH(RegionReciprocalRow)(size, width, out);
}

void block_horizontal_sums_row(const std::uint32_t* in, const std::uint8_t* left,
                               const std::uint8_t* right, int width, int block,
                               std::uint32_t* prefix, const std::uint32_t* above,
                               std::uint32_t* out) {
  HWY_DYNAMIC_DISPATCH(BlockHorizontalSumsRow)(in, left, right, width, block, prefix, above, out);
}

void block_vertical_sums_row(const std::uint32_t* const* column_rows, int y, const std::uint8_t* up,
                             const std::uint8_t* down, int width, int block,
                             const std::uint32_t* reciprocal, std::uint32_t* out) {
  HWY_DYNAMIC_DISPATCH(BlockVerticalSumsRow)
  (column_rows, y, up, down, width, block, reciprocal, out);
}

void blocks_to_rows(const std::uint32_t* blocks, int width, int block, int count,
                    std::uint16_t* rows, std::ptrdiff_t row_stride) {
  HWY_DYNAMIC_DISPATCH(BlocksToRows)(blocks, width, block, count, rows, row_stride);
}

}  // namespace dco::kernels
#endif  // HWY_ONCE
