// SIMD versions of the stereo stage's disparity selection row kernels: the histogram vote,
// winner-takes-all, the disparity values with their sub-pixel fit, and the left-right and
// uniqueness checks. Compiled once per Highway target and dispatched at run time; each loop
// covers whole vectors and leaves the last partial vector to the scalar range functions, so any
// width is handled and the results equal dco::kernels::scalar bit for bit.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "dco/kernels/stereo_kernels.hpp"
#include "scalar_ranges.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "stereo_selection_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dco::kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void BlockIndicatorRow(const std::int16_t* value, int width, const std::int32_t* candidates,
                       int count, std::uint32_t* out) {
  const hn::ScalableTag<std::int32_t> di;
  const int n = static_cast<int>(hn::Lanes(di));
  const int vector_end = count - count % n;
  const auto one = hn::Set(di, 1);
  for (int x = 0; x < width; ++x) {
    const auto v = hn::Set(di, value[x]);
    auto* dst = reinterpret_cast<std::int32_t*>(out) + x * count;
    for (int k = 0; k < vector_end; k += n)
      hn::StoreU(hn::IfThenElseZero(hn::Eq(v, hn::LoadU(di, candidates + k)), one), di, dst + k);
  }
  detail::block_indicator_range(value, width, candidates, count, vector_end, count, out);
}

void BlockVoteRow(const std::uint32_t* votes, int width, const std::int32_t* candidates, int count,
                  std::uint32_t* total, std::uint32_t* best_votes, std::int16_t* best_value) {
  const hn::ScalableTag<std::int32_t> di;
  const int n = static_cast<int>(hn::Lanes(di));
  const int vector_end = count - count % n;
  const auto* v32 = reinterpret_cast<const std::int32_t*>(votes);
  for (int x = 0; x < width; ++x) {
    for (int k = 0; k < vector_end; k += n) {
      const auto v = hn::LoadU(di, v32 + x * count + k);
      total[x] += static_cast<std::uint32_t>(hn::GetLane(hn::SumOfLanes(di, v)));
      const std::int32_t most = hn::GetLane(hn::MaxOfLanes(di, v));
      if (static_cast<std::uint32_t>(most) > best_votes[x]) {
        best_votes[x] = static_cast<std::uint32_t>(most);
        const intptr_t first = hn::FindFirstTrue(di, hn::Eq(v, hn::Set(di, most)));
        best_value[x] = static_cast<std::int16_t>(candidates[k + first]);
      }
    }
    detail::block_vote_range(votes, x, candidates, count, vector_end, count, total, best_votes,
                             best_value);
  }
}

