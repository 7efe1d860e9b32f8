#pragma once

// Per-pixel math of the densifier's photometric refinement (dco/pipeline/densify/
// photometric_refiner.hpp): float operations in one fixed order and no fused multiply-add, which
// the scalar references and the SIMD kernels (photometric_kernels.hpp) both follow, so every
// target gives the same bits.

#include <cmath>
#include <cstdint>

#include "dco/kernels/host_device.hpp"
#include "dco/kernels/stereo_pixel.hpp"

namespace dco::kernels::pixel {

// DIS's constants (grey levels 0..255): zeta^2 keeps the normalisation finite on flat ground,
// eps^2 is the robust penaliser's corner, 1e-6 keeps a pixel without data or neighbours defined.
inline constexpr float kPhotometricZetaSquared = 0.01f;
inline constexpr float kPhotometricEpsSquared = 1e-6f;
inline constexpr float kPhotometricTiny = 1e-6f;

// Grey level and central-difference derivatives of an image at column x from its rows y - 2 ..
// y + 2 (rows clamped by the caller) and columns l2 < l1 < x < r1 < r2 (clamped to the row).
struct Derivatives {
  float v, x, y, xx, xy, yy;
};
template <class T>
DCO_HD Derivatives derivatives_at(const T* const rows[5], int l2, int l1, int x, int r1, int r2) {
  const auto at = [rows](int row, int column) { return static_cast<float>(rows[row][column]); };
  Derivatives d;
  d.v = at(2, x);
  d.x = 0.5f * (at(2, r1) - at(2, l1));
  d.y = 0.5f * (at(3, x) - at(1, x));
  d.xx = 0.25f * ((at(2, r2) - 2.0f * d.v) + at(2, l2));
  d.xy = 0.25f * (((at(3, r1) - at(1, r1)) - at(3, l1)) + at(1, l1));
  d.yy = 0.25f * ((at(4, x) - 2.0f * d.v) + at(0, x));
  return d;
}

DCO_HD inline float lerp_sample(float p, float q, float t) {
  return p + t * (q - p);
}

// Weights of the refinement's energy (PhotometricParams).
struct PhotometricWeights {
  float alpha, delta, gamma;
};

// One pixel's linearised data term about its disparity d: the left image's derivatives `l`
// against the right's sampled at x - d (`r`); the derivatives linearised are both images' mean.
// The data term is a (d' - d)^2 - 2 (a d - rhs) (d' - d) + const, written as `a` and the
// right-hand side `rhs` of its normal equation a d' = rhs. The diagonal's kPhotometricTiny is
// matched here by kPhotometricTiny d, so a pixel without data or neighbours (flat ground, alpha 0)
// keeps d instead of decaying towards 0.
//
// Each term's weight is w Psi'(n e^2) n with the normalisation n = 1 / D, D = |grad|^2 + zeta^2:
// w / (D sqrt(e^2 / D + eps^2)) = w / q with q = sqrt(D e^2 + D^2 eps^2). Over the common
// denominator q_c q_x q_y the three terms take one division instead of six.
DCO_HD inline void photometric_data_term(const Derivatives& l, const Derivatives& r, float d,
                                         const PhotometricWeights& w, float& a, float& rhs) {
  const float ix = 0.5f * (l.x + r.x), iy = 0.5f * (l.y + r.y);
  const float ixx = 0.5f * (l.xx + r.xx), ixy = 0.5f * (l.xy + r.xy), iyy = 0.5f * (l.yy + r.yy);
  const float e = r.v - l.v, ex = r.x - l.x, ey = r.y - l.y;
  const float dc = (ix * ix + iy * iy) + kPhotometricZetaSquared;
  const float dx = (ixx * ixx + ixy * ixy) + kPhotometricZetaSquared;
  const float dy = (ixy * ixy + iyy * iyy) + kPhotometricZetaSquared;
  const float qc = std::sqrt(dc * (e * e) + (dc * dc) * kPhotometricEpsSquared);
  const float qx = std::sqrt(dx * (ex * ex) + (dx * dx) * kPhotometricEpsSquared);
  const float qy = std::sqrt(dy * (ey * ey) + (dy * dy) * kPhotometricEpsSquared);
  // The weights over the common denominator; the residuals move by -ix, -ixx, -ixy per unit of
  // disparity.
  const float mc = w.delta * (qx * qy), mx = w.gamma * (qc * qy), my = w.gamma * (qc * qx);
  const float inverse = 1.0f / (qc * (qx * qy));
  a = ((mc * (ix * ix) + mx * (ixx * ixx)) + my * (ixy * ixy)) * inverse;
  rhs =
      (a + kPhotometricTiny) * d + ((mc * (ix * e) + mx * (ixx * ex)) + my * (ixy * ey)) * inverse;
}

// The robust smoothness weight alpha / Psi(|grad d|^2) from the central differences of d.
DCO_HD inline float photometric_smoothness(float left, float right, float up, float down,
                                           float alpha) {
  const float gx = 0.5f * (right - left), gy = 0.5f * (down - up);
  return alpha / std::sqrt((gx * gx + gy * gy) + kPhotometricEpsSquared);
}

// The coupling of two neighbours from their smoothness weights.
DCO_HD inline float photometric_edge(float s, float s_q) {
  return 0.5f * (s + s_q);
}

// 1 / the diagonal of a pixel's row of (a + sum_q w_q) d - sum_q w_q d_q = rhs, the couplings
// added left, right, up, down (0 for a neighbour outside the image).
DCO_HD inline float photometric_inverse_diagonal(float a, float w_left, float w_right, float w_up,
                                                 float w_down) {
  return 1.0f / (((((a + kPhotometricTiny) + w_left) + w_right) + w_up) + w_down);
}

// One SOR step of that pixel, the neighbours added left, right, up, down (one outside the image
// with coupling and value 0: adding those changes no bit).
DCO_HD inline float sor_step(float d, float rhs, float inverse_diagonal, float w_left, float d_left,
                             float w_right, float d_right, float w_up, float d_up, float w_down,
                             float d_down, float omega) {
  const float num = (((rhs + w_left * d_left) + w_right * d_right) + w_up * d_up) + w_down * d_down;
  return d + omega * (num * inverse_diagonal - d);
}

}  // namespace dco::kernels::pixel
