#pragma once

#include "dco/core/image.hpp"
#include "dco/kernels/densify_kernels.hpp"

namespace dco::densify {

// A symmetric positive definite system on the pixel grid with a 5-point stencil:
//   (A x)(p) = diag(p) x(p) - Σ_{q ∈ N4(p)} w(p,q) x(q),  diag(p) = data(p) + Σ_q w(p,q).
// It is the normal equation of Σ_p data(p) (x_p - t_p)^2 + Σ_edges w (x_p - x_q)^2, the form of
// Eq. 20. `wx(x, y)` couples (x, y) with (x+1, y) (last column unused), `wy(x, y)` couples
// (x, y) with (x, y+1) (last row unused).
struct GridSystem {
  Image<float> data, wx, wy, diag;
  Image<float> inv_diag;  // 1 / diag, 0 where diag is 0: smoothing multiplies instead of dividing
  // Whether diag and inv_diag hold the current diagonal. A system whose solver works it out from
  // data and the weights as it goes (SweepRows::load) skips the two full-size images.
  bool has_diagonal = false;

  // Leaves has_diagonal false.
  void resize(int width, int height);
  int width() const { return data.width(); }
  int height() const { return data.height(); }
  // Recomputes diag and inv_diag from data and the edge weights; sets has_diagonal.
  void update_diagonal() {
    update_diagonal_rows(0, height());
    has_diagonal = true;
  }
  // The same for rows [begin, end) (reads the wy row above each).
  void update_diagonal_rows(int begin, int end);
};

// Row r of `a` as the row kernels take it (the x rows left null).
kernels::GridRow grid_row(const GridSystem& a, int r);

// y = A x.
void apply(const GridSystem& a, ImageView<const float> x, ImageView<float> y);
// out = row r of A x (reads rows r - 1 .. r + 1 of x).
void apply_row(const GridSystem& a, ImageView<const float> x, int r, float* out);

// Dot product and squared norm in double precision (sums over up to millions of floats).
double dot(ImageView<const float> a, ImageView<const float> b);

// The passes below each do the work of two or three of the plain ones in one sweep over the
// rows, while the rows are still in cache; the arithmetic, and the order of every sum, is that
// of the plain passes, so the results are the same bits.

// y = A x; returns dot(x, y).
double apply_dot(const GridSystem& a, ImageView<const float> x, ImageView<float> y);

// r = b - A x.
void residual(const GridSystem& a, ImageView<const float> b, ImageView<const float> x,
              ImageView<float> r);
// r = b - A x; returns dot(r, r).
double residual_dot(const GridSystem& a, ImageView<const float> b, ImageView<const float> x,
                    ImageView<float> r);
// x += alpha p, then r = b - A x; returns dot(r, r).
double step_residual_dot(const GridSystem& a, ImageView<const float> b, float alpha,
                         ImageView<const float> p, ImageView<float> x, ImageView<float> r);
// out = row r of b - A x.
void residual_row(const GridSystem& a, ImageView<const float> b, ImageView<const float> x, int r,
                  float* out);

}  // namespace dco::densify
