// SIMD kernels of the boundary refinement, compiled once per Highway target and dispatched at run
// time: the side costs (windows that the vectors cannot take go to pixel::side_cost) and the
// sides around each internal pixel (boundary_ranges.hpp holds their scalar rule).

#include <cstddef>
#include <cstdint>

#include "boundary_ranges.hpp"
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

// The scalar rule's selects (not hn::Min / hn::Max, whose NaN and signed-zero rules differ
// between targets), a vector of columns at a time.
void BoundaryColumnSides(const float* const* rows, int count, int width, float* HWY_RESTRICT far,
                         float* HWY_RESTRICT near) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto none = hn::Set(d, pixel::infinity());
  const auto no_near = hn::Set(d, -pixel::infinity());
  int x = 0;
  for (; x + n <= width; x += n) {
    auto lo = none, hi = no_near;
    for (int k = 0; k < count; ++k) {
      const auto v = hn::LoadU(d, rows[k] + x);
      // v < lo implies v < +inf; v > hi does not.
      lo = hn::IfThenElse(hn::Lt(v, lo), v, lo);
      hi = hn::IfThenElse(hn::And(hn::Gt(v, hi), hn::Lt(v, none)), v, hi);
    }
    hn::StoreU(lo, d, far + x);
    hn::StoreU(hi, d, near + x);
  }
  detail::boundary_column_sides_range(rows, count, x, width, far, near);
}

void BoundaryRowSides(const float* lo, const float* hi, int width, int reach, int narrow_reach,
                      float* HWY_RESTRICT far, float* HWY_RESTRICT near,
                      float* HWY_RESTRICT narrow_far, float* HWY_RESTRICT narrow_near) {
  const hn::ScalableTag<float> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int inner = narrow_far != nullptr ? narrow_reach : reach;
  int x = 0;
  for (; x + n <= width; x += n) {
    auto f = hn::LoadU(d, lo + x - inner), g = hn::LoadU(d, hi + x - inner);
    const auto fold = [&](int o) {
      const auto b = hn::LoadU(d, lo + x + o), c = hn::LoadU(d, hi + x + o);
      f = hn::IfThenElse(hn::Lt(b, f), b, f);
      g = hn::IfThenElse(hn::Gt(c, g), c, g);
    };
    for (int o = -inner + 1; o <= inner; ++o) fold(o);
    if (narrow_far != nullptr) {
      hn::StoreU(f, d, narrow_far + x);
      hn::StoreU(g, d, narrow_near + x);
      for (int o = -reach; o < -inner; ++o) fold(o);
      for (int o = inner + 1; o <= reach; ++o) fold(o);
    }
    hn::StoreU(f, d, far + x);
    hn::StoreU(g, d, near + x);
  }
  detail::boundary_row_sides_range(lo, hi, reach, narrow_reach, x, width, far, near, narrow_far,
                                   narrow_near);
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
HWY_EXPORT(BoundaryColumnSides);
HWY_EXPORT(BoundaryRowSides);

void boundary_column_sides(const float* const* rows, int count, int width, float* far,
                           float* near) {
  HWY_DYNAMIC_DISPATCH(BoundaryColumnSides)(rows, count, width, far, near);
}

void boundary_row_sides(const float* lo, const float* hi, int width, int reach, int narrow_reach,
                        float* far, float* near, float* narrow_far, float* narrow_near) {
  HWY_DYNAMIC_DISPATCH(BoundaryRowSides)
  (lo, hi, width, reach, narrow_reach, far, near, narrow_far, narrow_near);
}

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
