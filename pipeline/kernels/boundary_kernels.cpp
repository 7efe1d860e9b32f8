// SIMD side costs of the boundary refinement, compiled once per Highway target and dispatched at
// run time; windows that the vectors cannot take go to pixel::side_cost.

#include <cstddef>
#include <cstdint>

#include "dco/kernels/boundary_kernels.hpp"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "boundary_kernels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace dco::kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

std::uint32_t BoundarySideCost(const pixel::GreyPair& im, const BoundaryWindow& window, int d,
                               const pixel::BoundaryRule& rule) {
  const int left_end = window.x - window.radius;
  if (!window.vector || d < 0 || left_end - d < 0)
    return pixel::side_cost(im, window.x, window.y, d, rule);
  const hn::FixedTag<std::uint8_t, BoundaryWindow::kLanes> d8;
  const hn::FixedTag<std::uint16_t, BoundaryWindow::kLanes> d16;
  const hn::FixedTag<std::uint32_t, BoundaryWindow::kLanes / 2> d32;
  const auto cap = hn::Set(d8, static_cast<std::uint8_t>(pixel::kBoundaryCap));
  auto sum = hn::Zero(d32);
  for (int r = 0; r <= 2 * window.radius; ++r) {
    const std::ptrdiff_t qy = window.y - window.radius + r;
    const auto l = hn::LoadU(d8, im.left + qy * im.left_stride + left_end);
    const auto m = hn::LoadU(d8, im.right + qy * im.right_stride + left_end - d);
    const auto e = hn::PromoteTo(d16, hn::Min(hn::Sub(hn::Max(l, m), hn::Min(l, m)), cap));
    // A weight is at most kBoundaryWeightOne and a difference at most kBoundaryCap: the
    // product fits 16 bits.
    const auto product = hn::Mul(e, hn::Load(d16, window.weight[r]));
    sum = hn::Add(sum,
                  hn::Add(hn::PromoteTo(d32, hn::LowerHalf(product)),
                          hn::PromoteTo(d32, hn::UpperHalf(hn::Half<decltype(d16)>(), product))));
  }
  return hn::GetLane(hn::SumOfLanes(d32, sum));
}

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace dco::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace dco::kernels {

static_assert(pixel::kBoundaryWeightOne * pixel::kBoundaryCap < 65536,
              "weighted differences must fit 16-bit lanes");

HWY_EXPORT(BoundarySideCost);

void boundary_window(const pixel::GreyPair& im, int x, int y, const pixel::BoundaryRule& rule,
                     BoundaryWindow& window) {
  window.x = x;
  window.y = y;
  window.radius = rule.radius;
  window.vector = rule.radius <= BoundaryWindow::kMaxRadius && x - rule.radius >= 0 &&
                  x - rule.radius + BoundaryWindow::kLanes <= im.width && y - rule.radius >= 0 &&
                  y + rule.radius < im.height;
  if (!window.vector) return;
  const int centre = im.left[y * im.left_stride + x];
  for (int r = 0; r <= 2 * rule.radius; ++r) {
    const std::uint8_t* l = im.left + (y - rule.radius + r) * im.left_stride + x - rule.radius;
    for (int i = 0; i < BoundaryWindow::kLanes; ++i)
      window.weight[r][i] =
          i <= 2 * rule.radius ? rule.weight[pixel::abs_of(int(l[i]) - centre)] : 0;
  }
}

std::uint32_t boundary_side_cost(const pixel::GreyPair& im, const BoundaryWindow& window, int d,
                                 const pixel::BoundaryRule& rule) {
  return HWY_DYNAMIC_DISPATCH(BoundarySideCost)(im, window, d, rule);
}

}  // namespace dco::kernels
#endif  // HWY_ONCE
