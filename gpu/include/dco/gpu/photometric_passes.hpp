#pragma once

// The densifier's photometric refinement as data-parallel passes over tightly packed images (see
// stereo_passes.hpp). Each pass calls the CPU row kernels' own per-pixel steps
// (dco::kernels::derivative_at, photometric_terms_at, photometric_edges_at,
// photometric_inverse_diagonal_at and sor_at in photometric_kernels.hpp) on the rows around its
// grid point, so every value equals the CPU's bit for bit.

#include <cstddef>
#include <cstdint>

#include "dco/gpu/stereo_passes.hpp"
#include "dco/kernels/photometric_kernels.hpp"

namespace dco::gpu::passes {

// An image's grey level and five derivatives (kernels::DerivativeRows), one plane of width x
// height floats each.
struct DerivativePlanes {
  float* plane[6];
  DCO_HD kernels::DerivativeRows row(int y, int width) const {
    const std::size_t o = at(0, y, width);
    return {plane[0] + o, plane[1] + o, plane[2] + o, plane[3] + o, plane[4] + o, plane[5] + o};
  }
};

// The derivative planes of a grey image (rows and columns clamped at its edges).
struct PhotometricDerivatives {
  const std::uint8_t* image;
  int width, height;
  DerivativePlanes out;
  DCO_HD void operator()(int x, int y) const {
    const std::uint8_t* rows[5];
    for (int k = 0; k < 5; ++k)
      rows[k] = image + at(0, px::clamp_to(y + k - 2, 0, height - 1), width);
    kernels::derivative_at(rows, width, x, out.row(y, width));
  }
};

// Every pixel's linearised data term (a, rhs) and smoothness weight about the map d.
struct PhotometricTerms {
  DerivativePlanes left, right;
  const float* d;
  int width, height;
  px::PhotometricWeights weights;
  float *a, *rhs, *smooth;
  DCO_HD void operator()(int x, int y) const {
    const std::size_t o = at(0, y, width);
    kernels::PhotometricTermRows in{};
    for (int k = 0; k < 6; ++k) {
      in.left[k] = left.plane[k] + o;
      in.right[k] = right.plane[k] + o;
    }
    in.d = d + o;
    in.d_up = d + at(0, px::max_of(y - 1, 0), width);
    in.d_down = d + at(0, px::min_of(y + 1, height - 1), width);
    in.width = width;
    kernels::photometric_terms_at(in, weights, x, a + o, rhs + o, smooth + o);
  }
};

// The couplings' images: what the edge pass writes and the inverse-diagonal pass reads.
struct CouplingPlanes {
  const float *a, *s;
  float *wx, *wy, *inverse_diagonal;
  int width, height;
  DCO_HD kernels::CouplingRow row(int y) const {
    const std::size_t o = at(0, y, width);
    return {a + o, s + o, y + 1 < height ? s + o + width : nullptr,
            y > 0 ? wy + o - width : nullptr, width};
  }
};

struct PhotometricEdges {
  CouplingPlanes c;
  DCO_HD void operator()(int x, int y) const {
    const std::size_t o = at(0, y, c.width);
    kernels::photometric_edges_at(c.row(y), x, c.wx + o, c.wy + o);
  }
};

// After PhotometricEdges over the whole image (it reads the row above's wy).
struct PhotometricInverseDiagonal {
  CouplingPlanes c;
  DCO_HD void operator()(int x, int y) const {
    const std::size_t o = at(0, y, c.width);
    kernels::photometric_inverse_diagonal_at(c.row(y), x, c.wx + o, c.wy + o,
                                             c.inverse_diagonal + o);
  }
};

// One colour of a red-black SOR sweep: grid ((width + 1) / 2, height), point (i, y) updates
// column 2 i + (y + colour) % 2, the pixels with (x + y) % 2 == colour (red 0, black 1).
struct PhotometricSorColour {
  const float *rhs, *inverse_diagonal, *wx, *wy;
  float* d;
  int width, height, colour;
  float omega;
  DCO_HD void operator()(int i, int y) const {
    const int x = 2 * i + ((y + colour) & 1);
    if (x >= width) return;
    const std::size_t o = at(0, y, width);
    const kernels::SorRow row{rhs + o,
                              inverse_diagonal + o,
                              wx + o,
                              wy + o,
                              y > 0 ? wy + o - width : nullptr,
                              y > 0 ? d + o - width : nullptr,
                              y + 1 < height ? d + o + width : nullptr,
                              width};
    kernels::sor_at(row, x, omega, d + o);
  }
};

// Values below 0 set to 0 (std::max(v, 0.0f): -0 and NaN stay).
struct ClampBelowZero {
  float* d;
  int width;
  DCO_HD void operator()(int x, int y) const {
    float& v = d[at(x, y, width)];
    v = v < 0.0f ? 0.0f : v;
  }
};

}  // namespace dco::gpu::passes
