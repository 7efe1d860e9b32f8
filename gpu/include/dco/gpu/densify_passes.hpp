#pragma once

// The densify solver's operations on tightly packed grids as data-parallel passes (see
// stereo_passes.hpp): the 5-point operator, red-black Gauss-Seidel, the Galerkin coarsening and
// the transfers of 2x2 aggregation, vector updates and row dot products. The per-pixel math is
// dco::kernels::pixel (densify_pixel.hpp), shared with the CPU kernels; sums over the children
// of an aggregate run in the CPU's order, so every value equals the CPU's bit for bit.

#include "dco/gpu/stereo_passes.hpp"
#include "dco/kernels/densify_pixel.hpp"

namespace dco::gpu::passes {

// A GridSystem in device memory, rows of `width` floats.
struct SystemView {
  float *data, *wx, *wy, *diag, *inv_diag;
  int width, height;

  // Row y as the row kernels take it, with the rows of x around it.
  DCO_HD kernels::GridRow row(const float* x, int y) const {
    kernels::GridRow r;
    const std::size_t o = at(0, y, width);
    r.width = width;
    r.diag = diag + o;
    r.inv_diag = inv_diag + o;
    r.wx = wx + o;
    if (y + 1 < height) {
      r.wy = wy + o;
      r.x_below = x + o + width;
    }
    if (y > 0) {
      r.wy_above = wy + o - width;
      r.x_above = x + o - width;
    }
    return r;
  }
};

// out = A x.
struct Apply {
  SystemView a;
  const float* x;
  float* out;
  DCO_HD void operator()(int c, int y) const {
    out[at(c, y, a.width)] = px::apply_at(a.row(x, y), x + at(0, y, a.width), c);
  }
};

// One colour of a red-black Gauss-Seidel sweep: the pixels with c % 2 == (y + colour) % 2.
struct SmoothColour {
  SystemView a;
  const float* b;
  float* x;
  int colour;
  DCO_HD void operator()(int c, int y) const {
    if (c % 2 != (y + colour) % 2) return;
    const std::size_t o = at(0, y, a.width);
    x[o + c] = px::smooth_at(a.row(x, y), b + o, x + o, c);
  }
};

// Red-black sweeps as launch_steps steps: step s updates colour (first_colour + s) % 2.
struct SmoothColours {
  SystemView a;
  const float* b;
  float* x;
  int first_colour;
  DCO_HD void operator()(int c, int y, int step) const {
    SmoothColour{a, b, x, (first_colour + step) % 2}(c, y);
  }
};

// out = b - ax (out may be ax).
struct Residual {
  const float* b;
  const float* ax;
  float* out;
  int width;
  DCO_HD void operator()(int c, int y) const {
    out[at(c, y, width)] = b[at(c, y, width)] - ax[at(c, y, width)];
  }
};

// y += alpha x.
struct Axpy {
  float alpha;
  const float* x;
  float* y;
  int width;
  DCO_HD void operator()(int c, int r) const { y[at(c, r, width)] += alpha * x[at(c, r, width)]; }
};

// p = z + beta p.
struct UpdateDirection {
  const float* z;
  float beta;
  float* p;
  int width;
  DCO_HD void operator()(int c, int r) const {
    p[at(c, r, width)] = z[at(c, r, width)] + beta * p[at(c, r, width)];
  }
};

struct Copy {
  const float* in;
  float* out;
  int width;
  DCO_HD void operator()(int c, int r) const { out[at(c, r, width)] = in[at(c, r, width)]; }
};

// One grid point per row: that row's dot product as kernels::dot_row computes it.
struct RowDots {
  const float* a;
  const float* b;
  double* out;
  int width;
  DCO_HD void operator()(int, int y) const {
    out[y] = px::dot_row(a + at(0, y, width), b + at(0, y, width), width);
  }
};

// The Galerkin coarse system of 2x2 aggregation (densify::coarsen), one grid point per coarse
// pixel, summing the children in the order the CPU visits them.
struct Coarsen {
  SystemView fine, coarse;
  float edge_scale = 1.0f;
  DCO_HD void operator()(int cx, int cy) const {
    const int w = fine.width, h = fine.height;
    float d = 0.0f, ex = 0.0f, ey = 0.0f;
    for (int y = 2 * cy; y < 2 * cy + 2 && y < h; ++y)
      for (int x = 2 * cx; x < 2 * cx + 2 && x < w; ++x) {
        d += fine.data[at(x, y, w)];
        if (x % 2 == 1 && x + 1 < w) ex += fine.wx[at(x, y, w)];
        if (y % 2 == 1 && y + 1 < h) ey += fine.wy[at(x, y, w)];
      }
    const std::size_t o = at(cx, cy, coarse.width);
    coarse.data[o] = d;
    coarse.wx[o] = ex * edge_scale;
    coarse.wy[o] = ey * edge_scale;
  }
};

// diag and inv_diag from data and the edges (GridSystem::update_diagonal).
struct Diagonal {
  SystemView a;
  DCO_HD void operator()(int c, int y) const {
    const std::size_t o = at(0, y, a.width);
    const float g =
        px::diagonal(a.data[o + c], a.wx + o, a.wy + o, y > 0 ? a.wy + o - a.width : nullptr, c,
                     a.width, y + 1 < a.height);
    a.diag[o + c] = g;
    a.inv_diag[o + c] = px::inverse_diagonal(g);
  }
};

// coarse = the sum (or, with `mean`, the mean) of each aggregate's children.
struct Restrict {
  const float* fine;
  int fine_width, fine_height;
  float* coarse;
  int coarse_width;
  bool mean;
  DCO_HD void operator()(int cx, int cy) const {
    float s = 0.0f;
    const int rows = px::min_of(2, fine_height - 2 * cy), cols = px::min_of(2, fine_width - 2 * cx);
    for (int y = 2 * cy; y < 2 * cy + rows; ++y)
      for (int x = 2 * cx; x < 2 * cx + cols; ++x) s += fine[at(x, y, fine_width)];
    if (mean) s /= static_cast<float>(rows * cols);
    coarse[at(cx, cy, coarse_width)] = s;
  }
};

// fine = (or, with `add`, fine +=) the value of each pixel's aggregate.
struct Prolong {
  const float* coarse;
  int coarse_width;
  float* fine;
  int fine_width;
  bool add;
  DCO_HD void operator()(int x, int y) const {
    const float c = coarse[at(x / 2, y / 2, coarse_width)];
    float& f = fine[at(x, y, fine_width)];
    f = add ? f + c : c;
  }
};

struct FillZero {
  float* out;
  int width;
  DCO_HD void operator()(int c, int r) const { out[at(c, r, width)] = 0.0f; }
};

}  // namespace dco::gpu::passes