void DisparityValuesRow(const DisparityRowInputs& in, int width, bool subpixel, float max_value,
                        float* raw, float* sparse) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::RebindToUnsigned<decltype(df)> du;
  const hn::Rebind<std::int16_t, decltype(df)> di16;
  const hn::Rebind<std::uint16_t, decltype(df)> du16;
  const hn::Rebind<std::uint8_t, decltype(df)> du8;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto zero = hn::Zero(df);
  const auto two = hn::Set(df, 2.0f);
  const auto top = hn::Set(df, max_value);
  const auto unknown = hn::Set(df, std::numeric_limits<float>::infinity());
  const auto no_cost = hn::Set(di, kNoCost);
  const auto invalid = hn::Set(di, pixel::kInvalid);
  const auto one = hn::Set(di, 1);
  const auto cost = [&](const std::uint16_t* p) {
    return hn::BitCast(di, hn::PromoteTo(du, hn::LoadU(du16, p)));
  };
  int x = 0;
  for (; x + n <= width; x += n) {
    // pixel::subpixel_offset: (below - above) / (2 rise) where the fit exists, else 0; lanes
    // without a fit divide by 1 and discard the quotient.
    const auto b = cost(in.below + x), c = cost(in.best + x), a = cost(in.above + x);
    const auto rise = hn::Sub(hn::Max(b, a), c);
    auto fit = hn::And(hn::And(hn::Not(hn::Eq(b, no_cost)), hn::Not(hn::Eq(a, no_cost))),
                       hn::And(hn::Not(hn::Lt(b, c)), hn::Not(hn::Lt(a, c))));
    fit = hn::And(fit, hn::Gt(rise, hn::Zero(di)));
    auto offset = zero;
    if (subpixel) {
      const auto quotient =
          hn::Div(hn::ConvertTo(df, hn::Sub(b, a)),
                  hn::Mul(two, hn::ConvertTo(df, hn::IfThenElse(fit, rise, one))));
      offset = hn::IfThenElseZero(hn::RebindMask(df, fit), quotient);
    }
    const auto v =
        hn::Add(hn::ConvertTo(df, hn::PromoteTo(di, hn::LoadU(di16, in.wta + x))), offset);
    hn::StoreU(hn::IfThenElse(hn::Lt(v, zero), zero, hn::IfThenElse(hn::Gt(v, top), top, v)), df,
               raw + x);
    const auto d = hn::PromoteTo(di, hn::LoadU(di16, in.checked + x));
    const auto voted = hn::RebindMask(
        df, hn::Not(hn::Eq(hn::BitCast(di, hn::PromoteTo(du, hn::LoadU(du8, in.voted + x))),
                           hn::Zero(di))));
    auto s = hn::Add(hn::ConvertTo(df, d), hn::IfThenZeroElse(voted, offset));
    s = hn::IfThenElse(hn::Gt(s, top), top, s);
    const auto has_value =
        hn::And(hn::RebindMask(df, hn::Not(hn::Eq(d, invalid))), hn::Gt(s, zero));
    hn::StoreU(hn::IfThenElse(has_value, s, unknown), df, sparse + x);
  }
  detail::disparity_values_range(in, subpixel, max_value, x, width, raw, sparse);
}

