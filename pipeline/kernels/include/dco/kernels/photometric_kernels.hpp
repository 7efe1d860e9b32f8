#pragma once

// Row kernels of the densifier's photometric refinement (dco/pipeline/densify/
// photometric_refiner.hpp). Dispatched at run time like the other kernels; dco::kernels::scalar
// holds the references, whose per-pixel math is kernels::pixel's (photometric_pixel.hpp). The
// vector versions do the same float operations in the same order, no fused multiply-add, so all
// of them give the same bits.

#include <cstdint>

#include "dco/kernels/photometric_pixel.hpp"

namespace dco::kernels {

// The grey level and derivatives of one image row: out.v[x] ... out.yy[x] =
// pixel::derivatives_at(rows, ...) with the columns x - 2 .. x + 2 clamped to the row, from rows
// y - 2 .. y + 2 (clamped by the caller).
struct DerivativeRows {
  float* v;
  float* x;
  float* y;
  float* xx;
  float* xy;
  float* yy;
};
void derivative_row(const std::uint8_t* const rows[5], int width, const DerivativeRows& out);

// One row's linearised data terms and smoothness weights:
//   a[x], rhs[x] = pixel::photometric_data_term(left at x, right at x - d[x], d[x]), the right
//     image's derivatives interpolated linearly between the columns floor(x - d[x]) and the one
//     after, each clamped to the row;
//   smooth[x] = pixel::photometric_smoothness of d's row neighbours (clamped) and of d_up[x],
//     d_down[x] (the caller's rows above and below, the row itself at the image's edges).
struct PhotometricTermRows {
  const float* left[6];   // the left image's DerivativeRows at this row: v, x, y, xx, xy, yy
  const float* right[6];  // the right image's
  const float* d;
  const float* d_up;
  const float* d_down;
  int width;
};
void photometric_terms_row(const PhotometricTermRows& in, const pixel::PhotometricWeights& w,
                           float* a, float* rhs, float* smooth);

// The couplings of one row from the smoothness weights of it (s) and of the row below (s_down,
// null for the last row): wx[x] = pixel::photometric_edge(s[x], s[x + 1]) (0 for the last column),
// wy[x] = pixel::photometric_edge(s[x], s_down[x]) (0 for the last row), and
// inverse_diagonal[x] = pixel::photometric_inverse_diagonal(a[x], wx[x - 1], wx[x], wy_up[x],
// wy[x]) with the row above's wy (wy_up, null for the first row; 0 outside the image).
struct CouplingRow {
  const float* a;
  const float* s;
  const float* s_down;
  const float* wy_up;
  int width;
};
void photometric_couplings_row(const CouplingRow& row, float* wx, float* wy,
                               float* inverse_diagonal);

// One colour of a red-black SOR sweep on one row: d[x] = pixel::sor_step(...) for every x with
// x % 2 == first, from the couplings of photometric_couplings_row (wy_up the row above's, null
// for the first row, with d_up; wy 0 and d_down null for the last row). The other colour, which
// the step reads, is left as it is. `scratch` holds `width` floats.
struct SorRow {
  const float* rhs;
  const float* inverse_diagonal;
  const float* wx;
  const float* wy;
  const float* wy_up;
  const float* d_up;
  const float* d_down;
  int width;
};
void sor_row(const SorRow& row, int first, float omega, float* d, float* scratch);

namespace scalar {
void derivative_row(const std::uint8_t* const rows[5], int width, const DerivativeRows& out);
void photometric_terms_row(const PhotometricTermRows& in, const pixel::PhotometricWeights& w,
                           float* a, float* rhs, float* smooth);
void photometric_couplings_row(const CouplingRow& row, float* wx, float* wy,
                               float* inverse_diagonal);
void sor_row(const SorRow& row, int first, float omega, float* d);
}  // namespace scalar

}  // namespace dco::kernels
