#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/pipeline/densify/conjugate_gradients.hpp"
#include "dco/pipeline/densify/grid_system.hpp"
#include "dco/pipeline/densify/match_planes.hpp"
#include "dco/pipeline/densify/multigrid.hpp"
#include "dco/pipeline/densify/photometric_refiner.hpp"
#include "dco/pipeline/densify/system_solver.hpp"
#include "dco/pipeline/row_team.hpp"

namespace dco {
class ConfigSchema;
}

namespace dco::densify {

// The border plane (DensifyParams::border_plane_rms) is fitted to this many columns from each
// row's first match, over the rows within kBorderFitRows of the hole's row.
inline constexpr int kBorderFitColumns = 32;
inline constexpr int kBorderFitRows = 8;

// Parameters of the quadratic densification (§6, Eq. 20; defaults from §7.2).
struct DensifyParams {
  double lambda_d = 0.8;    // data term, Eq. 13–14
  double lambda_s = 1.2;    // contour-aware smoothness, Eq. 15–17
  double lambda_s2 = 0.02;  // stability against the previous frame, Eq. 18–19
  // Floor of every smoothness weight: keeps each pixel connected to the rest, so regions a
  // contour encloses without any sparse value still get one, and the system stays definite.
  double min_edge_weight = 0.001;
  // Weak data term for holes: the farther of the row neighbours (but see fill_edge_weight). Not
  // for a hole run whose left neighbour is the nearer by 2 px or more: occlusions lie only left
  // of a near surface (kernels::occlusion_fill_row).
  double background_fill = 0.05;
  // A hole takes the other row neighbour when only that one is reached without crossing an edge
  // whose smoothness weight (relative, after contours, Canny strength and image guidance) is
  // below this. A hole inside an object then keeps the object's depth instead of the
  // background's. 0 = off.
  double fill_edge_weight = 0.05;
  // A hole run about as wide as the disparity jump across it, the farther match on its left,
  // holds the strip the near surface hides from the right camera (kernels::occlusion_fill_row):
  // the strip's pixels are pulled towards that farther match with this weight (times lambda_d),
  // and the near surface's rim past them takes no hole hint. 0 = off.
  double occlusion_fill = 2;
  // Holes at the left border, where the right image holds no match, continue the surface next to
  // them: their hint is a plane fitted to the first kBorderFitColumns matched pixels of the rows
  // within kBorderFitRows, used when it fits them within this RMS (px). Else, and with 0, they
  // take the first match of their row, as other holes. Left alone, a slanted surface that runs
  // into the border is filled flat.
  double border_plane_rms = 0.3;
  double color_sigma = 1;  // grey-level scale of exp(-|I_p - I_q| / sigma) on the weights; 0 = off
  // Matches first smoothed along local planes (MatchPlaneSmoother): the window side on the
  // matcher's grid (DensifyInputs::match_step; odd, 0 = off) and the largest RMS distance (px)
  // of its matches to their plane.
  int plane_window = 7;
  double plane_rms = 0.6;
  // "full" solves Eq. 20 at the input resolution; "half" solves its 2x2-aggregated (Galerkin)
  // system and then runs `fine_sweeps` Gauss-Seidel sweeps and up to `fine_iterations`
  // conjugate-gradient iterations of the full system from the result, so contours still act at
  // the input resolution; "auto" = half when the input is wider than 640 px.
  std::string solve_resolution = "auto";
  int fine_sweeps = 4;
  int fine_iterations = 0;
  // After a half-size solve's sweeps (and no full-size iteration), also measure the residual of
  // the output on the full system (SolverReport::output_residual, else NaN): one more pass over
  // it, about 0.2-0.4 ms of a 1280x720 frame, for a figure the tools print and nothing else
  // reads.
  bool output_residual = false;
  int max_iterations = 60;
  double tolerance = 1e-4;  // relative residual ||b - Ax|| / ||b||
  bool multigrid = true;    // V-cycle preconditioner (else plain conjugate gradients)
  // Side of the median filter on the dense output (0 = off, 3 or 5). The solve leaves single
  // pixels and one-pixel slivers between two surfaces where a hole of the 2x2 matcher grid met
  // a depth edge; against a virtual plane each is a speck of wrong occlusion. A median removes
  // them and keeps a straight step where it is; the 5x5 one also two-pixel slivers. The
  // solver's own solution stays unfiltered: it is the next frame's warm start and previous
  // frame (Eq. 18).
  int median_size = 5;
  // The output fitted to the images themselves after the median (PhotometricRefiner), where
  // DensifyInputs::right is given; iterations 0 = off.
  PhotometricParams photometric;
  // Threads that share the stage's row-wise steps (building the system, the clamp and the
  // median), the stage's own included: 0 = auto, 1 where fewer than 4 CPUs are usable (the two
  // stage threads have them), else half of them, at most 4. Same output however many.
  int row_threads = 0;
};

void register_params(ConfigSchema& schema, DensifyParams& params);
void validate(const DensifyParams& params);  // throws dco::Error

// Everything at the input resolution except m_fuse (the internal resolution, or any other: it is
// sampled as the contour gate, kernels::pixel::gate_sample). Optional inputs may be empty.
struct DensifyInputs {
  ImageView<const float> sparse;           // disparity px, +inf (or <= 0) where unknown
  ImageView<const float> m_fuse;           // [0, 1], optional
  ImageView<const float> m_intensity;      // [0, 1], optional
  ImageView<const std::uint8_t> contours;  // B_dp, non-zero on a depth contour, optional
  ImageView<const float> previous;         // last frame's dense disparity, optional
  ImageView<const std::uint8_t> image;     // grey input image, optional (colour guidance)
  // Grey right image on the left's rows and levels, optional: with `image`, the photometric
  // refinement's second view.
  ImageView<const std::uint8_t> right;
  // The grey left image as the refinement compares it with `right`, optional: `image` through
  // the stereo stage's lens fall-off correction, where it has one (else `image` itself).
  ImageView<const std::uint8_t> photometric_left;
  // The sparse map after smooth_matches with these params, optional: compute then skips that
  // step (it needs only the sparse map, so the stereo thread runs it).
  ImageView<const float> planar;
  // The matcher's grid: sparse values come in match_step x match_step blocks (the stereo
  // stage's internal downscale).
  int match_step = 1;
};

struct DensifyTimings {
  // median_ms: the clamp of the solution to the data range and the median filter; refine_ms: the
  // photometric refinement.
  double planes_ms = 0, build_ms = 0, solve_ms = 0, median_ms = 0, refine_ms = 0, total_ms = 0;
};

// Solves Eq. 20 in disparity (a plane in the scene is affine in disparity, so smoothness in
// disparity keeps slanted surfaces straight) and writes a dense disparity map: every pixel set.
// The solution of the previous call is the starting point of the next (warm start).
// The densifier's first step: `sparse` with its matches along local planes (plane_window,
// plane_rms; MatchPlaneSmoother) into `out`, or copied when plane_window is 0. `out` has sparse's
// size and does not share its memory.
void smooth_matches(const DensifyParams& params, MatchPlaneSmoother& planes,
                    ImageView<const float> sparse, int match_step, ImageView<float> out);

class Densifier {
 public:
  // `solver` makes the solver of the system, `refinement` the photometric refinement (empty: the
  // CPU ones).
  explicit Densifier(const DensifyParams& params, const SystemSolverFactory& solver = {},
                     const PhotometricRefinementFactory& refinement = {});