void WtaUpdateRange(const std::uint16_t* cost, std::ptrdiff_t cost_stride, int count, int begin,
                    int end, int d, const WtaRow& s) {
  const hn::ScalableTag<std::uint16_t> du;
  const hn::RebindToSigned<decltype(du)> di;
  using VU = hn::Vec<decltype(du)>;
  using VI = hn::Vec<decltype(di)>;
  const int n = static_cast<int>(hn::Lanes(du));
  const auto no_cost = hn::Set(du, kNoCost);
  const auto one = hn::Set(di, 1);
  const auto first = hn::Set(di, static_cast<std::int16_t>(d));
  // Disparity 0 starts the left state: it is set, not loaded.
  const bool fresh = d == 0;
  const auto no_disparity = hn::Set(di, pixel::kInvalid);
  int x = begin;
  for (; x + n <= end; x += n) {
    auto best = no_cost, second = no_cost, below = no_cost, above = no_cost;
    auto prev1 = no_cost, prev2 = no_cost, runmin = no_cost;
    auto disp = no_disparity;
    if (!fresh) {
      best = hn::LoadU(du, s.best + x);
      second = hn::LoadU(du, s.second + x);
      below = hn::LoadU(du, s.below + x);
      above = hn::LoadU(du, s.above + x);
      prev1 = hn::LoadU(du, s.prev1 + x);
      prev2 = hn::LoadU(du, s.prev2 + x);
      runmin = hn::LoadU(du, s.runmin + x);
      disp = hn::LoadU(di, s.disp + x);
    }
    VI dk = first;  // the disparity of the step, in every lane
    // One disparity: pixel::wta_feed on a vector of pixels. `older` is the cost two disparities
    // back; the caller rotates the names, so no step copies a register.
    const auto feed = [&](VU c, VU older, VU previous) {
      runmin = hn::Min(runmin, older);
      const auto better = hn::Lt(c, best);
      const auto next = hn::AndNot(better, hn::RebindMask(du, hn::Eq(disp, hn::Sub(dk, one))));
      best = hn::IfThenElse(better, c, best);
      disp = hn::IfThenElse(hn::RebindMask(di, better), dk, disp);
      second = hn::IfThenElse(better, runmin, hn::IfThenElse(next, second, hn::Min(second, c)));
      below = hn::IfThenElse(better, previous, below);
      above = hn::IfThenElse(better, no_cost, hn::IfThenElse(next, c, above));
      dk = hn::Add(dk, one);
    };
    int k = 0;
    for (; k + 2 <= count; k += 2) {
      const VU c0 = hn::LoadU(du, cost + k * cost_stride + x);
      const VU c1 = hn::LoadU(du, cost + (k + 1) * cost_stride + x);
      feed(c0, prev2, prev1);
      feed(c1, prev1, c0);
      prev2 = c0;
      prev1 = c1;
    }
    if (k < count) {
      const VU c0 = hn::LoadU(du, cost + k * cost_stride + x);
      feed(c0, prev2, prev1);
      prev2 = prev1;
      prev1 = c0;
    }
    hn::StoreU(best, du, s.best + x);
    hn::StoreU(second, du, s.second + x);
    hn::StoreU(below, du, s.below + x);
    hn::StoreU(above, du, s.above + x);
    hn::StoreU(prev1, du, s.prev1 + x);
    hn::StoreU(prev2, du, s.prev2 + x);
    hn::StoreU(runmin, du, s.runmin + x);
    hn::StoreU(disp, di, s.disp + x);
  }
  if (fresh) detail::wta_start_range(x, end, s);
  for (int k = 0; k < count; ++k) detail::wta_left_range(cost + k * cost_stride, x, end, d + k, s);
  // Right pixel r at disparity d + k is left pixel r + d + k. The right pixels whose left pixels
  // at every disparity of the call lie in [begin, end) keep their state in registers over the
  // disparities (a shifted load of each disparity's costs); those at either end of the range
  // take the costs they have disparity by disparity.
  const int main_begin = std::max(0, begin - d);
  int r = main_begin;
  for (; r + n <= end - d - count + 1; r += n) {
    auto best = hn::LoadU(du, s.best_right + r);
    auto disp = hn::LoadU(di, s.disp_right + r);
    VI dk = first;
    for (int k = 0; k < count; ++k) {
      const auto c = hn::LoadU(du, cost + k * cost_stride + r + d + k);
      const auto better = hn::Lt(c, best);
      best = hn::IfThenElse(better, c, best);
      disp = hn::IfThenElse(hn::RebindMask(di, better), dk, disp);
      dk = hn::Add(dk, one);
    }
    hn::StoreU(best, du, s.best_right + r);
    hn::StoreU(disp, di, s.disp_right + r);
  }
  const int main_end = r;
  for (int k = 0; k < count; ++k) {
    const int dk = d + k;
    const std::uint16_t* ck = cost + k * cost_stride;
    // Left pixels [x_begin, x_end) update right pixels x - dk.
    const auto shifted = [&](int x_begin, int x_end) {
      const auto vd = hn::Set(di, static_cast<std::int16_t>(dk));
      int xl = x_begin;
      for (; xl + n <= x_end; xl += n) {
        const auto c = hn::LoadU(du, ck + xl);
        const auto best = hn::LoadU(du, s.best_right + xl - dk);
        const auto better = hn::Lt(c, best);
        hn::StoreU(hn::IfThenElse(better, c, best), du, s.best_right + xl - dk);
        hn::StoreU(
            hn::IfThenElse(hn::RebindMask(di, better), vd, hn::LoadU(di, s.disp_right + xl - dk)),
            di, s.disp_right + xl - dk);
      }
      detail::wta_right_range(ck, xl, x_end, dk, s);
    };
    const int low = std::max(begin, dk);  // right pixels from 0 on
    shifted(low, std::max(low, std::min(end, main_begin + dk)));
    const int high = std::max(low, main_end + dk);
    shifted(high, std::max(high, end));
  }
}

