#include "dco/kernels/photometric_kernels.hpp"
#include "photometric_ranges.hpp"

namespace dco::kernels::scalar {

void derivative_row(const std::uint8_t* const rows[5], int width, const DerivativeRows& out) {
  detail::derivative_range(rows, width, 0, width, out);
}

void photometric_terms_row(const PhotometricTermRows& in, const pixel::PhotometricWeights& w,
                           float* a, float* rhs, float* smooth) {
  detail::photometric_terms_range(in, w, 0, in.width, a, rhs, smooth);
}

void photometric_couplings_row(const CouplingRow& row, float* wx, float* wy,
                               float* inverse_diagonal) {
  detail::photometric_couplings_range(row, 0, row.width, wx, wy, inverse_diagonal);
}

void sor_row(const SorRow& row, int first, float omega, float* d) {
  detail::sor_range(row, first, row.width, omega, d);
}

}  // namespace dco::kernels::scalar
