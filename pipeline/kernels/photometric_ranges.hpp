#pragma once

// The photometric refinement's scalar row kernels over a range of columns: the whole row for
// dco::kernels::scalar, the borders and the tails for the SIMD versions. The order of the float
// operations (kernels::pixel's) is the contract the vector code follows.

#include "dco/kernels/photometric_kernels.hpp"

namespace dco::kernels::detail {

inline void derivative_range(const std::uint8_t* const rows[5], int width, int begin, int end,
                             const DerivativeRows& out) {
  for (int x = begin; x < end; ++x) derivative_at(rows, width, x, out);
}

inline void photometric_terms_range(const PhotometricTermRows& in,
                                    const pixel::PhotometricWeights& w, int begin, int end,
                                    float* a, float* rhs, float* smooth) {
  for (int x = begin; x < end; ++x) photometric_terms_at(in, w, x, a, rhs, smooth);
}

inline void photometric_couplings_range(const CouplingRow& row, int begin, int end, float* wx,
                                        float* wy, float* inverse_diagonal) {
  for (int x = begin; x < end; ++x) photometric_edges_at(row, x, wx, wy);
  for (int x = begin; x < end; ++x)
    photometric_inverse_diagonal_at(row, x, wx, wy, inverse_diagonal);
}

// Columns begin, begin + 2, ... below end: the caller starts at a pixel of the colour to update.
inline void sor_range(const SorRow& row, int begin, int end, float omega, float* d) {
  for (int x = begin; x < end; x += 2) sor_at(row, x, omega, d);
}

}  // namespace dco::kernels::detail
