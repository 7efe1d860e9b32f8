// SIMD versions of the photometric refinement's row kernels, compiled once per Highway target and
// dispatched at run time. The interior columns go by whole vectors; the clamped borders and the
// tails go to the scalar range functions, so the results equal dco::kernels::scalar bit for bit
// (the file is built without floating-point contraction).

#include <algorithm>
#include <cstdint>

#include "dco/kernels/photometric_kernels.hpp"
#include "photometric_ranges.hpp"
#include "vector_cover.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "photometric_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dco::kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void DerivativeRow(const std::uint8_t* const rows[5], int width, const DerivativeRows& out) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const hn::Rebind<std::uint8_t, decltype(df)> du8;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto at = [&](int row, int x) {
    return hn::ConvertTo(df, hn::PromoteTo(di, hn::LoadU(du8, rows[row] + x)));
  };
  const auto half = hn::Set(df, 0.5f), quarter = hn::Set(df, 0.25f), two = hn::Set(df, 2.0f);
  // Columns whose taps all lie inside the row.
  const int begin = width < 4 ? width : 2;
  const int end = width < 4 ? width : width - 2;
  detail::derivative_range(rows, width, 0, begin, out);
  const auto vector = [&](int x) {
    const auto v = at(2, x);
    hn::StoreU(v, df, out.v + x);
    hn::StoreU(hn::Mul(half, hn::Sub(at(2, x + 1), at(2, x - 1))), df, out.x + x);
    hn::StoreU(hn::Mul(half, hn::Sub(at(3, x), at(1, x))), df, out.y + x);
    hn::StoreU(hn::Mul(quarter, hn::Add(hn::Sub(at(2, x + 2), hn::Mul(two, v)), at(2, x - 2))), df,
               out.xx + x);
    const auto xy =
        hn::Add(hn::Sub(hn::Sub(at(3, x + 1), at(1, x + 1)), at(3, x - 1)), at(1, x - 1));
    hn::StoreU(hn::Mul(quarter, xy), df, out.xy + x);
    hn::StoreU(hn::Mul(quarter, hn::Add(hn::Sub(at(4, x), hn::Mul(two, v)), at(0, x))), df,
               out.yy + x);
  };
  const int done = detail::cover_with_vectors(begin, end, n, vector);  // outputs are not inputs
  detail::derivative_range(rows, width, done, width, out);
}

