#pragma once

// Row kernels of the densify solver: the 5-point system of dco::densify::GridSystem. Every
// function in dco::kernels dispatches at run time to the best SIMD target (see
// stereo_kernels.hpp); the functions of the same name in dco::kernels::scalar are the plain
// references. The vector versions do the same float operations in the same order (no fused
// multiply-add), so their results are bit-identical to the references.

namespace dco::kernels {

// One row y of a system (A x)(p) = diag(p) x(p) - Σ_{q ∈ N4(p)} w(p,q) x(q).
struct GridRow {
  int width = 0;
  const float* diag = nullptr;      // used by grid_apply_row
  const float* inv_diag = nullptr;  // 1 / diag, 0 where diag is 0; used by grid_smooth_row
  const float* wx = nullptr;        // wx[c] couples (c, y) and (c + 1, y)
  // The row below and its couplings wy[c] of (c, y) with (c, y + 1); both null on the last row.
  const float* wy = nullptr;
  const float* x_below = nullptr;
  // The row above and the couplings of (c, y - 1) with (c, y); both null on the first row.
  const float* wy_above = nullptr;
  const float* x_above = nullptr;
};

// Gauss-Seidel update of the pixels of one colour of row y, columns start, start + 2, ...
// (start 0 or 1): x[c] = (b[c] + Σ w x(neighbour)) * inv_diag[c]. The pixels of the other
// colour, which the updates read, are left as they are.
void grid_smooth_row(const GridRow& row, int start, const float* b, float* x);

// out = (A x) of row y; x is row y of the same vector as row.x_above and row.x_below.
void grid_apply_row(const GridRow& row, const float* x, float* out);

// Σ a[i] b[i] over n values: sixteen float partial sums (lane i % 16), plus the last n % 16
// products in double, all added up in double.
double dot_row(const float* a, const float* b, int n);

namespace scalar {
void grid_smooth_row(const GridRow& row, int start, const float* b, float* x);
void grid_apply_row(const GridRow& row, const float* x, float* out);
double dot_row(const float* a, const float* b, int n);
}  // namespace scalar

}  // namespace dco::kernels
