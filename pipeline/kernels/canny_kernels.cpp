// SIMD versions of the Canny row classification and gate, compiled once per Highway target and
// dispatched at run time. All four comparison pairs are loaded and the direction selects one per
// lane, so textured images cost no mispredicted branches; the tails go to the scalar ranges.

#include <cstdint>

#include "canny_ranges.hpp"
#include "dco/kernels/canny_kernels.hpp"
#include "vector_cover.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "canny_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dco::kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void CannyClassifyRow(const CannyRow& r, const CannyLevels& t, std::uint8_t* out) {
  const int w = r.width;
  if (w <= 0) return;
  out[0] = kCannyNone;
  if (w == 1) return;
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const hn::Rebind<std::uint8_t, decltype(di)> du8;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto low = hn::Set(d, t.low);
  const auto high = hn::Set(d, t.high);
  const auto depth = hn::Set(d, t.depth);
  const auto weak = hn::Set(di, kCannyWeak);
  const auto strong = hn::Set(di, kCannyStrong);
  const auto classify = [&](int x) {
    const auto v = hn::LoadU(d, r.row + x);
    const auto dir = hn::PromoteTo(di, hn::LoadU(du8, r.direction + x));
    const auto horizontal = hn::RebindMask(d, hn::Eq(dir, hn::Set(di, 0)));
    const auto diagonal_down = hn::RebindMask(d, hn::Eq(dir, hn::Set(di, 1)));
    const auto vertical = hn::RebindMask(d, hn::Eq(dir, hn::Set(di, 2)));
    const auto before = hn::IfThenElse(
        horizontal, hn::LoadU(d, r.row + x - 1),
        hn::IfThenElse(
            diagonal_down, hn::LoadU(d, r.above + x - 1),
            hn::IfThenElse(vertical, hn::LoadU(d, r.above + x), hn::LoadU(d, r.below + x - 1))));
    const auto after = hn::IfThenElse(
        horizontal, hn::LoadU(d, r.row + x + 1),
        hn::IfThenElse(
            diagonal_down, hn::LoadU(d, r.below + x + 1),
            hn::IfThenElse(vertical, hn::LoadU(d, r.below + x), hn::LoadU(d, r.above + x + 1))));
    auto keep = hn::And(hn::Ge(v, low), hn::And(hn::Gt(v, before), hn::Ge(v, after)));
    if (r.gate != nullptr) keep = hn::And(keep, hn::Ge(hn::LoadU(d, r.gate + x), depth));
    const auto cls = hn::IfThenElse(hn::RebindMask(di, hn::Gt(v, high)), strong, weak);
    const auto result = hn::IfThenElseZero(hn::RebindMask(di, keep), cls);
    hn::StoreU(hn::DemoteTo(du8, result), du8, out + x);
  };
  const int done = detail::cover_with_vectors(1, w - 1, n, classify);  // out is not an input
  detail::canny_classify_range(r, t, done, w - 1, out);
  out[w - 1] = kCannyNone;
}

void CannyGateRow(const std::uint8_t* classes, const float* gate, float depth, int width,
                  std::uint8_t* out) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const hn::Rebind<std::uint8_t, decltype(di)> du8;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto limit = hn::Set(d, depth);
  int x = 0;
  // Each vector reads its lanes before it stores them, so out may be classes.
  for (; x + n <= width; x += n) {
    const auto cls = hn::PromoteTo(di, hn::LoadU(du8, classes + x));
    const auto closed = hn::RebindMask(di, hn::Lt(hn::LoadU(d, gate + x), limit));
    hn::StoreU(hn::DemoteTo(du8, hn::IfThenZeroElse(closed, cls)), du8, out + x);
  }
  detail::canny_gate_range(classes, gate, depth, x, width, out);
}

}  // namespace HWY_NAMESPACE
}  // namespace dco::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dco::kernels {

HWY_EXPORT(CannyClassifyRow);
HWY_EXPORT(CannyGateRow);

void canny_classify_row(const CannyRow& row, const CannyLevels& levels, std::uint8_t* out) {
  HWY_DYNAMIC_DISPATCH(CannyClassifyRow)(row, levels, out);
}

void canny_gate_row(const std::uint8_t* classes, const float* gate, float depth, int width,
                    std::uint8_t* out) {
  HWY_DYNAMIC_DISPATCH(CannyGateRow)(classes, gate, depth, width, out);
}

}  // namespace dco::kernels
#endif  // HWY_ONCE
