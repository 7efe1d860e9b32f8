// SIMD versions of the densify row kernels, compiled once per Highway target and dispatched at
// run time. The interior columns go by whole vectors; the borders and the last partial vector go
// to the scalar range functions, so any width is handled and the results equal
// dco::kernels::scalar bit for bit (the file is built without floating-point contraction).

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>

#include "dco/kernels/densify_kernels.hpp"
#include "densify_ranges.hpp"
#include "vector_cover.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "densify_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dco::kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The interior pixels [begin, end) of one colour, with the row pointers in restrict locals
// and the rows above and below fixed per call; returns the first pixel left undone. A pixel's
// update reads only the other colour and the other rows, so updating a pixel twice gives the
// same bits (detail::cover_with_vectors).
template <bool kBelow, bool kAbove>
HWY_NOINLINE int SmoothSplitInterior(const SplitSmoothRow& r, int begin, int end,
                                     float* HWY_RESTRICT x) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const float* HWY_RESTRICT b = r.b;
  const float* HWY_RESTRICT inv_diag = r.inv_diag;
  const float* HWY_RESTRICT wx = r.wx;
  // Pixel i's right neighbour is x_other[i + p], its left one and left edge at i + p - 1 (offset
  // where used: the row of a colour with no pixels has no data to point into).
  const float* HWY_RESTRICT wx_other = r.wx_other;
  const float* HWY_RESTRICT x_other = r.x_other;
  const int p = r.parity;
  const float* HWY_RESTRICT wy = r.wy;
  const float* HWY_RESTRICT x_below = r.x_below;
  const float* HWY_RESTRICT wy_above = r.wy_above;
  const float* HWY_RESTRICT x_above = r.x_above;
  const auto update = [&](int i) {
    auto v =
        hn::Add(hn::LoadU(d, b + i), hn::Mul(hn::LoadU(d, wx + i), hn::LoadU(d, x_other + i + p)));
    v = hn::Add(v, hn::Mul(hn::LoadU(d, wx_other + i + p - 1), hn::LoadU(d, x_other + i + p - 1)));
    auto vertical = hn::Zero(d);
    if constexpr (kBelow) vertical = hn::Mul(hn::LoadU(d, wy + i), hn::LoadU(d, x_below + i));
    if constexpr (kAbove)
      vertical = hn::Add(vertical, hn::Mul(hn::LoadU(d, wy_above + i), hn::LoadU(d, x_above + i)));
    hn::StoreU(hn::Mul(hn::Add(v, vertical), hn::LoadU(d, inv_diag + i)), d, x + i);
  };
  return detail::cover_with_vectors(begin, end, n, update);
}

void GridSmoothSplitRow(const SplitSmoothRow& r, float* x) {
  const int count = parity_count(r.width, r.parity);
  // Pixels with both row neighbours: column 2 i + p > 0 and 2 i + p + 1 < width.
  const int begin = 1 - r.parity;
  const int end = std::max(begin, (r.width - r.parity) / 2);
  detail::smooth_split_range(r, x, 0, std::min(begin, count));
  int done = begin;
  detail::with_rows_next_to(
      r.x_below != nullptr, r.x_above != nullptr, [&](auto below, auto above) {
        done =
            SmoothSplitInterior<decltype(below)::value, decltype(above)::value>(r, begin, end, x);
      });
  detail::smooth_split_range(r, x, done, count);
}

// The interior pixels [begin, end) of one colour of split_residual_row, as SmoothSplitInterior
// (the output is not an input, so the last partial vector overlaps the one before it).
template <bool kBelow, bool kAbove>
HWY_NOINLINE int ResidualSplitInterior(const SplitResidualRow& r, int begin, int end,
                                       float* HWY_RESTRICT out) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const SplitSmoothRow& s = r.row;
  const float* HWY_RESTRICT b = s.b;
  const float* HWY_RESTRICT diag = r.diag;
  const float* HWY_RESTRICT x = r.x;
  const float* HWY_RESTRICT wx = s.wx;
  const float* HWY_RESTRICT wx_other = s.wx_other;
  const float* HWY_RESTRICT x_other = s.x_other;
  const int p = s.parity;
  const float* HWY_RESTRICT wy = s.wy;
  const float* HWY_RESTRICT x_below = s.x_below;
  const float* HWY_RESTRICT wy_above = s.wy_above;
  const float* HWY_RESTRICT x_above = s.x_above;
  const auto residual = [&](int i) {
    auto v = hn::Sub(hn::Mul(hn::LoadU(d, diag + i), hn::LoadU(d, x + i)),
                     hn::Mul(hn::LoadU(d, wx + i), hn::LoadU(d, x_other + i + p)));
    v = hn::Sub(v, hn::Mul(hn::LoadU(d, wx_other + i + p - 1), hn::LoadU(d, x_other + i + p - 1)));
    auto vertical = hn::Zero(d);
    if constexpr (kBelow) vertical = hn::Mul(hn::LoadU(d, wy + i), hn::LoadU(d, x_below + i));
    if constexpr (kAbove)
      vertical = hn::Add(vertical, hn::Mul(hn::LoadU(d, wy_above + i), hn::LoadU(d, x_above + i)));
    hn::StoreU(hn::Sub(hn::LoadU(d, b + i), hn::Sub(v, vertical)), d, out + i);
  };
  return detail::cover_with_vectors(begin, end, n, residual);
}

