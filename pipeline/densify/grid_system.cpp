#include "dco/pipeline/densify/grid_system.hpp"

#include <cassert>

#include "dco/kernels/densify_kernels.hpp"
#include "dco/kernels/densify_pixel.hpp"

namespace dco::densify {

void GridSystem::resize(int width, int height) {
  data.resize(width, height);
  wx.resize(width, height);
  wy.resize(width, height);
  diag.resize(width, height);
  inv_diag.resize(width, height);
  has_diagonal = false;
}

void GridSystem::update_diagonal_rows(int begin, int end) {
  const int w = width();
  const int h = height();
  for (int y = begin; y < end; ++y)
    kernels::diagonal_row(data.row(y), wx.row(y), y + 1 < h ? wy.row(y) : nullptr,
                          y > 0 ? wy.row(y - 1) : nullptr, w, diag.row(y), inv_diag.row(y));
}

kernels::GridRow grid_row(const GridSystem& a, int r) {
  kernels::GridRow row;
  row.width = a.width();
  row.diag = a.diag.row(r);
  row.inv_diag = a.inv_diag.row(r);
  row.wx = a.wx.row(r);
  if (r + 1 < a.height()) row.wy = a.wy.row(r);
  if (r > 0) row.wy_above = a.wy.row(r - 1);
  return row;
}

void apply_row(const GridSystem& a, ImageView<const float> x, int r, float* out) {
  kernels::GridRow row = grid_row(a, r);
  if (r + 1 < a.height()) row.x_below = x.row(r + 1);
  if (r > 0) row.x_above = x.row(r - 1);
  kernels::grid_apply_row(row, x.row(r), out);
}

void apply(const GridSystem& a, ImageView<const float> x, ImageView<float> y) {
  assert(x.same_size(a.width(), a.height()) && y.same_size(a.width(), a.height()));
  for (int r = 0; r < a.height(); ++r) apply_row(a, x, r, y.row(r));
}

double apply_dot(const GridSystem& a, ImageView<const float> x, ImageView<float> y) {
  const int h = a.height();
  assert(x.same_size(a.width(), h) && y.same_size(a.width(), h));
  double s = 0;
  for (int r = 0; r < h; ++r) {
    apply_row(a, x, r, y.row(r));
    s += kernels::dot_row(x.row(r), y.row(r), a.width());
  }
  return s;
}

void residual_row(const GridSystem& a, ImageView<const float> b, ImageView<const float> x, int r,
                  float* out) {
  apply_row(a, x, r, out);
  const float* br = b.row(r);
  for (int c = 0; c < a.width(); ++c) out[c] = br[c] - out[c];
}

void residual(const GridSystem& a, ImageView<const float> b, ImageView<const float> x,
              ImageView<float> r) {
  assert(x.same_size(a.width(), a.height()) && b.same_size(a.width(), a.height()) &&
         r.same_size(a.width(), a.height()));
  for (int y = 0; y < a.height(); ++y) residual_row(a, b, x, y, r.row(y));
}

double residual_dot(const GridSystem& a, ImageView<const float> b, ImageView<const float> x,
                    ImageView<float> r) {
  double s = 0;
  for (int y = 0; y < a.height(); ++y) {
    residual_row(a, b, x, y, r.row(y));
    s += kernels::dot_row(r.row(y), r.row(y), a.width());
  }
  return s;
}

double step_residual_dot(const GridSystem& a, ImageView<const float> b, float alpha,
                         ImageView<const float> p, ImageView<float> x, ImageView<float> r) {
  const int w = a.width();
  const int h = a.height();
  assert(p.same_size(w, h) && x.same_size(w, h) && r.same_size(w, h));
  const auto update = [&](int y) {
    const float* pr = p.row(y);
    float* xr = x.row(y);
    for (int c = 0; c < w; ++c) xr[c] += alpha * pr[c];
  };
  // Row y of the residual reads rows y - 1 .. y + 1 of the new x: the update runs a row ahead.
  double s = 0;
  if (h > 0) update(0);
  for (int y = 0; y < h; ++y) {
    if (y + 1 < h) update(y + 1);
    residual_row(a, b, x, y, r.row(y));
    s += kernels::dot_row(r.row(y), r.row(y), w);
  }
  return s;
}

double dot(ImageView<const float> a, ImageView<const float> b) {
  double s = 0;
  for (int y = 0; y < a.height; ++y) s += kernels::dot_row(a.row(y), b.row(y), a.width);
  return s;
}

}  // namespace dco::densify