void WtaSkipRange(int count, int begin, int end, int d, const WtaRow& s) {
  const hn::ScalableTag<std::uint16_t> du;
  const hn::RebindToSigned<decltype(du)> di;
  const int n = static_cast<int>(hn::Lanes(du));
  const auto no_cost = hn::Set(du, kNoCost);
  const auto winner_below = hn::Set(di, static_cast<std::int16_t>(d - 1));  // d == disp + 1
  // Disparity 0 starts the left state: it is set, not loaded (the winner and its costs too).
  const bool fresh = d == 0;
  const auto no_disparity = hn::Set(di, pixel::kInvalid);
  int x = begin;
  for (; x + n <= end; x += n) {
    auto prev1 = no_cost, prev2 = no_cost, runmin = no_cost, above = no_cost;
    auto disp = no_disparity;
    if (!fresh) {
      prev1 = hn::LoadU(du, s.prev1 + x);
      prev2 = hn::LoadU(du, s.prev2 + x);
      runmin = hn::LoadU(du, s.runmin + x);
      above = hn::LoadU(du, s.above + x);
      disp = hn::LoadU(di, s.disp + x);
    }
    runmin = hn::Min(runmin, prev2);
    if (count >= 2) runmin = hn::Min(runmin, prev1);
    hn::StoreU(runmin, du, s.runmin + x);
    const auto next = hn::RebindMask(du, hn::Eq(disp, winner_below));
    hn::StoreU(hn::IfThenElse(next, no_cost, above), du, s.above + x);
    hn::StoreU(count >= 2 ? no_cost : prev1, du, s.prev2 + x);
    hn::StoreU(no_cost, du, s.prev1 + x);
    if (fresh) {
      hn::StoreU(no_cost, du, s.best + x);
      hn::StoreU(no_cost, du, s.second + x);
      hn::StoreU(no_cost, du, s.below + x);
      hn::StoreU(disp, di, s.disp + x);
    }
  }
  if (fresh) detail::wta_start_range(x, end, s);
  for (; x < end; ++x)
    pixel::wta_skip(d, count, s.above[x], s.prev1[x], s.prev2[x], s.runmin[x], s.disp[x]);
}

void LeftRightCheckRow(std::int16_t* HWY_RESTRICT left, const std::int16_t* HWY_RESTRICT right,
                       int width, int max_diff, std::int32_t* HWY_RESTRICT scratch) {
  const hn::ScalableTag<std::int32_t> di;
  const hn::Rebind<std::int16_t, decltype(di)> d16;
  const int n = static_cast<int>(hn::Lanes(di));
  // 32-bit lanes can gather only 32-bit values: the right row widened once.
  int x = 0;
  for (; x + n <= width; x += n)
    hn::StoreU(hn::PromoteTo(di, hn::LoadU(d16, right + x)), di, scratch + x);
  for (; x < width; ++x) scratch[x] = right[x];
  const auto invalid = hn::Set(di, pixel::kInvalid);
  const auto beyond = hn::Set(di, max_diff + 1);
  const auto lanes = hn::Iota(di, 0);  // hoisted: Iota is not a single instruction everywhere
  for (x = 0; x + n <= width; x += n) {
    const auto d = hn::PromoteTo(di, hn::LoadU(d16, left + x));
    const auto xr = hn::Sub(hn::Add(lanes, hn::Set(di, x)), d);
    // Invalid lanes (d = -1) and those left of the row look up column 0 and are dropped anyway.
    const auto inside = hn::And(hn::Ne(d, invalid), hn::Gt(xr, hn::Set(di, -1)));
    const auto r = hn::GatherIndex(di, scratch, hn::IfThenElseZero(inside, xr));
    const auto agree =
        hn::And(inside, hn::And(hn::Ne(r, invalid), hn::Lt(hn::Abs(hn::Sub(r, d)), beyond)));
    hn::StoreU(hn::DemoteTo(d16, hn::IfThenElse(agree, d, invalid)), d16, left + x);
  }
  for (; x < width; ++x)
    if (left[x] != pixel::kInvalid && !pixel::left_right_agree(x, left[x], right, max_diff))
      left[x] = pixel::kInvalid;
}