void ResidualSplitRow(const SplitResidualRow& r, float* out) {
  const SplitSmoothRow& s = r.row;
  const int count = parity_count(s.width, s.parity);
  const int begin = 1 - s.parity;
  const int end = std::max(begin, (s.width - s.parity) / 2);
  detail::residual_split_range(r, out, 0, std::min(begin, count));
  int done = begin;
  detail::with_rows_next_to(
      s.x_below != nullptr, s.x_above != nullptr, [&](auto below, auto above) {
        done = ResidualSplitInterior<decltype(below)::value, decltype(above)::value>(r, begin, end,
                                                                                     out);
      });
  detail::residual_split_range(r, out, done, count);
}

void InverseDiagonalRow(const float* HWY_RESTRICT diag, int count, float* HWY_RESTRICT inv) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto zero = hn::Zero(d);
  const auto one = hn::Set(d, 1.0f);
  const auto inverse = [&](int i) {
    const auto s = hn::LoadU(d, diag + i);
    hn::StoreU(hn::IfThenElseZero(hn::Gt(s, zero), hn::Div(one, s)), d, inv + i);
  };
  const int done = detail::cover_with_vectors(0, count, n, inverse);
  detail::inverse_diagonal_range(diag, done, count, inv);
}

void SplitRow(const float* HWY_RESTRICT in, int width, float* HWY_RESTRICT even,
              float* HWY_RESTRICT odd) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int pairs = width / 2;
  const auto split = [&](int i) {
    hn::Vec<decltype(d)> e, o;
    hn::LoadInterleaved2(d, in + 2 * i, e, o);
    hn::StoreU(e, d, even + i);
    hn::StoreU(o, d, odd + i);
  };
  const int done = detail::cover_with_vectors(0, pairs, n, split);
  detail::split_range(in, width, done, parity_count(width, 0), even, odd);
}

void MergeRow(const float* HWY_RESTRICT even, const float* HWY_RESTRICT odd, int width,
              float* HWY_RESTRICT out) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int pairs = width / 2;
  const auto merge = [&](int i) {
    hn::StoreInterleaved2(hn::LoadU(d, even + i), hn::LoadU(d, odd + i), d, out + 2 * i);
  };
  const int done = detail::cover_with_vectors(0, pairs, n, merge);
  detail::merge_range(even, odd, width, done, parity_count(width, 0), out);
}

// Columns [begin, end) of A x, each with both row neighbours, as SmoothSplitInterior (out is
// not an input); returns the first column left undone.
template <bool kBelow, bool kAbove>
HWY_NOINLINE int ApplyInterior(const GridRow& r, const float* HWY_RESTRICT x, int begin, int end,
                               float* HWY_RESTRICT out) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const float* HWY_RESTRICT diag = r.diag;
  const float* HWY_RESTRICT wx = r.wx;
  const float* HWY_RESTRICT wy = r.wy;
  const float* HWY_RESTRICT x_below = r.x_below;
  const float* HWY_RESTRICT wy_above = r.wy_above;
  const float* HWY_RESTRICT x_above = r.x_above;
  const auto apply = [&](int c) {
    auto v = hn::Sub(hn::Mul(hn::LoadU(d, diag + c), hn::LoadU(d, x + c)),
                     hn::Mul(hn::LoadU(d, wx + c), hn::LoadU(d, x + c + 1)));
    v = hn::Sub(v, hn::Mul(hn::LoadU(d, wx + c - 1), hn::LoadU(d, x + c - 1)));
    auto vertical = hn::Zero(d);
    if constexpr (kBelow) vertical = hn::Mul(hn::LoadU(d, wy + c), hn::LoadU(d, x_below + c));
    if constexpr (kAbove)
      vertical = hn::Add(vertical, hn::Mul(hn::LoadU(d, wy_above + c), hn::LoadU(d, x_above + c)));
    hn::StoreU(hn::Sub(v, vertical), d, out + c);
  };
  return detail::cover_with_vectors(begin, end, n, apply);
}

void GridApplyRow(const GridRow& r, const float* x, float* out) {
  const int w = r.width;
  detail::apply_range(r, x, out, 0, std::min(1, w));
  int done = 1;
  detail::with_rows_next_to(r.x_below != nullptr, r.x_above != nullptr,
                            [&](auto below, auto above) {
                              done = ApplyInterior<decltype(below)::value, decltype(above)::value>(
                                  r, x, 1, std::max(1, w - 1), out);
                            });
  detail::apply_range(r, x, out, done, w);
}