void PhotometricTermsRow(const PhotometricTermRows& in, const pixel::PhotometricWeights& w,
                         float* a, float* rhs, float* smooth) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const int n = static_cast<int>(hn::Lanes(df));
  const int width = in.width;
  const auto half = hn::Set(df, 0.5f);
  const auto zeta = hn::Set(df, pixel::kPhotometricZetaSquared);
  const auto eps = hn::Set(df, pixel::kPhotometricEpsSquared);
  const auto tiny = hn::Set(df, pixel::kPhotometricTiny);
  const auto one = hn::Set(df, 1.0f);
  const auto delta = hn::Set(df, w.delta), gamma = hn::Set(df, w.gamma),
             alpha = hn::Set(df, w.alpha);
  const auto zero_i = hn::Zero(di), last_i = hn::Set(di, width - 1), one_i = hn::Set(di, 1);
  const auto lanes = hn::Iota(di, 0);
  // Columns whose row neighbours lie inside the row (the sampled columns are clamped anyway).
  const int begin = width < 3 ? width : 1;
  const int end = width < 3 ? width : width - 1;
  detail::photometric_terms_range(in, w, 0, begin, a, rhs, smooth);
  const auto vector = [&](int x) {
    const auto d = hn::LoadU(df, in.d + x);
    const auto column = hn::Add(lanes, hn::Set(di, x));
    const auto xs = hn::Sub(hn::ConvertTo(df, column), d);
    const auto floor = hn::Floor(xs);
    const auto t = hn::Sub(xs, floor);
    const auto j = hn::ConvertTo(di, floor);
    const auto j0 = hn::Min(hn::Max(j, zero_i), last_i);
    const auto j1 = hn::Min(hn::Max(hn::Add(j, one_i), zero_i), last_i);
    // Where the vector's columns j lie within one of each other and inside the row (a smooth
    // map, most of the image), three loads and two selects per row instead of two gathers.
    const auto shift = hn::Sub(j, column);
    const int low = hn::GetLane(hn::MinOfLanes(di, shift));
    const int high = hn::GetLane(hn::MaxOfLanes(di, shift));
    const bool contiguous = high - low <= 1 && x + low >= 0 && x + low + n + 1 <= width - 1;
    const auto at_low = hn::RebindMask(df, hn::Eq(shift, hn::Set(di, low)));
    const auto sample = [&](int k) {
      if (contiguous) {
        const float* base = in.right[k] + x + low;
        const auto l0 = hn::LoadU(df, base), l1 = hn::LoadU(df, base + 1);
        const auto l2 = hn::LoadU(df, base + 2);
        const auto p = hn::IfThenElse(at_low, l0, l1), q = hn::IfThenElse(at_low, l1, l2);
        return hn::Add(p, hn::Mul(t, hn::Sub(q, p)));
      }
      const auto p = hn::GatherIndex(df, in.right[k], j0);
      const auto q = hn::GatherIndex(df, in.right[k], j1);
      return hn::Add(p, hn::Mul(t, hn::Sub(q, p)));
    };
    const auto left = [&](int k) { return hn::LoadU(df, in.left[k] + x); };
    const auto rv = sample(0), rx = sample(1), ry = sample(2);
    const auto rxx = sample(3), rxy = sample(4), ryy = sample(5);
    const auto lv = left(0), lx = left(1), ly = left(2), lxx = left(3), lxy = left(4),
               lyy = left(5);
    // pixel::photometric_data_term, operation for operation.
    const auto ix = hn::Mul(half, hn::Add(lx, rx)), iy = hn::Mul(half, hn::Add(ly, ry));
    const auto ixx = hn::Mul(half, hn::Add(lxx, rxx)), ixy = hn::Mul(half, hn::Add(lxy, rxy));
    const auto iyy = hn::Mul(half, hn::Add(lyy, ryy));
    const auto e = hn::Sub(rv, lv), ex = hn::Sub(rx, lx), ey = hn::Sub(ry, ly);
    const auto sq = [](auto v) { return hn::Mul(v, v); };
    const auto dc = hn::Add(hn::Add(sq(ix), sq(iy)), zeta);
    const auto dx = hn::Add(hn::Add(sq(ixx), sq(ixy)), zeta);
    const auto dy = hn::Add(hn::Add(sq(ixy), sq(iyy)), zeta);
    const auto robust = [&](auto dn, auto residual) {
      return hn::Sqrt(hn::Add(hn::Mul(dn, sq(residual)), hn::Mul(hn::Mul(dn, dn), eps)));
    };
    const auto qc = robust(dc, e), qx = robust(dx, ex), qy = robust(dy, ey);
    const auto mc = hn::Mul(delta, hn::Mul(qx, qy));
    const auto mx = hn::Mul(gamma, hn::Mul(qc, qy));
    const auto my = hn::Mul(gamma, hn::Mul(qc, qx));
    const auto inverse = hn::Div(one, hn::Mul(qc, hn::Mul(qx, qy)));
    const auto coeff = hn::Mul(
        hn::Add(hn::Add(hn::Mul(mc, sq(ix)), hn::Mul(mx, sq(ixx))), hn::Mul(my, sq(ixy))), inverse);
    const auto pull =
        hn::Mul(hn::Add(hn::Add(hn::Mul(mc, hn::Mul(ix, e)), hn::Mul(mx, hn::Mul(ixx, ex))),
                        hn::Mul(my, hn::Mul(ixy, ey))),
                inverse);
    hn::StoreU(coeff, df, a + x);
    hn::StoreU(hn::Add(hn::Mul(hn::Add(coeff, tiny), d), pull), df, rhs + x);
    // pixel::photometric_smoothness.
    const auto gx =
        hn::Mul(half, hn::Sub(hn::LoadU(df, in.d + x + 1), hn::LoadU(df, in.d + x - 1)));
    const auto gy =
        hn::Mul(half, hn::Sub(hn::LoadU(df, in.d_down + x), hn::LoadU(df, in.d_up + x)));
    hn::StoreU(hn::Div(alpha, hn::Sqrt(hn::Add(hn::Add(sq(gx), sq(gy)), eps))), df, smooth + x);
  };
  const int done = detail::cover_with_vectors(begin, end, n, vector);  // outputs are not inputs
  detail::photometric_terms_range(in, w, done, width, a, rhs, smooth);
}

void PhotometricCouplingsRow(const CouplingRow& row, float* wx, float* wy,
                             float* inverse_diagonal) {
  const hn::ScalableTag<float> df;
  const int n = static_cast<int>(hn::Lanes(df));
  const int width = row.width;
  const int begin = width < 3 ? width : 1;
  const int end = width < 3 ? width : width - 1;
  detail::photometric_couplings_range(row, 0, begin, wx, wy, inverse_diagonal);
  const auto half = hn::Set(df, 0.5f), tiny = hn::Set(df, pixel::kPhotometricTiny);
  const auto one = hn::Set(df, 1.0f);
  detail::with_rows_next_to(row.s_down != nullptr, row.wy_up != nullptr, [&](auto down, auto up) {
    const auto vector = [&](int x) {
      const auto s = hn::LoadU(df, row.s + x);
      const auto w_left = hn::Mul(half, hn::Add(hn::LoadU(df, row.s + x - 1), s));
      const auto w_right = hn::Mul(half, hn::Add(s, hn::LoadU(df, row.s + x + 1)));
      const auto w_down = decltype(down)::value
                              ? hn::Mul(half, hn::Add(s, hn::LoadU(df, row.s_down + x)))
                              : hn::Zero(df);
      const auto w_up = decltype(up)::value ? hn::LoadU(df, row.wy_up + x) : hn::Zero(df);
      hn::StoreU(w_right, df, wx + x);
      hn::StoreU(w_down, df, wy + x);
      const auto a = hn::Add(hn::LoadU(df, row.a + x), tiny);
      const auto diagonal = hn::Add(hn::Add(hn::Add(hn::Add(a, w_left), w_right), w_up), w_down);
      hn::StoreU(hn::Div(one, diagonal), df, inverse_diagonal + x);
    };
    const int done = detail::cover_with_vectors(begin, end, n, vector);  // outputs not inputs
    detail::photometric_couplings_range(row, done, width, wx, wy, inverse_diagonal);
  });
}

