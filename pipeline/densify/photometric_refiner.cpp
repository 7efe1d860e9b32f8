#include "dco/pipeline/densify/photometric_refiner.hpp"

#include <algorithm>
#include <string>

#include "dco/core/error.hpp"
#include "dco/kernels/photometric_kernels.hpp"

namespace dco::densify {
namespace {

kernels::DerivativeRows derivative_rows(Image<float>& rows, int first) {
  return {rows.row(first),     rows.row(first + 1), rows.row(first + 2),
          rows.row(first + 3), rows.row(first + 4), rows.row(first + 5)};
}

// The derivative rows of `img` at row y (rows y - 2 .. y + 2, clamped).
void derivatives_of(ImageView<const std::uint8_t> img, int y, const kernels::DerivativeRows& out) {
  const std::uint8_t* rows[5];
  for (int k = 0; k < 5; ++k) rows[k] = img.row(std::clamp(y + k - 2, 0, img.height - 1));
  kernels::derivative_row(rows, img.width, out);
}

void clamp_row(float* d, int w) {
  for (int x = 0; x < w; ++x) d[x] = std::max(d[x], 0.0f);
}

}  // namespace

void PhotometricRefinement::refine(ImageView<const std::uint8_t> left,
                                   ImageView<const std::uint8_t> right,
                                   const PhotometricParams& params, ImageView<float> disparity) {
  const int w = disparity.width;
  const int h = disparity.height;
  if (!left.same_size(w, h) || !right.same_size(w, h) || left.channels != 1 || right.channels != 1)
    throw Error("photometric refinement: the images must be grey and " + std::to_string(w) + "x" +
                std::to_string(h) + " like the disparity map, not " + std::to_string(left.width) +
                "x" + std::to_string(left.height) + "x" + std::to_string(left.channels) + " and " +
                std::to_string(right.width) + "x" + std::to_string(right.height) + "x" +
                std::to_string(right.channels));
  if (params.iterations <= 0 || params.sweeps <= 0 || w == 0 || h == 0) return;
  fit(left, right, params, disparity);
}

std::unique_ptr<PhotometricRefinement> make_photometric_refinement(
    const PhotometricRefinementFactory& factory, pipeline::RowTeam* rows) {
  if (factory) return factory();
  return std::make_unique<PhotometricRefiner>(rows);
}

void PhotometricRefiner::fit(ImageView<const std::uint8_t> left,
                             ImageView<const std::uint8_t> right, const PhotometricParams& params,
                             ImageView<float> disparity) {
  if (rows_ != nullptr && rows_->threads() > 1)
    fit_by_rows(left, right, params, disparity);
  else
    fit_in_one_pass(left, right, params, disparity);
}

void PhotometricRefiner::fit_by_rows(ImageView<const std::uint8_t> left,
                                     ImageView<const std::uint8_t> right,
                                     const PhotometricParams& params, ImageView<float> disparity) {
  const int w = disparity.width;
  const int h = disparity.height;
  for (Image<float>* image : {&a_, &rhs_, &smooth_, &wx_, &wy_, &inverse_diagonal_})
    image->resize(w, h);
  part_rows_.resize(static_cast<std::size_t>(rows_->threads()));
  for (Image<float>& rows : part_rows_) rows.resize(w, 16);
  const kernels::pixel::PhotometricWeights weights{static_cast<float>(params.alpha),
                                                   static_cast<float>(params.delta),
                                                   static_cast<float>(params.gamma)};
  // A pass's body over one thread's block of rows; every pass reads only what the passes before
  // it wrote (the half-sweeps also the other colour of their own pass, which it leaves alone).
  const auto terms = [&](int part, int begin, int end) {
    Image<float>& own = part_rows_[static_cast<std::size_t>(part)];
    kernels::PhotometricTermRows t{};
    for (int k = 0; k < 6; ++k) {
      t.left[k] = own.row(k);
      t.right[k] = own.row(6 + k);
    }
    t.width = w;
    for (int y = begin; y < end; ++y) {
      derivatives_of(left, y, derivative_rows(own, 0));
      derivatives_of(right, y, derivative_rows(own, 6));
      t.d = disparity.row(y);
      t.d_up = disparity.row(std::max(y - 1, 0));
      t.d_down = disparity.row(std::min(y + 1, h - 1));
      kernels::photometric_terms_row(t, weights, a_.row(y), rhs_.row(y), smooth_.row(y));
    }
  };
  const auto coupling_row = [&](int y, const float* wy_up) {
    return kernels::CouplingRow{a_.row(y), smooth_.row(y), y + 1 < h ? smooth_.row(y + 1) : nullptr,
                                wy_up, w};
  };
  const auto couplings = [&](int part, int begin, int end) {
    if (begin >= end) return;
    Image<float>& own = part_rows_[static_cast<std::size_t>(part)];
    const float* wy_up = nullptr;
    if (begin > 0) {
      // The row above's wy, as its own block computes it (its other outputs go unused).
      kernels::photometric_couplings_row(coupling_row(begin - 1, nullptr), own.row(13), own.row(14),
                                         own.row(15));
      wy_up = own.row(14);
    }
    for (int y = begin; y < end; ++y) {
      kernels::photometric_couplings_row(coupling_row(y, wy_up), wx_.row(y), wy_.row(y),
                                         inverse_diagonal_.row(y));
      wy_up = wy_.row(y);
    }
  };
  for (int iteration = 0; iteration < params.iterations; ++iteration) {
    rows_->run(h, terms);
    rows_->run(h, couplings);
    // The row kernel of a half-sweep stores whole vectors, rewriting the other colour's pixels
    // unchanged, and the rows above and below read those: so each half-sweep runs on the even
    // rows, then on the odd ones, and no thread reads a row while another writes it. A colour's
    // pixels read only the other colour's, so the split changes no bit.
    for (int half = 0; half < 2 * params.sweeps; ++half)
      for (const int parity : {0, 1})
        rows_->run(h, [&](int part, int begin, int end) {
          float* steps = part_rows_[static_cast<std::size_t>(part)].row(12);
          for (int y = begin + ((begin & 1) != parity); y < end; y += 2) {
            const kernels::SorRow row{rhs_.row(y),
                                      inverse_diagonal_.row(y),
                                      wx_.row(y),
                                      wy_.row(y),
                                      y > 0 ? wy_.row(y - 1) : nullptr,
                                      y > 0 ? disparity.row(y - 1) : nullptr,
                                      y + 1 < h ? disparity.row(y + 1) : nullptr,
                                      w};
            kernels::sor_row(row, (y + half) & 1, kPhotometricOmega, disparity.row(y), steps);
          }
        });
  }
  rows_->run(h, [&](int, int begin, int end) {
    for (int y = begin; y < end; ++y) clamp_row(disparity.row(y), w);
  });
}

void PhotometricRefiner::fit_in_one_pass(ImageView<const std::uint8_t> left,
                                         ImageView<const std::uint8_t> right,
                                         const PhotometricParams& params,
                                         ImageView<float> disparity) {
  const int w = disparity.width;
  const int h = disparity.height;
  const int stages = 2 * params.sweeps;  // half-sweeps, red then black
  // At step t the terms of row t are made, the couplings of row t - 1, and half-sweep k runs on
  // row t - 1 - k, which reads the couplings of the row above it: rows t - stages - 1 .. t.
  const int ring = stages + 2;
  derivatives_.resize(w, 12);
  for (Image<float>* rows : {&a_, &rhs_, &smooth_, &wx_, &wy_, &inverse_diagonal_})
    rows->resize(w, ring);
  scratch_.resize(static_cast<std::size_t>(w));
  const kernels::DerivativeRows left_rows = derivative_rows(derivatives_, 0);
  const kernels::DerivativeRows right_rows = derivative_rows(derivatives_, 6);
  kernels::PhotometricTermRows terms{};
  for (int k = 0; k < 6; ++k) {
    terms.left[k] = derivatives_.row(k);
    terms.right[k] = derivatives_.row(6 + k);
  }
  terms.width = w;
  const kernels::pixel::PhotometricWeights weights{static_cast<float>(params.alpha),
                                                   static_cast<float>(params.delta),
                                                   static_cast<float>(params.gamma)};
  const auto slot = [ring](int row) { return row % ring; };
  for (int iteration = 0; iteration < params.iterations; ++iteration) {
    const bool last_iteration = iteration + 1 == params.iterations;
    for (int t = 0; t < h + stages; ++t) {
      if (t < h) {
        // Row t's terms read rows t - 1 .. t + 1 of the map before any half-sweep of this
        // iteration reaches them: the first one is a row behind.
        derivatives_of(left, t, left_rows);
        derivatives_of(right, t, right_rows);
        terms.d = disparity.row(t);
        terms.d_up = disparity.row(std::max(t - 1, 0));
        terms.d_down = disparity.row(std::min(t + 1, h - 1));
        kernels::photometric_terms_row(terms, weights, a_.row(slot(t)), rhs_.row(slot(t)),
                                       smooth_.row(slot(t)));
      }
      if (const int r = t - 1; r >= 0 && r < h) {
        const kernels::CouplingRow row{a_.row(slot(r)), smooth_.row(slot(r)),
                                       r + 1 < h ? smooth_.row(slot(r + 1)) : nullptr,
                                       r > 0 ? wy_.row(slot(r - 1)) : nullptr, w};
        kernels::photometric_couplings_row(row, wx_.row(slot(r)), wy_.row(slot(r)),
                                           inverse_diagonal_.row(slot(r)));
      }
      for (int stage = 0; stage < stages; ++stage) {
        const int r = t - 1 - stage;
        if (r < 0 || r >= h) continue;
        const kernels::SorRow row{rhs_.row(slot(r)),
                                  inverse_diagonal_.row(slot(r)),
                                  wx_.row(slot(r)),
                                  wy_.row(slot(r)),
                                  r > 0 ? wy_.row(slot(r - 1)) : nullptr,
                                  r > 0 ? disparity.row(r - 1) : nullptr,
                                  r + 1 < h ? disparity.row(r + 1) : nullptr,
                                  w};
        // Red: the pixels with x + y even; black the others.
        const int first = (r + stage) & 1;
        kernels::sor_row(row, first, kPhotometricOmega, disparity.row(r), scratch_.data());
        // The clamp comes after every sweep, as in the plain order: row r - 1 once row r's last
        // half-sweep has read it, the last row at the end.
        if (last_iteration && stage + 1 == stages) {
          if (r > 0) clamp_row(disparity.row(r - 1), w);
          if (r + 1 == h) clamp_row(disparity.row(r), w);
        }
      }
    }
  }
}

}  // namespace dco::densify