void EdgeWeightsRow(const EdgeEnds& e, const EdgeRule& rule, int n, float* out) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Rebind<std::uint8_t, decltype(df)> du8;
  const int lanes = static_cast<int>(hn::Lanes(df));
  const auto scale = hn::Set(df, rule.scale);
  const auto floor = hn::Set(df, rule.floor);
  const auto one = hn::Set(df, 1.0f);
  const auto cut = hn::Mul(scale, floor);
  const auto* colour = rule.colour;
  // With the floor reached within the first vector of weights, a difference past it clamps to
  // it (its product with 1 - min(s_a, s_b) <= 1 is below the floor too) and one lane permute
  // replaces the gather.
  const bool colour_in_register = colour != nullptr && rule.colour_floor_from < lanes;
  const auto colour_lanes = colour_in_register ? hn::LoadU(df, colour) : hn::Zero(df);
  const auto colour_last = hn::Set(di, colour_in_register ? rule.colour_floor_from : 0);
  const auto weights = [&](int i) {
    const auto ba = hn::PromoteTo(di, hn::LoadU(du8, e.barrier_a + i));
    const auto bb = hn::PromoteTo(di, hn::LoadU(du8, e.barrier_b + i));
    const auto sa = hn::LoadU(df, e.strength_a + i);
    const auto sb = hn::LoadU(df, e.strength_b + i);
    // min(a, b) as the reference picks it: b where b < a or b is NaN, else a (the same value,
    // signed zeros and NaN from either end).
    auto weight = hn::Sub(one, hn::IfThenElse(hn::Or(hn::Lt(sb, sa), hn::IsNaN(sb)), sb, sa));
    if (colour != nullptr) {
      const auto ga = hn::PromoteTo(di, hn::LoadU(du8, e.grey_a + i));
      const auto gb = hn::PromoteTo(di, hn::LoadU(du8, e.grey_b + i));
      const auto diff = hn::Abs(hn::Sub(ga, gb));
      weight = hn::Mul(
          weight, colour_in_register
                      ? hn::TableLookupLanes(colour_lanes,
                                             hn::IndicesFromVec(df, hn::Min(diff, colour_last)))
                      : hn::GatherIndex(df, colour, diff));
    }
    const auto kept = hn::Mul(scale, hn::IfThenElse(hn::Lt(weight, floor), floor, weight));
    hn::StoreU(hn::IfThenElse(hn::RebindMask(df, hn::Ne(ba, bb)), cut, kept), df, out + i);
  };
  const int done = detail::cover_with_vectors(0, n, lanes, weights);  // out is not an input
  detail::edge_range(e, rule, done, n, out);
}

// Bit i of `bits`: values[i] is known (positive and finite), for i < count <= 64.
void KnownBits(const float* values, int count, std::uint64_t& bits) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));  // a power of two, at most 64
  const auto zero = hn::Zero(d);
  const auto inf = hn::Set(d, std::numeric_limits<float>::infinity());
  HWY_ALIGN float pad[HWY_MAX_BYTES / sizeof(float)];
  bits = 0;
  for (int j = 0; j < count; j += n) {
    hn::Vec<decltype(d)> v;
    if (j + n <= count) {
      v = hn::LoadU(d, values + j);
    } else {
      for (int i = 0; i < n; ++i) pad[i] = j + i < count ? values[j + i] : 0.0f;  // 0: unknown
      v = hn::Load(d, pad);
    }
    std::uint8_t bytes[8] = {};  // StoreMaskBits writes ceil(n / 8) bytes, unused bits zero
    hn::StoreMaskBits(d, hn::And(hn::Gt(v, zero), hn::Lt(v, inf)), bytes);
    std::uint64_t lane_bits = 0;
    std::memcpy(&lane_bits, bytes, sizeof(lane_bits));
    bits |= lane_bits << j;
  }
}

// The hints of the hole run [start, end) of a row, whose known neighbours are start - 1 and end
// where they lie inside the row, as hole_hint_row defines them. The left path to a hole x crosses
// a weak edge when one lies in [start - 1, x - 1], so every hole after the run's first weak edge
// has a crossed left path; the right path crosses one in [x, end - 1] (the row's last pixel has
// no edge), so every hole up to the last weak edge has a crossed right path. The run takes at
// most three values, one per stretch.
void HoleRunHints(const float* sparse, const float* wx, int width, float crossing, int start,
                  int end, float* hint) {
  const float left = start > 0 ? sparse[start - 1] : 0.0f;
  const float right = end < width ? sparse[end] : 0.0f;
  int first_weak = end;
  for (int j = std::max(start - 1, 0); j < end - 1; ++j)
    if (wx[j] < crossing) {
      first_weak = j;
      break;
    }
  int last_weak = start - 1;
  for (int j = std::min(end, width - 1) - 1; j >= start; --j)
    if (wx[j] < crossing) {
      last_weak = j;
      break;
    }
  // Left crossed from a on, right crossed before b.
  const int a = std::min(first_weak + 1, end);
  const int b = std::max(last_weak + 1, start);
  const auto fill = [&](int from, int to, bool left_crossed, bool right_crossed) {
    if (from < to)
      std::fill(hint + from, hint + to,
                pixel::hole_hint(left_crossed ? -left : left, right, right_crossed));
  };
  fill(start, std::min(a, b), false, true);
  if (a <= b)
    fill(a, b, true, true);
  else
    fill(b, a, false, false);
  fill(std::max(a, b), end, true, false);
}

// Calls run(start, end) for every maximal run of holes [start, end) of a row, in order, those
// touching the row's ends included. The runs come from bit masks of the matched pixels, 64 at a
// time: a branch per run rather than per pixel (rows alternate between short runs of matches and
// holes).
template <class Run>
void ForEachHoleRun(const float* sparse, int width, Run&& run) {
  bool open = true;  // the pixel before holds no value; the row starts inside a run
  int run_start = 0;
  for (int word = 0; word < width; word += 64) {
    const int lanes = std::min(64, width - word);
    std::uint64_t known = 0;
    KnownBits(sparse + word, lanes, known);
    const std::uint64_t valid = lanes == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << lanes) - 1;
    // Bits of the pixels whose state differs from the pixel before them.
    std::uint64_t changes = (known ^ ((known << 1) | (open ? 0u : 1u))) & valid;
    while (changes != 0) {
      const int i = static_cast<int>(hwy::Num0BitsBelowLS1Bit_Nonzero64(changes));
      changes &= changes - 1;
      const int x = word + i;
      open = ((known >> i) & 1u) == 0;
      if (open)
        run_start = x;
      else if (run_start < x)
        run(run_start, x);
    }
  }
  if (open && run_start < width) run(run_start, width);
}