template <bool kUp, bool kDown>
void SorInterior(const SorRow& row, int first, float omega, const float* old, float* d) {
  const hn::ScalableTag<float> df;
  const hn::RebindToSigned<decltype(df)> di;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto om = hn::Set(df, omega);
  // Which lanes are of this colour, for a vector that starts on an even and on an odd column.
  const auto odd_lane = hn::And(hn::Iota(di, 0), hn::Set(di, 1));
  const auto mine_from_even = hn::RebindMask(df, hn::Eq(odd_lane, hn::Set(di, first)));
  const auto mine_from_odd = hn::RebindMask(df, hn::Eq(odd_lane, hn::Set(di, 1 - first)));
  // The neighbours come from `old`, the row before this half-sweep: a pixel of this colour reads
  // only the other colour, which the half-sweep leaves as it is, so `old` holds the same values
  // as d, and the stores into d never feed a load.
  const auto vector = [&](int x) {
    const auto dc = hn::LoadU(df, old + x);
    auto num = hn::Add(hn::LoadU(df, row.rhs + x),
                       hn::Mul(hn::LoadU(df, row.wx + x - 1), hn::LoadU(df, old + x - 1)));
    num = hn::Add(num, hn::Mul(hn::LoadU(df, row.wx + x), hn::LoadU(df, old + x + 1)));
    if constexpr (kUp)
      num = hn::Add(num, hn::Mul(hn::LoadU(df, row.wy_up + x), hn::LoadU(df, row.d_up + x)));
    else
      num = hn::Add(num, hn::Mul(hn::Zero(df), hn::Zero(df)));
    if constexpr (kDown)
      num = hn::Add(num, hn::Mul(hn::LoadU(df, row.wy + x), hn::LoadU(df, row.d_down + x)));
    else
      num = hn::Add(num, hn::Mul(hn::LoadU(df, row.wy + x), hn::Zero(df)));
    const auto v = hn::Mul(num, hn::LoadU(df, row.inverse_diagonal + x));
    const auto stepped = hn::Add(dc, hn::Mul(om, hn::Sub(v, dc)));
    hn::StoreU(hn::IfThenElse((x & 1) ? mine_from_odd : mine_from_even, stepped, dc), df, d + x);
  };
  // A pixel done twice gets the same bits: every input is in `old` or the row's terms.
  detail::cover_with_vectors(1, row.width - 1, n, vector);
}

void SorColourRow(const SorRow& row, int first, float omega, float* d, float* scratch) {
  const hn::ScalableTag<float> df;
  const int n = static_cast<int>(hn::Lanes(df));
  const int width = row.width;
  if (width - 2 < n) {
    detail::sor_range(row, first, width, omega, d);
    return;
  }
  std::copy(d, d + width, scratch);
  detail::with_rows_next_to(row.d_down != nullptr, row.d_up != nullptr, [&](auto down, auto up) {
    SorInterior<decltype(up)::value, decltype(down)::value>(row, first, omega, scratch, d);
  });
  detail::sor_range(row, first, 1, omega, d);  // column 0 when it is of this colour
  const int last = width - 1;
  if ((last & 1) == first) detail::sor_range(row, last, width, omega, d);
}

}  // namespace HWY_NAMESPACE
}  // namespace dco::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dco::kernels {

HWY_EXPORT(DerivativeRow);
HWY_EXPORT(PhotometricTermsRow);
HWY_EXPORT(PhotometricCouplingsRow);
HWY_EXPORT(SorColourRow);

void derivative_row(const std::uint8_t* const rows[5], int width, const DerivativeRows& out) {
  HWY_DYNAMIC_DISPATCH(DerivativeRow)(rows, width, out);
}

void photometric_terms_row(const PhotometricTermRows& in, const pixel::PhotometricWeights& w,
                           float* a, float* rhs, float* smooth) {
  HWY_DYNAMIC_DISPATCH(PhotometricTermsRow)(in, w, a, rhs, smooth);
}

void photometric_couplings_row(const CouplingRow& row, float* wx, float* wy,
                               float* inverse_diagonal) {
  HWY_DYNAMIC_DISPATCH(PhotometricCouplingsRow)(row, wx, wy, inverse_diagonal);
}

void sor_row(const SorRow& row, int first, float omega, float* d, float* scratch) {
  HWY_DYNAMIC_DISPATCH(SorColourRow)(row, first, omega, d, scratch);
}

}  // namespace dco::kernels
#endif  // HWY_ONCE
