#include "dco/pipeline/densify/grid_system.hpp"

#include <cassert>

namespace dco::densify {

void GridSystem::resize(int width, int height) {
  data.resize(width, height);
  wx.resize(width, height);
  wy.resize(width, height);
  diag.resize(width, height);
}

void GridSystem::update_diagonal() {
  const int w = width();
  const int h = height();
  for (int y = 0; y < h; ++y) {
    const float* d = data.row(y);
    const float* ex = wx.row(y);
    const float* ey = wy.row(y);
    const float* ey_above = y > 0 ? wy.row(y - 1) : nullptr;
    float* g = diag.row(y);
    for (int x = 0; x < w; ++x) {
      float s = d[x];
      if (x + 1 < w) s += ex[x];
      if (x > 0) s += ex[x - 1];
      if (y + 1 < h) s += ey[x];
      if (ey_above) s += ey_above[x];
      g[x] = s;
    }
  }
}

void apply(const GridSystem& a, ImageView<const float> x, ImageView<float> y) {
  const int w = a.width();
  const int h = a.height();
  assert(x.same_size(w, h) && y.same_size(w, h));
  for (int r = 0; r < h; ++r) {
    const float* xr = x.row(r);
    const float* xu = r > 0 ? x.row(r - 1) : nullptr;
    const float* xd = r + 1 < h ? x.row(r + 1) : nullptr;
    const float* g = a.diag.row(r);
    const float* ex = a.wx.row(r);
    const float* ey = a.wy.row(r);
    const float* eu = r > 0 ? a.wy.row(r - 1) : nullptr;
    float* out = y.row(r);
    for (int c = 0; c < w; ++c) {
      float v = g[c] * xr[c];
      if (c + 1 < w) v -= ex[c] * xr[c + 1];
      if (c > 0) v -= ex[c - 1] * xr[c - 1];
      if (xd) v -= ey[c] * xd[c];
      if (xu) v -= eu[c] * xu[c];
      out[c] = v;
    }
  }
}

double dot(ImageView<const float> a, ImageView<const float> b) {
  double s = 0;
  for (int y = 0; y < a.height; ++y) {
    const float* ra = a.row(y);
    const float* rb = b.row(y);
    double row = 0;
    for (int x = 0; x < a.width; ++x) row += static_cast<double>(ra[x]) * rb[x];
    s += row;
  }
  return s;
}

}  // namespace dco::densify