// The runs of holes between the matched pixels are filled a stretch at a time; the matched
// pixels' entries are left alone.
void HoleHintRow(const float* sparse, const float* wx, int width, float crossing, float* hint) {
  ForEachHoleRun(sparse, width, [&](int start, int end) {
    HoleRunHints(sparse, wx, width, crossing, start, end, hint);
  });
}

// Runs as the scalar reference weights them: only those with a known pixel on both sides.
int OcclusionFillRow(const float* sparse, const float* hint, int width, const OcclusionRule& rule,
                     float* data, float* b) {
  int weighted = 0;
  int prev_start = -1, prev_end = -1;  // the previous run: known left neighbour, no strip
  ForEachHoleRun(sparse, width, [&](int start, int end) {
    if (start > 0 && end < width)
      weighted +=
          pixel::fill_occlusion_run(sparse, hint, start, end, rule, data, b, prev_start, prev_end);
  });
  return weighted;
}

void DataTermsRow(const float* sparse, const float* hint, const float* previous, int width,
                  const DataTermRule& rule, float* data, float* b, float* low, float* high) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto zero = hn::Zero(d);
  const auto inf = hn::Set(d, std::numeric_limits<float>::infinity());
  const auto regulariser = hn::Set(d, rule.regulariser);
  const auto lambda_d = hn::Set(d, rule.lambda_d);
  const auto hint_weight = hn::Set(d, rule.hint_weight);
  const auto lambda_s2 = hn::Set(d, rule.lambda_s2);
  // Min and max are exact, so the lanes' running extremes give the same result in any order.
  auto lo = hn::Set(d, *low), hi = hn::Set(d, *high);
  const auto known = [&](hn::Vec<decltype(d)> v) {
    return hn::And(hn::Gt(v, zero), hn::Lt(v, inf));
  };
  int x = 0;
  for (; x + n <= width; x += n) {
    const auto sp = hn::LoadU(d, sparse + x);
    const auto h = hn::LoadU(d, hint + x);
    const auto k = known(sp);
    const auto has_hint = hn::Gt(h, zero);
    const auto w = hn::IfThenElse(k, lambda_d, hn::IfThenElseZero(has_hint, hint_weight));
    const auto v = hn::IfThenElse(k, sp, hn::IfThenElseZero(has_hint, h));
    auto a = hn::Add(regulariser, w);
    auto r = hn::Add(zero, hn::Mul(w, v));
    lo = hn::IfThenElse(k, hn::Min(lo, sp), lo);
    hi = hn::IfThenElse(k, hn::Max(hi, sp), hi);
    if (previous != nullptr) {
      const auto p = hn::LoadU(d, previous + x);
      const auto kp = known(p);
      const auto w2 = hn::IfThenElseZero(kp, lambda_s2);
      a = hn::Add(a, w2);
      r = hn::Add(r, hn::Mul(w2, hn::IfThenElseZero(kp, p)));
      lo = hn::IfThenElse(kp, hn::Min(lo, p), lo);
      hi = hn::IfThenElse(kp, hn::Max(hi, p), hi);
    }
    hn::StoreU(a, d, data + x);
    hn::StoreU(r, d, b + x);
  }
  *low = hn::GetLane(hn::MinOfLanes(d, lo));
  *high = hn::GetLane(hn::MaxOfLanes(d, hi));
  detail::data_terms_range(sparse, hint, previous, rule, x, width, data, b, low, high);
}

// Columns [begin, end) of DiagonalRow, each with both row edges, with the rows above and below
// fixed per call (the outputs are not inputs); returns the first column left undone. The
// additions keep kernels::pixel::diagonal's order.
template <bool kBelow, bool kAbove>
HWY_NOINLINE int DiagonalInterior(const float* HWY_RESTRICT data, const float* HWY_RESTRICT wx,
                                  const float* HWY_RESTRICT wy, const float* HWY_RESTRICT wy_above,
                                  int begin, int end, float* HWY_RESTRICT diag,
                                  float* HWY_RESTRICT inv_diag) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto zero = hn::Zero(d);
  const auto one = hn::Set(d, 1.0f);
  const auto diagonal = [&](int x) {
    auto s = hn::Add(hn::LoadU(d, data + x), hn::LoadU(d, wx + x));
    s = hn::Add(s, hn::LoadU(d, wx + x - 1));
    if constexpr (kBelow) s = hn::Add(s, hn::LoadU(d, wy + x));
    if constexpr (kAbove) s = hn::Add(s, hn::LoadU(d, wy_above + x));
    hn::StoreU(s, d, diag + x);
    hn::StoreU(hn::IfThenElseZero(hn::Gt(s, zero), hn::Div(one, s)), d, inv_diag + x);
  };
  return detail::cover_with_vectors(begin, end, n, diagonal);
}

