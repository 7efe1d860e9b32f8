#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/pipeline/row_team.hpp"

namespace dco::densify {

// Weights of the photometric refinement (DIS's variational refinement, Kroeger et al. 2016, with
// the flow held to the rows: u = -d, v = 0). Its energy over the disparity d:
//   sum_p  delta Psi(E_I) + gamma Psi(E_Gx) + gamma Psi(E_Gy) + alpha Psi(|grad d|^2)
// E_I: the grey level of the right image at x - d against the left's, E_Gx / E_Gy: the same for
// the two image derivatives, each normalised by its own gradient's square (+ zeta^2) so that
// strong and weak texture weigh alike; Psi(s) = sqrt(s + eps^2), the robust penaliser that lets
// occlusions and depth edges go.
struct PhotometricParams {
  int iterations = 2;  // fixed-point iterations (each relinearises about the current map); 0 = off
  int sweeps = 3;      // SOR sweeps (red then black) per iteration
  double alpha = 20;   // smoothness
  double delta = 2;    // grey-level constancy
  double gamma = 20;   // gradient constancy
  // Where the refinement runs on the CPU, frames with more pixels are left as the solve gives
  // them: it costs 11-12 ms per 1280x720 frame on one core of the 2-core machine, which that
  // size's real-time budget (25 ms a frame on two cores) has no room for. 0: every frame skips it
  // there. A GPU refinement (1.8 ms at 1280x720 on an H200) refines every frame.
  int max_pixels = 600000;
};

// Whether the CPU refines a width x height frame under `params`.
inline bool refines(const PhotometricParams& params, int width, int height) {
  return params.iterations > 0 &&
         static_cast<long long>(width) * height <= static_cast<long long>(params.max_pixels);
}

// Fits a dense disparity map to the images themselves: a few fixed-point iterations of the
// energy above, each linearised about the current map (grey levels and derivatives of the right
// image sampled at x - d along the row, linear interpolation; the derivatives the mean of both
// images') and relaxed by red-black SOR sweeps, then every value below 0 set to 0. The map's
// sub-pixel values on textured surfaces then come from the image alignment rather than from the
// smoothness between sparse matches; depth edges and occlusions stay where they are, because the
// robust penalisers give their large residuals and gradients little weight.
//
// The plain order defines the result: all pixels' terms, then all couplings, then each
// half-sweep over the whole image, the clamp last. Backends (the CPU below, a GPU grid in
// dco/gpu) give its bits.
class PhotometricRefinement {
 public:
  virtual ~PhotometricRefinement() = default;
  // left, right: grey, rectified (the right camera's rows and levels corrected), the map's size.
  // disparity: refined in place. Throws dco::Error on a size mismatch or colour images.
  void refine(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
              const PhotometricParams& params, ImageView<float> disparity);
  // Whether the densifier refines its width x height frames with this backend under `params`
  // (the CPU's rule, densify::refines, unless the backend says otherwise).
  virtual bool refines(const PhotometricParams& params, int width, int height) const {
    return densify::refines(params, width, height);
  }

 protected:
  // After the checks, with iterations and sweeps > 0 and a map of at least one pixel.
  virtual void fit(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                   const PhotometricParams& params, ImageView<float> disparity) = 0;
};

// Makes a backend's refinement (CPU, CUDA); an empty factory means the CPU one, sharing its
// passes with `rows` (see PhotometricRefiner).
using PhotometricRefinementFactory = std::function<std::unique_ptr<PhotometricRefinement>()>;
std::unique_ptr<PhotometricRefinement> make_photometric_refinement(
    const PhotometricRefinementFactory& factory, pipeline::RowTeam* rows = nullptr);

// The CPU's, with the vector row kernels. On one thread: one pass over the rows per iteration,
// row t's terms, then each half-sweep one row behind the one before it (the red one of sweep 1
// on row t - 1, the black one on t - 2, ...), in a ring of rows that stays in cache; every pixel
// sees the values it would see in the plain order, so the result is that order's, bit for bit.
// With a row team of more threads: the plain order itself, each of its passes (terms, couplings,
// half-sweeps, on the even rows and then on the odd ones, clamp) shared out by rows, whose rows
// within a pass are independent; the same bits however many threads. Allocates only when the size,
// the number of sweeps or the threads grow.
class PhotometricRefiner final : public PhotometricRefinement {
 public:
  // `rows`: the threads that share the passes (the densifier's row team); none or one thread:
  // the single pass over the rows. It must outlive the refiner.
  explicit PhotometricRefiner(pipeline::RowTeam* rows = nullptr) : rows_(rows) {}

 protected:
  void fit(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
           const PhotometricParams& params, ImageView<float> disparity) override;

 private:
  void fit_in_one_pass(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                       const PhotometricParams& params, ImageView<float> disparity);
  void fit_by_rows(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                   const PhotometricParams& params, ImageView<float> disparity);

  pipeline::RowTeam* rows_;
  Image<float> derivatives_;  // 12 rows: the left image's six derivative rows, then the right's
  // Rings of rows (one pass), or whole images (by rows): the data terms, smoothness weights,
  // couplings and inverse diagonals.
  Image<float> a_, rhs_, smooth_, wx_, wy_, inverse_diagonal_;
  std::vector<float> scratch_;  // one row of steps
  // By rows, per thread: 12 derivative rows, a row of steps, and the couplings of the row above
  // its first row (wx, wy, inverse diagonal), which another thread's block holds.
  std::vector<Image<float>> part_rows_;
};

// The over-relaxation factor of the sweeps (DIS's).
inline constexpr float kPhotometricOmega = 1.6f;

}  // namespace dco::densify