void UniquenessCheckRow(std::int16_t* HWY_RESTRICT disparity,
                        const std::uint16_t* HWY_RESTRICT best,
                        const std::uint16_t* HWY_RESTRICT second, int width, double keep) {
  // In double lanes, so that the products and comparisons are the pixel rule's own.
  const hn::ScalableTag<double> df;
  const hn::Rebind<std::int32_t, decltype(df)> di32;
  const hn::Rebind<std::uint32_t, decltype(df)> du32;
  const hn::Rebind<std::uint16_t, decltype(df)> du16;
  const hn::Rebind<std::int16_t, decltype(df)> di16;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto to_double = [&](const std::uint16_t* p) {
    return hn::PromoteTo(df, hn::BitCast(di32, hn::PromoteTo(du32, hn::LoadU(du16, p))));
  };
  const auto factor = hn::Set(df, keep);
  const auto no_cost = hn::Set(df, static_cast<double>(kNoCost));
  const auto invalid = hn::Set(df, static_cast<double>(pixel::kInvalid));
  int x = 0;
  for (; x + n <= width; x += n) {
    const auto b = to_double(best + x);
    const auto s = to_double(second + x);
    const auto reject = hn::AndNot(hn::Eq(s, no_cost), hn::Gt(b, hn::Mul(factor, s)));
    const auto d = hn::PromoteTo(df, hn::PromoteTo(di32, hn::LoadU(di16, disparity + x)));
    hn::StoreU(hn::DemoteTo(di16, hn::DemoteTo(di32, hn::IfThenElse(reject, invalid, d))), di16,
               disparity + x);
  }
  for (; x < width; ++x)
    if (!pixel::unique_enough(best[x], second[x], keep)) disparity[x] = pixel::kInvalid;
}

}  // namespace HWY_NAMESPACE
}  // namespace dco::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dco::kernels {

HWY_EXPORT(BlockIndicatorRow);
HWY_EXPORT(BlockVoteRow);
HWY_EXPORT(WtaUpdateRange);
HWY_EXPORT(WtaSkipRange);
HWY_EXPORT(DisparityValuesRow);
HWY_EXPORT(LeftRightCheckRow);
HWY_EXPORT(UniquenessCheckRow);

void block_indicator_row(const std::int16_t* value, int width, const std::int32_t* candidates,
                         int count, std::uint32_t* out) {
  HWY_DYNAMIC_DISPATCH(BlockIndicatorRow)(value, width, candidates, count, out);
}

void block_vote_row(const std::uint32_t* votes, int width, const std::int32_t* candidates,
                    int count, std::uint32_t* total, std::uint32_t* best_votes,
                    std::int16_t* best_value) {
  HWY_DYNAMIC_DISPATCH(BlockVoteRow)
  (votes, width, candidates, count, total, best_votes, best_value);
}

void wta_update_row(const std::uint16_t* cost, std::ptrdiff_t cost_stride, int count, int width,
                    int d, const WtaRow& row) {
  HWY_DYNAMIC_DISPATCH(WtaUpdateRange)(cost, cost_stride, count, 0, width, d, row);
}

void wta_update_range(const std::uint16_t* cost, std::ptrdiff_t cost_stride, int count, int begin,
                      int end, int d, const WtaRow& row) {
  HWY_DYNAMIC_DISPATCH(WtaUpdateRange)(cost, cost_stride, count, begin, end, d, row);
}

void wta_skip_row(int count, int width, int d, const WtaRow& row) {
  HWY_DYNAMIC_DISPATCH(WtaSkipRange)(count, 0, width, d, row);
}

void wta_skip_range(int count, int begin, int end, int d, const WtaRow& row) {
  HWY_DYNAMIC_DISPATCH(WtaSkipRange)(count, begin, end, d, row);
}

void disparity_values_row(const DisparityRowInputs& in, int width, bool subpixel, float max_value,
                          float* raw, float* sparse) {
  HWY_DYNAMIC_DISPATCH(DisparityValuesRow)(in, width, subpixel, max_value, raw, sparse);
}

void left_right_check_row(std::int16_t* left, const std::int16_t* right, int width, int max_diff,
                          std::int32_t* scratch) {
  HWY_DYNAMIC_DISPATCH(LeftRightCheckRow)(left, right, width, max_diff, scratch);
}

void uniqueness_check_row(std::int16_t* disparity, const std::uint16_t* best,
                          const std::uint16_t* second, int width, double keep) {
  HWY_DYNAMIC_DISPATCH(UniquenessCheckRow)(disparity, best, second, width, keep);
}

}  // namespace dco::kernels
#endif  // HWY_ONCE