void DiagonalRow(const float* data, const float* wx, const float* wy, const float* wy_above,
                 int width, float* diag, float* inv_diag) {
  detail::diagonal_range(data, wx, wy, wy_above, width, 0, std::min(1, width), diag, inv_diag);
  int done = 1;
  detail::with_rows_next_to(wy != nullptr, wy_above != nullptr, [&](auto below, auto above) {
    done = DiagonalInterior<decltype(below)::value, decltype(above)::value>(
        data, wx, wy, wy_above, 1, std::max(1, width - 1), diag, inv_diag);
  });
  detail::diagonal_range(data, wx, wy, wy_above, width, done, width, diag, inv_diag);
}

void MatchPlaneRow(const float* sums, const float* own, int n, const MatchPlaneRule& rule,
                   float* plane) {
  const hn::ScalableTag<float> d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const auto one = hn::Set(d, 1.0f), zero = hn::Zero(d);
  const auto inf = hn::Set(d, std::numeric_limits<float>::infinity());
  const auto nan = hn::Set(d, std::numeric_limits<float>::quiet_NaN());
  const auto min_count = hn::Set(d, rule.min_count), max_square = hn::Set(d, rule.max_square);
  const auto offset = hn::Set(d, rule.offset), flat = hn::Set(d, 1e-3f);
  int i = 0;
  for (; i + lanes <= n; i += lanes) {
    const auto at = [&](int k) {
      return hn::LoadU(d, sums + static_cast<std::ptrdiff_t>(k) * n + i);
    };
    const auto count = at(0);
    const auto inv = hn::Div(one, hn::IfThenElse(hn::Gt(count, one), count, one));
    const auto mu = hn::Mul(at(1), inv), mv = hn::Mul(at(2), inv), md = hn::Mul(at(6), inv);
    const auto cuu = hn::Sub(at(3), hn::Mul(hn::Mul(count, mu), mu));
    const auto cuv = hn::Sub(at(4), hn::Mul(hn::Mul(count, mu), mv));
    const auto cvv = hn::Sub(at(5), hn::Mul(hn::Mul(count, mv), mv));
    const auto cud = hn::Sub(at(7), hn::Mul(hn::Mul(count, mu), md));
    const auto cvd = hn::Sub(at(8), hn::Mul(hn::Mul(count, mv), md));
    const auto cdd = hn::Sub(at(9), hn::Mul(hn::Mul(count, md), md));
    const auto det = hn::Sub(hn::Mul(cuu, cvv), hn::Mul(cuv, cuv));
    const auto a_det = hn::Sub(hn::Mul(cvv, cud), hn::Mul(cuv, cvd));
    const auto b_det = hn::Sub(hn::Mul(cuu, cvd), hn::Mul(cuv, cud));
    const auto v = hn::LoadU(d, own + i);
    auto fits = hn::And(hn::Gt(v, zero), hn::Lt(v, inf));
    fits = hn::And(fits, hn::Ge(count, min_count));
    fits = hn::And(fits, hn::Gt(det, hn::Mul(hn::Mul(flat, count), count)));
    fits = hn::And(fits, hn::Le(hn::Mul(hn::Sub(cdd, hn::Mul(max_square, count)), det),
                                hn::Add(hn::Mul(a_det, cud), hn::Mul(b_det, cvd))));
    const auto slope = hn::Div(hn::Add(hn::Mul(a_det, mu), hn::Mul(b_det, mv)), det);
    const auto value = hn::Add(offset, hn::Sub(md, slope));
    hn::StoreU(hn::IfThenElse(fits, value, nan), d, plane + i);
  }
  for (; i < n; ++i) {
    const auto at = [&](int k) { return sums[static_cast<std::ptrdiff_t>(k) * n + i]; };
    plane[i] = pixel::match_plane(at(0), at(1), at(2), at(3), at(4), at(5), at(6), at(7), at(8),
                                  at(9), own[i], rule);
  }
}