  void compute(const DensifyInputs& in, Image<float>& dense);

  const SolverReport& last_report() const { return report_; }
  const DensifyTimings& last_timings() const { return timings_; }
  const DensifyParams& params() const { return params_; }
  // The solution of the last call (empty before the first or after reset). It stays valid
  // while the next call builds its system, so it can be that call's `previous` input.
  ImageView<const float> last_solution() const {
    return has_solution_ ? solution_.view() : ImageView<const float>{};
  }
  // The full-resolution system A x = b of the last call (Eq. 20's normal equations), for
  // checks against other solvers; its diagonal is worked out here if the solve did not need it.
  const GridSystem& last_system();
  ImageView<const float> last_rhs() const { return rhs_.cview(); }
  // Whether a frame `width` pixels wide is solved at half resolution.
  bool solves_at_half(int width) const;
  // Whether a width x height frame is fitted to its images by the photometric refinement (which
  // needs DensifyInputs::right then). Any thread may ask.
  bool refines(int width, int height) const {
    return refiner_->refines(params_.photometric, width, height);
  }
  // Forgets the previous solution (a scene cut, a new sequence).
  void reset() { has_solution_ = false; }

 private:
  void build_system(const DensifyInputs& in);
  // The output: the clamped solution through the median filter (median_size).
  void finish(Image<float>& dense);
  // Clamps `map` to the range of the data terms' values (none before the first system).
  void clamp_to_data_range(ImageView<float> map);
  // Overwrites the hints of the holes at the start of each row (see border_plane_rms) and widens
  // [low, high] to the hints it sets.
  void border_plane_hints(ImageView<const float> sparse, float& low, float& high);

  DensifyParams params_;
  std::unique_ptr<SystemSolver> solver_;
  GridSystem system_;
  MatchPlaneSmoother planes_;
  Image<float> smoothed_;  // the sparse map after planes_
  Image<float> rhs_, hint_, solution_, smooth_strength_;
  Image<std::uint8_t> barrier_;
  std::vector<int> fuse_column_;  // column of M_fuse for each input column
  pipeline::RowTeam rows_;
  // Per thread of rows_: the 5x5 median's sorted columns of one row, and the data range.
  std::vector<std::vector<float>> median_columns_;
  std::vector<std::array<float, 2>> part_range_;
  // Per row: its first matched column and the sums of its fitted pixels (n, x, x², d, x·d, d²).
  std::vector<int> border_first_;
  std::vector<std::array<double, 6>> border_sums_;
  std::array<float, 256> color_weight_{};  // exp(-diff / color_sigma) per grey-level difference
  // Range of the frame's sparse and previous values: the exact minimiser of Eq. 20 is a
  // weighted mean of them, so the solution is kept inside it.
  float data_low_ = 0.0f, data_high_ = 0.0f;
  bool has_solution_ = false;
  SolverReport report_;
  DensifyTimings timings_;
  std::unique_ptr<PhotometricRefinement> refiner_;
};

// Closes diagonal gaps of a contour mask so that it separates regions under 4-connectivity
// (two contour pixels touching only at a corner would let the smoothness term leak across).
void close_diagonal_gaps(ImageView<const std::uint8_t> contours, ImageView<std::uint8_t> closed);
// The same for rows [begin, end) of `closed` (row y reads rows y and y + 1 of `contours`).
void close_diagonal_gap_rows(ImageView<const std::uint8_t> contours, int begin, int end,
                             ImageView<std::uint8_t> closed);

}  // namespace dco::densify