void MatchPlaneRowSums(const float* match, const float* dv, const float* dd, int n, int radius,
                       float* sums) {
  const hn::ScalableTag<float> d;
  using V = hn::Vec<decltype(d)>;
  const int lanes = static_cast<int>(hn::Lanes(d));
  // Pixels with every offset inside the row, [radius, n - radius): a vector of them keeps its six
  // sums in registers over the offsets and stores them once (computed afresh, so an overlapping
  // last vector gives the same values again). The sums add the offsets in rising order, as
  // pixel::match_plane_row_step's callers do.
  const int begin = std::min(radius, n);
  const int end = std::max(begin, n - radius);
  const auto one = hn::Set(d, 1.0f);
  const auto interior = [&](int x) {
    V a0 = hn::Zero(d), a1 = a0, a2 = a0, a3 = a0, a4 = a0, a5 = a0;
    for (int k = -radius; k <= radius; ++k) {
      const auto fk = static_cast<float>(k);
      const auto vk = hn::Set(d, fk), vk2 = hn::Set(d, fk * fk);
      const auto m = hn::LoadU(d, match + x + k), v = hn::LoadU(d, dv + x + k);
      const auto vv = hn::LoadU(d, dd + x + k);
      a0 = hn::Add(a0, hn::Mul(one, m));
      a1 = hn::Add(a1, hn::Mul(vk, m));
      a2 = hn::Add(a2, hn::Mul(vk2, m));
      a3 = hn::Add(a3, hn::Mul(one, v));
      a4 = hn::Add(a4, hn::Mul(vk, v));
      a5 = hn::Add(a5, hn::Mul(one, vv));
    }
    const auto at = [&](int j) { return sums + static_cast<std::ptrdiff_t>(j) * n + x; };
    hn::StoreU(a0, d, at(0));
    hn::StoreU(a1, d, at(1));
    hn::StoreU(a2, d, at(2));
    hn::StoreU(a3, d, at(3));
    hn::StoreU(a4, d, at(4));
    hn::StoreU(a5, d, at(5));
  };
  const int vector_end = detail::cover_with_vectors(begin, end, lanes, interior);
  // The rest pixel by pixel, over the offsets inside the row.
  const auto pixel_sums = [&](int x) {
    for (int j = 0; j < 6; ++j) sums[static_cast<std::ptrdiff_t>(j) * n + x] = 0.0f;
    for (int k = std::max(-radius, -x); k <= std::min(radius, n - 1 - x); ++k) {
      const auto fk = static_cast<float>(k);
      pixel::match_plane_row_step(match[x + k], dv[x + k], dd[x + k], fk, fk * fk, sums + x, n);
    }
  };
  for (int x = 0; x < begin; ++x) pixel_sums(x);
  for (int x = vector_end; x < n; ++x) pixel_sums(x);
}

// The four disparity sums (Σd, Σud, Σvd, Σd²) of the window at columns [x, x + lanes), in
// registers over the window's rows and stored once, each added up from 0 in row order.
template <class D>
HWY_INLINE void WindowDisparitySums(D d, const float* const* rows, int radius, int n, int x,
                                    float* s) {
  using V = hn::Vec<D>;
  const auto one = hn::Set(d, 1.0f);
  V a6 = hn::Zero(d), a7 = a6, a8 = a6, a9 = a6;
  for (int j = -radius; j <= radius; ++j) {
    const float* r = rows[j + radius];
    if (r == nullptr) continue;
    const auto v = hn::Set(d, static_cast<float>(j));
    const auto rd = hn::LoadU(d, r + 3 * n + x), rud = hn::LoadU(d, r + 4 * n + x);
    const auto rdd = hn::LoadU(d, r + 5 * n + x);
    a6 = hn::Add(a6, hn::Mul(one, rd));
    a7 = hn::Add(a7, hn::Mul(one, rud));
    a8 = hn::Add(a8, hn::Mul(v, rd));
    a9 = hn::Add(a9, hn::Mul(one, rdd));
  }
  const auto at = [&](int k) { return s + static_cast<std::ptrdiff_t>(k) * n + x; };
  hn::StoreU(a6, d, at(6));
  hn::StoreU(a7, d, at(7));
  hn::StoreU(a8, d, at(8));
  hn::StoreU(a9, d, at(9));
}

void MatchPlaneWindowSums(const float* const* rows, int radius, int n, float* s) {
  const hn::ScalableTag<float> d;
  using V = hn::Vec<decltype(d)>;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const auto one = hn::Set(d, 1.0f);
  int x = 0;
  // Each vector of columns: the six whole-number sums in registers over the window's rows,
  // stored once (named vectors: SVE vectors cannot form an array), then the four disparity
  // sums (each sum its own accumulator, so two passes give the bits of one).
  for (; x + lanes <= n; x += lanes) {
    V a0 = hn::Zero(d), a1 = a0, a2 = a0, a3 = a0, a4 = a0, a5 = a0;
    for (int j = -radius; j <= radius; ++j) {
      const float* r = rows[j + radius];
      if (r == nullptr) continue;
      const auto fv = static_cast<float>(j);
      const auto v = hn::Set(d, fv), v2 = hn::Set(d, fv * fv);
      const auto r0 = hn::LoadU(d, r + x), r1 = hn::LoadU(d, r + n + x);
      const auto r2 = hn::LoadU(d, r + 2 * n + x);
      a0 = hn::Add(a0, hn::Mul(one, r0));
      a1 = hn::Add(a1, hn::Mul(one, r1));
      a2 = hn::Add(a2, hn::Mul(v, r0));
      a3 = hn::Add(a3, hn::Mul(one, r2));
      a4 = hn::Add(a4, hn::Mul(v, r1));
      a5 = hn::Add(a5, hn::Mul(v2, r0));
    }
    const auto at = [&](int k) { return s + static_cast<std::ptrdiff_t>(k) * n + x; };
    hn::StoreU(a0, d, at(0));
    hn::StoreU(a1, d, at(1));
    hn::StoreU(a2, d, at(2));
    hn::StoreU(a3, d, at(3));
    hn::StoreU(a4, d, at(4));
    hn::StoreU(a5, d, at(5));
    WindowDisparitySums(d, rows, radius, n, x, s);
  }
  for (int k = 0; k < 10; ++k)
    std::fill(s + static_cast<std::ptrdiff_t>(k) * n + x,
              s + static_cast<std::ptrdiff_t>(k + 1) * n, 0.0f);
  for (int j = -radius; j <= radius; ++j) {
    const float* r = rows[j + radius];
    if (r == nullptr) continue;
    const auto v = static_cast<float>(j);
    for (int i = x; i < n; ++i) pixel::match_plane_window_step(r + i, v, v * v, n, s + i);
  }
}

void MatchPlaneWindowSlide(const float* const* rows, const float* left, int radius, int n,
                           float* s) {
  const hn::ScalableTag<float> d;
  using V = hn::Vec<decltype(d)>;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const float* entered = rows[2 * radius];
  const auto fr = static_cast<float>(radius);
  const auto two = hn::Set(d, 2.0f);
  const auto r = hn::Set(d, fr), r1 = hn::Set(d, fr + 1.0f);
  const auto rr = hn::Set(d, fr * fr), r1r1 = hn::Set(d, (fr + 1.0f) * (fr + 1.0f));
  const auto at = [&](int k, int x) { return s + static_cast<std::ptrdiff_t>(k) * n + x; };
  int x = 0;
  for (; x + lanes <= n; x += lanes) {
    // pixel::match_plane_window_move, operation for operation.
    const auto load = [&](const float* row, int k) {
      return row != nullptr ? hn::LoadU(d, row + static_cast<std::ptrdiff_t>(k) * n + x)
                            : hn::Zero(d);
    };
    const V l0 = load(left, 0), l1 = load(left, 1), l2 = load(left, 2);
    const V e0 = load(entered, 0), e1 = load(entered, 1), e2 = load(entered, 2);
    const V count = hn::Add(hn::Sub(hn::LoadU(d, at(0, x)), l0), e0);
    const V su = hn::Add(hn::Sub(hn::LoadU(d, at(1, x)), l1), e1);
    const V sv_up = hn::Add(hn::Add(hn::LoadU(d, at(2, x)), hn::Mul(r, l0)), hn::Mul(r1, e0));
    const V svv_up = hn::Add(hn::Sub(hn::LoadU(d, at(5, x)), hn::Mul(rr, l0)), hn::Mul(r1r1, e0));
    const V suv_up = hn::Add(hn::Add(hn::LoadU(d, at(4, x)), hn::Mul(r, l1)), hn::Mul(r1, e1));
    hn::StoreU(count, d, at(0, x));
    hn::StoreU(su, d, at(1, x));
    hn::StoreU(hn::Sub(sv_up, count), d, at(2, x));
    hn::StoreU(hn::Add(hn::Sub(hn::LoadU(d, at(3, x)), l2), e2), d, at(3, x));
    hn::StoreU(hn::Sub(suv_up, su), d, at(4, x));
    hn::StoreU(hn::Add(hn::Sub(svv_up, hn::Mul(two, sv_up)), count), d, at(5, x));
    WindowDisparitySums(d, rows, radius, n, x, s);  // afresh
  }
  detail::match_plane_window_slide_range(rows, left, radius, n, x, n, s);
}

double DotRow(const float* a, const float* b, int n) {
  // At most 16 lanes, so a vector is a whole number of the reference's partial sums: vector k of
  // a block holds partial sums k * lanes .. (k + 1) * lanes - 1.
  constexpr int kLanes = detail::kDotLanes;
  const hn::CappedTag<float, kLanes> d;
  const int lanes = static_cast<int>(hn::Lanes(d));
  const int vectors = kLanes / lanes;
  float partial[kLanes] = {};
  auto acc0 = hn::Zero(d), acc1 = hn::Zero(d), acc2 = hn::Zero(d), acc3 = hn::Zero(d);
  int i = 0;
  if (vectors <= 4) {
    for (; i + kLanes <= n; i += kLanes) {
      acc0 = hn::Add(acc0, hn::Mul(hn::LoadU(d, a + i), hn::LoadU(d, b + i)));
      if (vectors > 1)
        acc1 = hn::Add(acc1, hn::Mul(hn::LoadU(d, a + i + lanes), hn::LoadU(d, b + i + lanes)));
      if (vectors > 2) {
        acc2 = hn::Add(acc2,
                       hn::Mul(hn::LoadU(d, a + i + 2 * lanes), hn::LoadU(d, b + i + 2 * lanes)));
        acc3 = hn::Add(acc3,
                       hn::Mul(hn::LoadU(d, a + i + 3 * lanes), hn::LoadU(d, b + i + 3 * lanes)));
      }
    }
    hn::StoreU(acc0, d, partial);
    if (vectors > 1) hn::StoreU(acc1, d, partial + lanes);
    if (vectors > 2) {
      hn::StoreU(acc2, d, partial + 2 * lanes);
      hn::StoreU(acc3, d, partial + 3 * lanes);
    }
  } else {  // fewer than 4 lanes: not a target Highway builds for floats, but stay exact
    for (; i + kLanes <= n; i += kLanes)
      for (int lane = 0; lane < kLanes; ++lane) partial[lane] += a[i + lane] * b[i + lane];
  }
  return detail::finish_dot(a, b, i, n, partial);
}

// match_plane_select_half_row: the even and the odd columns of a vector of grid pixels apart.
void MatchPlaneSelectHalfRow(const float* HWY_RESTRICT sparse, const float* HWY_RESTRICT own,
                             const float* HWY_RESTRICT plane, int width, float* HWY_RESTRICT out) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int pairs = width / 2;
  const auto select = [&](int i) {
    hn::Vec<decltype(d)> even, odd;
    hn::LoadInterleaved2(d, sparse + 2 * i, even, odd);
    const auto g = hn::LoadU(d, own + i);
    const auto p = hn::LoadU(d, plane + i);
    const auto kept = hn::Eq(p, p);
    hn::StoreInterleaved2(hn::IfThenElse(hn::And(hn::Eq(even, g), kept), p, even),
                          hn::IfThenElse(hn::And(hn::Eq(odd, g), kept), p, odd), d, out + 2 * i);
  };
  // out is not an input; the rest (a row narrower than two vectors, an odd last column) pixel by
  // pixel.
  const int done = detail::cover_with_vectors(0, pairs, n, select);
  for (int x = 2 * done; x < width; ++x)
    out[x] = pixel::match_plane_select(sparse[x], own[x / 2], plane[x / 2]);
}

}  // namespace HWY_NAMESPACE
}  // namespace dco::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dco::kernels {

HWY_EXPORT(GridApplyRow);
HWY_EXPORT(GridSmoothSplitRow);
HWY_EXPORT(SplitRow);
HWY_EXPORT(ResidualSplitRow);
HWY_EXPORT(InverseDiagonalRow);
HWY_EXPORT(MergeRow);
HWY_EXPORT(DotRow);
HWY_EXPORT(MatchPlaneRowSums);
HWY_EXPORT(MatchPlaneWindowSums);
HWY_EXPORT(MatchPlaneWindowSlide);
HWY_EXPORT(MatchPlaneRow);
HWY_EXPORT(MatchPlaneSelectHalfRow);
HWY_EXPORT(EdgeWeightsRow);
HWY_EXPORT(HoleHintRow);
HWY_EXPORT(OcclusionFillRow);
HWY_EXPORT(DataTermsRow);
HWY_EXPORT(DiagonalRow);

void grid_apply_row(const GridRow& row, const float* x, float* out) {
  HWY_DYNAMIC_DISPATCH(GridApplyRow)(row, x, out);
}

void grid_smooth_split_row(const SplitSmoothRow& row, float* x) {
  HWY_DYNAMIC_DISPATCH(GridSmoothSplitRow)(row, x);
}

void split_row(const float* in, int width, float* even, float* odd) {
  HWY_DYNAMIC_DISPATCH(SplitRow)(in, width, even, odd);
}

void split_residual_row(const SplitResidualRow& row, float* out) {
  HWY_DYNAMIC_DISPATCH(ResidualSplitRow)(row, out);
}

void inverse_diagonal_row(const float* diag, int n, float* inv) {
  HWY_DYNAMIC_DISPATCH(InverseDiagonalRow)(diag, n, inv);
}

void merge_row(const float* even, const float* odd, int width, float* out) {
  HWY_DYNAMIC_DISPATCH(MergeRow)(even, odd, width, out);
}

double dot_row(const float* a, const float* b, int n) {
  return HWY_DYNAMIC_DISPATCH(DotRow)(a, b, n);
}

void match_plane_row_sums(const float* match, const float* d, const float* dd, int n, int radius,
                          float* sums) {
  HWY_DYNAMIC_DISPATCH(MatchPlaneRowSums)(match, d, dd, n, radius, sums);
}

void match_plane_window_sums(const float* const* rows, int radius, int n, float* sums) {
  HWY_DYNAMIC_DISPATCH(MatchPlaneWindowSums)(rows, radius, n, sums);
}

void match_plane_window_slide(const float* const* rows, const float* left, int radius, int n,
                              float* sums) {
  HWY_DYNAMIC_DISPATCH(MatchPlaneWindowSlide)(rows, left, radius, n, sums);
}

void match_plane_row(const float* sums, const float* own, int n, const MatchPlaneRule& rule,
                     float* plane) {
  HWY_DYNAMIC_DISPATCH(MatchPlaneRow)(sums, own, n, rule, plane);
}

void match_plane_select_half_row(const float* sparse, const float* own, const float* plane,
                                 int width, float* out) {
  HWY_DYNAMIC_DISPATCH(MatchPlaneSelectHalfRow)(sparse, own, plane, width, out);
}

void edge_weights_row(const EdgeEnds& ends, const EdgeRule& rule, int n, float* out) {
  HWY_DYNAMIC_DISPATCH(EdgeWeightsRow)(ends, rule, n, out);
}

void hole_hint_row(const float* sparse, const float* wx, int width, float crossing, float* hint) {
  HWY_DYNAMIC_DISPATCH(HoleHintRow)(sparse, wx, width, crossing, hint);
}

int occlusion_fill_row(const float* sparse, const float* hint, int width, const OcclusionRule& rule,
                       float* data, float* b) {
  return HWY_DYNAMIC_DISPATCH(OcclusionFillRow)(sparse, hint, width, rule, data, b);
}

void data_terms_row(const float* sparse, const float* hint, const float* previous, int width,
                    const DataTermRule& rule, float* data, float* b, float* low, float* high) {
  HWY_DYNAMIC_DISPATCH(DataTermsRow)(sparse, hint, previous, width, rule, data, b, low, high);
}

void diagonal_row(const float* data, const float* wx, const float* wy, const float* wy_above,
                  int width, float* diag, float* inv_diag) {
  HWY_DYNAMIC_DISPATCH(DiagonalRow)(data, wx, wy, wy_above, width, diag, inv_diag);
}

}  // namespace dco::kernels
#endif  // HWY_ONCE
