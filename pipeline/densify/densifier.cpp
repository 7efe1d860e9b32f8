#include "dco/pipeline/densify/densifier.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include <opencv2/imgproc.hpp>

#include "dco/core/config.hpp"
#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/core/stopwatch.hpp"
#include "dco/kernels/contour_pixel.hpp"
#include "dco/kernels/densify_kernels.hpp"
#include "dco/kernels/densify_pixel.hpp"
#include "dco/kernels/filter_kernels.hpp"

namespace dco::densify {
namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw Error("densify parameters: " + what);
}

double det3(const std::array<double, 9>& m) {
  return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
         m[2] * (m[3] * m[7] - m[4] * m[6]);
}

// Solves the 3x3 system m x = b (row-major m) by Cramer's rule; false when it is singular.
bool solve3(const std::array<double, 9>& m, const std::array<double, 3>& b,
            std::array<double, 3>& x) {
  const double d = det3(m);
  if (!(std::abs(d) > 1e-9 * (std::abs(m[0] * m[4] * m[8]) + 1e-300))) return false;
  for (int k = 0; k < 3; ++k) {
    std::array<double, 9> mk = m;
    for (int r = 0; r < 3; ++r)
      mk[static_cast<std::size_t>(3 * r + k)] = b[static_cast<std::size_t>(r)];
    x[static_cast<std::size_t>(k)] = det3(mk) / d;
  }
  return true;
}

// s[x] = fuse[x / 2] * intensity[x]: M_fuse at half the width (the stereo stage's internal
// resolution), written per pair of columns so that it vectorises.
void strength_row_half_width(const float* __restrict fuse, const float* __restrict intensity,
                             int width, float* __restrict s) {
  for (int g = 0; g < width / 2; ++g) {
    s[2 * g] = fuse[g] * intensity[2 * g];
    s[2 * g + 1] = fuse[g] * intensity[2 * g + 1];
  }
}

}  // namespace

void register_params(ConfigSchema& s, DensifyParams& p) {
  s.add("densify.lambda_d", &p.lambda_d, 0.001, 1000.0, "λ_d of Eq. 20 (data term)");
  s.add("densify.lambda_s", &p.lambda_s, 0.0, 1000.0, "λ_s of Eq. 20 (smoothness)");
  s.add("densify.lambda_s2", &p.lambda_s2, 0.0, 1000.0, "λ_s2 of Eq. 20 (stability)");
  s.add("densify.min_edge_weight", &p.min_edge_weight, 1e-6, 1.0,
        "floor of every smoothness weight (keeps the system connected)");
  s.add("densify.color_sigma", &p.color_sigma, 0.0, 255.0,
        "grey-level scale of the image guidance on smoothness weights (0 = off)");
  s.add("densify.background_fill", &p.background_fill, 0.0, 1.0,
        "weight (times lambda_d) pulling holes towards the farther of their row neighbours "
        "(not a run whose left neighbour is the nearer by 2 px or more)");
  s.add("densify.fill_edge_weight", &p.fill_edge_weight, 0.0, 1.0,
        "holes take the row neighbour reached without crossing an edge weaker than this "
        "(0 = always the farther one)");
  s.add("densify.occlusion_fill", &p.occlusion_fill, 0.0, 100.0,
        "weight (times lambda_d) pulling the occlusion strip of a hole run about as wide as the "
        "disparity jump across it, the farther match on its left, towards that match; the "
        "run's rim past the strip then takes no hole hint (0 = off)");
  s.add("densify.border_plane_rms", &p.border_plane_rms, 0.0, 10.0,
        "holes at the left border take a plane fitted to the matches next to them when it fits "
        "within this RMS, px (0 = the row's first match, as other holes)");
  s.add("densify.plane_window", &p.plane_window, 0, 31,
        "matches first take the value of the plane through the matches of this window around "
        "them, on the matcher's grid: 0 (off) or odd from 3");
  s.add("densify.plane_rms", &p.plane_rms, 0.01, 10.0,
        "... where those matches lie within this RMS of their plane, px");
  s.add("densify.solve_resolution", &p.solve_resolution, {"auto", "full", "half"},
        "auto = solve at half size, then refine at full size, when wider than 640 px");
  s.add("densify.fine_sweeps", &p.fine_sweeps, 0, 100,
        "Gauss-Seidel sweeps at full size after a half-size solve");
  s.add("densify.fine_iterations", &p.fine_iterations, 0, 100,
        "conjugate-gradient iterations at full size after a half-size solve and its sweeps");
  s.add("densify.output_residual", &p.output_residual,
        "after a half-size solve's sweeps also measure the output's residual on the full system "
        "(a pass over it, about 0.2–0.4 ms per 1280x720 frame; dco-depth prints it, else the "
        "half-size solve's)");
  s.add("densify.max_iterations", &p.max_iterations, 1, 10000, "conjugate-gradient iterations");
  s.add("densify.tolerance", &p.tolerance, 1e-9, 0.1, "relative residual to stop at");
  s.add("densify.multigrid", &p.multigrid, "multigrid V-cycle preconditioner");
  s.add("densify.median_size", &p.median_size, 0, 5,
        "median filter of the dense output, px: 0 (off), 3 or 5; removes one- and two-pixel "
        "specks between two surfaces");
  s.add("densify.photometric_iterations", &p.photometric.iterations, 0, 20,
        "fixed-point iterations of the photometric refinement: the output fitted to the grey "
        "levels and gradients of both images (0 = off)");
  s.add("densify.photometric_sweeps", &p.photometric.sweeps, 1, 50,
        "SOR sweeps of the photometric refinement per iteration");
  s.add("densify.photometric_alpha", &p.photometric.alpha, 0.0, 1000.0,
        "smoothness weight of the photometric refinement (robust, on the disparity's gradient)");
  s.add("densify.photometric_delta", &p.photometric.delta, 0.0, 1000.0,
        "grey-level constancy weight of the photometric refinement");
  s.add("densify.photometric_gamma", &p.photometric.gamma, 0.0, 1000.0,
        "gradient constancy weight of the photometric refinement");
  s.add("densify.photometric_max_pixels", &p.photometric.max_pixels, 0, 100000000,
        "where the photometric refinement runs on the CPU, frames with more pixels skip it (0: "
        "every frame skips it on the CPU); on the CUDA backend it refines every frame (1.8 ms at "
        "1280x720 on an H200)");
  s.add("densify.row_threads", &p.row_threads, 0, 16,
        "threads sharing the row-wise steps (building the system, the clamp and the median), the "
        "stage's own included (0 = auto: 1 below 4 usable CPUs, else half of them, at most 4)");
}

void validate(const DensifyParams& p) {
  require(p.lambda_d > 0, "lambda_d must be positive (the data term anchors the solution)");
  require(p.lambda_s >= 0 && p.lambda_s2 >= 0, "lambda_s and lambda_s2 must be >= 0");
  require(p.min_edge_weight > 0 && p.min_edge_weight <= 1, "min_edge_weight must be in (0, 1]");
  require(p.max_iterations >= 1, "max_iterations must be >= 1");
  require(
      p.solve_resolution == "auto" || p.solve_resolution == "full" || p.solve_resolution == "half",
      "solve_resolution must be auto, full or half, not '" + p.solve_resolution + "'");
  require(p.fine_sweeps >= 0, "fine_sweeps must be >= 0");
  require(p.fine_iterations >= 0, "fine_iterations must be >= 0");
  require(p.tolerance > 0 && p.tolerance < 1, "tolerance must be in (0, 1)");
  require(p.border_plane_rms >= 0, "border_plane_rms must be >= 0");
  require(p.occlusion_fill >= 0, "occlusion_fill must be >= 0");
  require(p.plane_window == 0 ||
              (p.plane_window >= 3 && p.plane_window <= 31 && p.plane_window % 2 == 1),
          "plane_window must be 0 or odd in 3..31");
  require(p.plane_rms > 0, "plane_rms must be positive");
  require(p.median_size == 0 || p.median_size == 3 || p.median_size == 5,
          "median_size must be 0, 3 or 5, not " + std::to_string(p.median_size));
  require(p.photometric.iterations >= 0 && p.photometric.sweeps >= 1,
          "photometric_iterations must be >= 0 and photometric_sweeps >= 1");
  require(p.photometric.alpha >= 0 && p.photometric.delta >= 0 && p.photometric.gamma >= 0 &&
              p.photometric.delta + p.photometric.gamma > 0,
          "photometric_alpha, _delta and _gamma must be >= 0, delta + gamma > 0");
  require(p.row_threads >= 0 && p.row_threads <= 16,
          "row_threads must be in 0..16 (0 = auto), not " + std::to_string(p.row_threads));
}

void close_diagonal_gaps(ImageView<const std::uint8_t> contours, ImageView<std::uint8_t> closed) {
  close_diagonal_gap_rows(contours, 0, contours.height, closed);
}

void close_diagonal_gap_rows(ImageView<const std::uint8_t> contours, int begin, int end,
                             ImageView<std::uint8_t> closed) {
  const int w = contours.width;
  const int h = contours.height;
  // A 2x2 block whose contour pixels touch only at a corner gets the upper pixel of the other
  // diagonal: "\" (top-left, bottom-right) fills its top-right, "/" (top-right, bottom-left) its
  // top-left. Each row is a function of its own and the next row of the input alone (a filled
  // pixel never makes or breaks another block's case), so the rows are independent and the
  // loops plain enough to vectorise.
  for (int y = begin; y < end; ++y) {
    const std::uint8_t* top = contours.row(y);
    std::uint8_t* out = closed.row(y);
    if (y + 1 == h || w < 2) {
      for (int x = 0; x < w; ++x) out[x] = top[x] ? 1 : 0;
      continue;
    }
    const std::uint8_t* bottom = contours.row(y + 1);
    // The corner pixel below x must be set and x itself empty; then a contour pixel at the top
    // of a neighbouring column whose bottom is empty completes a diagonal. Bitwise operators,
    // not && and ||, so the loop has no branches and vectorises.
    const auto fill = [&](int x, bool left_diagonal, bool right_diagonal) {
      return static_cast<std::uint8_t>((top[x] != 0) |
                                       ((bottom[x] != 0) & (left_diagonal | right_diagonal)));
    };
    const auto diagonal_at = [&](int x) { return (top[x] != 0) & (bottom[x] == 0); };
    out[0] = fill(0, false, diagonal_at(1));
    for (int x = 1; x + 1 < w; ++x) out[x] = fill(x, diagonal_at(x - 1), diagonal_at(x + 1));
    out[w - 1] = fill(w - 1, diagonal_at(w - 2), false);
  }
}

Densifier::Densifier(const DensifyParams& params, const SystemSolverFactory& solver,
                     const PhotometricRefinementFactory& refinement)
    : params_((validate(params), params)),
      rows_(pipeline::RowTeam::threads_for(params_.row_threads)) {
  median_columns_.resize(static_cast<std::size_t>(rows_.threads()));
  part_range_.resize(static_cast<std::size_t>(rows_.threads()));
  solver_ = make_system_solver(solver, params_);
  refiner_ = make_photometric_refinement(refinement, &rows_);
  // Grey-level differences are integers: one table instead of two exp() per pixel.
  for (std::size_t diff = 0; diff < color_weight_.size(); ++diff)
    color_weight_[diff] =
        params_.color_sigma > 0
            ? static_cast<float>(std::exp(-static_cast<double>(diff) / params_.color_sigma))
            : 1.0f;
}

void Densifier::build_system(const DensifyInputs& in) {
  const int w = in.sparse.width;
  const int h = in.sparse.height;
  system_.resize(w, h);
  rhs_.resize(w, h);
  // The hole hints are written at the holes only: the matched pixels' entries are never read,
  // but are set once, so no frame reads memory nothing wrote.
  if (hint_.resize(w, h)) hint_.fill(0.0f);
  smooth_strength_.resize(w, h);
  barrier_.resize(w, h);

  // Every step below works row by row, each row from its own inputs and the rows next to it, so
  // the rows are shared among rows_' threads in blocks; a step that reads a neighbouring row of an
  // earlier step waits for that step on every block.
  const bool has_contours = !in.contours.empty();
  // s_p = M_fuse(p) * M_I(p), Eq. 17; M_fuse may come at the internal resolution.
  const bool has_strength = !in.m_fuse.empty() && !in.m_intensity.empty();
  if (has_strength && !(in.m_fuse.width * 2 == w)) {
    fuse_column_.resize(static_cast<std::size_t>(w));
    for (int x = 0; x < w; ++x)
      fuse_column_[static_cast<std::size_t>(x)] =
          kernels::pixel::gate_sample(x, w, in.m_fuse.width);
  }
  rows_.run(h, [&](int, int begin, int end) {
    if (has_contours)
      close_diagonal_gap_rows(in.contours, begin, end, barrier_.view());
    else
      for (int y = begin; y < end; ++y) std::fill(barrier_.row(y), barrier_.row(y) + w, 0);
    for (int y = begin; y < end; ++y) {
      float* s = smooth_strength_.row(y);
      if (!has_strength) {
        std::fill(s, s + w, 0.0f);
        continue;
      }
      const float* fuse = in.m_fuse.row(kernels::pixel::gate_sample(y, h, in.m_fuse.height));
      const float* intensity = in.m_intensity.row(y);
      if (in.m_fuse.width * 2 == w)
        strength_row_half_width(fuse, intensity, w, s);
      else
        for (int x = 0; x < w; ++x)
          s[x] = fuse[fuse_column_[static_cast<std::size_t>(x)]] * intensity[x];
    }
  });

  // Each undirected edge appears twice in Σ_p Σ_{q∈N4(p)} of Eq. 20, hence 2 λ_s.
  const auto edge_scale = static_cast<float>(2.0 * params_.lambda_s);
  const auto floor = static_cast<float>(params_.min_edge_weight);
  const bool has_image = !in.image.empty() && params_.color_sigma > 0;
  const kernels::EdgeRule rule{edge_scale, floor, has_image ? color_weight_.data() : nullptr,
                               kernels::colour_floor_from(color_weight_.data(), floor)};
  // Hint of each hole: the nearest known values to its left and right in its row. Holes next to a
  // jump are mostly occlusions, which belong to the farther surface; but when an image edge (a
  // weak smoothness weight) lies between the hole and one of them only, the hole belongs to the
  // other side's surface. No path starts weaker than edge_scale, so crossing <= edge_scale.
  const float crossing = static_cast<float>(params_.fill_edge_weight) * edge_scale;
  rows_.run(h, [&](int, int begin, int end) {
    for (int y = begin; y < end; ++y) {
      const std::uint8_t* bar = barrier_.row(y);
      const float* str = smooth_strength_.row(y);
      const std::uint8_t* grey = has_image ? in.image.row(y) : nullptr;
      float* ex = system_.wx.row(y);
      kernels::edge_weights_row({bar, bar + 1, str, str + 1, grey, grey ? grey + 1 : nullptr}, rule,
                                w - 1, ex);
      ex[w - 1] = 0.0f;
      float* ey = system_.wy.row(y);
      if (y + 1 == h) {
        std::fill(ey, ey + w, 0.0f);
      } else {
        const std::uint8_t* grey_below = has_image ? in.image.row(y + 1) : nullptr;
        kernels::edge_weights_row(
            {bar, barrier_.row(y + 1), str, smooth_strength_.row(y + 1), grey, grey_below}, rule, w,
            ey);
      }
      kernels::hole_hint_row(in.sparse.row(y), ex, w, crossing, hint_.row(y));
    }
  });

  // The range of the data-term targets: the exact minimiser lies within it.
  float low = std::numeric_limits<float>::infinity(), high = 0.0f;
  if (params_.border_plane_rms > 0) border_plane_hints(in.sparse, low, high);
  // Data (Eq. 13–14) and stability (Eq. 18–19) terms; a tiny pull towards 0 keeps the system
  // definite even for a frame without a single sparse value.
  const auto ld = static_cast<float>(params_.lambda_d);
  const auto ls2 = static_cast<float>(params_.lambda_s2);
  const bool has_previous = !in.previous.empty() && in.previous.same_size(w, h);
  constexpr float kRegulariser = 1e-6f;
  const auto lh = static_cast<float>(params_.lambda_d * params_.background_fill);
  const kernels::DataTermRule terms{kRegulariser, ld, lh > 0.0f ? lh : 0.0f, ls2};
  // The strips a near surface hides from the right camera take the farther side's value; holes
  // where the hint has no ground (the near surface's rim past a strip, and right of a near
  // surface, where no occlusion lies) drop it.
  const kernels::OcclusionRule occlusion{
      static_cast<float>(params_.lambda_d * params_.occlusion_fill), terms.hint_weight};
  std::fill(part_range_.begin(), part_range_.end(), std::array<float, 2>{low, high});
  // The full-size diagonal only where the solver reads it (two images fewer to write).
  const bool diagonal = solver_->needs_diagonal(w);
  rows_.run(h, [&](int part, int begin, int end) {
    std::array<float, 2>& range = part_range_[static_cast<std::size_t>(part)];
    for (int y = begin; y < end; ++y) {
      kernels::data_terms_row(in.sparse.row(y), hint_.row(y),
                              has_previous ? in.previous.row(y) : nullptr, w, terms,
                              system_.data.row(y), rhs_.row(y), &range[0], &range[1]);
      if (occlusion.weight > 0.0f || occlusion.hint_weight > 0.0f)
        kernels::occlusion_fill_row(in.sparse.row(y), hint_.row(y), w, occlusion,
                                    system_.data.row(y), rhs_.row(y));
    }
    if (diagonal) system_.update_diagonal_rows(begin, end);
  });
  system_.has_diagonal = diagonal;
  for (int part = 0; part < rows_.threads(); ++part) {
    low = std::min(low, part_range_[static_cast<std::size_t>(part)][0]);
    high = std::max(high, part_range_[static_cast<std::size_t>(part)][1]);
  }
  data_low_ = high > 0.0f ? low : 0.0f;
  data_high_ = high;
}

void Densifier::border_plane_hints(ImageView<const float> sparse, float& low, float& high) {
  const int w = sparse.width;
  const int h = sparse.height;
  border_first_.resize(static_cast<std::size_t>(h));
  border_sums_.resize(static_cast<std::size_t>(h));
  for (int y = 0; y < h; ++y) {
    const float* s = sparse.row(y);
    int first = 0;
    while (first < w && !kernels::pixel::known_value(s[first])) ++first;
    std::array<double, 6> sums{};
    for (int x = first; x < std::min(w, first + kBorderFitColumns); ++x) {
      if (!kernels::pixel::known_value(s[x])) continue;
      const double d = s[x];
      sums[0] += 1, sums[1] += x, sums[2] += double(x) * x;
      sums[3] += d, sums[4] += x * d, sums[5] += d * d;
    }
    border_first_[static_cast<std::size_t>(y)] = first;
    border_sums_[static_cast<std::size_t>(y)] = sums;
  }
  for (int y = 0; y < h; ++y) {
    const int first = border_first_[static_cast<std::size_t>(y)];
    if (first == 0 || first == w) continue;  // no hole at the border, or no match at all
    // Least squares d = a + b x + c (row - y) over the window's fitted pixels.
    double n = 0, sx = 0, sxx = 0, sr = 0, srr = 0, sxr = 0, sd = 0, sxd = 0, srd = 0, sdd = 0;
    for (int r = std::max(0, y - kBorderFitRows); r <= std::min(h - 1, y + kBorderFitRows); ++r) {
      const std::array<double, 6>& t = border_sums_[static_cast<std::size_t>(r)];
      const double dr = r - y;
      n += t[0], sx += t[1], sxx += t[2], sd += t[3], sxd += t[4], sdd += t[5];
      sr += dr * t[0], srr += dr * dr * t[0], sxr += dr * t[1], srd += dr * t[3];
    }
    if (n < 3.0 * kBorderFitColumns) continue;  // too few matches to trust a plane
    const std::array<double, 9> normal = {n, sx, sr, sx, sxx, sxr, sr, sxr, srr};
    const std::array<double, 3> moments = {sd, sxd, srd};
    std::array<double, 3> plane{};
    if (!solve3(normal, moments, plane)) continue;
    // Residual sum of squares of a least-squares fit: sum d^2 - plane . moments.
    const double rss = sdd - (plane[0] * sd + plane[1] * sxd + plane[2] * srd);
    if (!(rss <= params_.border_plane_rms * params_.border_plane_rms * n)) continue;
    float* hint = hint_.row(y);
    for (int x = 0; x < first; ++x) {
      hint[x] = static_cast<float>(std::max(0.0, plane[0] + plane[1] * x));
      if (hint[x] <= 0.0f) continue;  // no hint
      low = std::min(low, hint[x]);
      high = std::max(high, hint[x]);
    }
  }
}

void smooth_matches(const DensifyParams& params, MatchPlaneSmoother& planes,
                    ImageView<const float> sparse, int match_step, ImageView<float> out) {
  if (params.plane_window > 0) {
    planes.apply(sparse, match_step, params.plane_window / 2, static_cast<float>(params.plane_rms),
                 out);
    return;
  }
  for (int y = 0; y < sparse.height; ++y)
    std::copy(sparse.row(y), sparse.row(y) + sparse.width, out.row(y));
}

const GridSystem& Densifier::last_system() {
  if (!system_.has_diagonal && system_.width() > 0) system_.update_diagonal();
  return system_;
}

bool Densifier::solves_at_half(int width) const {
  return densify::solves_at_half(params_, width);
}

void Densifier::clamp_to_data_range(ImageView<float> map) {
  // No data at all (no match, no hint, no previous frame: a covered or dead camera) is a range
  // of [0, 0]: nothing known, and nothing a refinement may invent.
  const float high = std::max(data_high_, 0.0f);
  const float low = std::min(data_low_, high);
  rows_.run(map.height, [&](int, int begin, int end) {
    for (int y = begin; y < end; ++y) {
      float* row = map.row(y);
      for (int x = 0; x < map.width; ++x) row[x] = std::clamp(row[x], low, high);
    }
  });
}

void Densifier::finish(Image<float>& dense) {
  const int w = solution_.width();
  const int h = solution_.height();
  dense.resize(w, h);
  // An iterative solve stopped early can overshoot in a small region that contours cut off
  // (weakly coupled, so it weighs little in the residual); the exact solution cannot.
  clamp_to_data_range(solution_.view());
  if (params_.median_size == 3) {
    cv::medianBlur(as_mat(solution_.cview()), as_mat(dense.view()), 3);
  } else if (params_.median_size == 5) {
    // Reads two rows on each side: every block was clamped before any is filtered. OpenCV's 5x5
    // median of floats takes 4 ms per 1280x720 map; the kernel about 1.3.
    rows_.run(h, [&](int part, int begin, int end) {
      std::vector<float>& columns = median_columns_[static_cast<std::size_t>(part)];
      columns.resize(static_cast<std::size_t>(kernels::median5_columns(w)));
      for (int y = begin; y < end; ++y) {
        const float* rows[5];
        for (int i = 0; i < 5; ++i) rows[i] = solution_.row(std::clamp(y + i - 2, 0, h - 1));
        kernels::median5_row(rows, w, columns.data(), dense.row(y));
      }
    });
  } else {
    dense.copy_from(solution_.cview());
  }
}

void Densifier::compute(const DensifyInputs& in, Image<float>& dense) {
  const int w = in.sparse.width;
  const int h = in.sparse.height;
  if (in.sparse.empty() || in.sparse.channels != 1)
    throw Error("densify: the sparse disparity must be a non-empty one-channel image");
  const auto check = [&](auto view, const char* name) {
    if (!view.empty() && !view.same_size(w, h))
      throw Error(std::string("densify: ") + name + " is " + std::to_string(view.width) + "x" +
                  std::to_string(view.height) + ", the sparse map " + std::to_string(w) + "x" +
                  std::to_string(h));
  };
  check(in.m_intensity, "m_intensity");
  check(in.planar, "the planar sparse map");
  check(in.contours, "the contour mask");
  check(in.previous, "the previous frame");
  check(in.right, "the right image");
  check(in.photometric_left, "the refinement's left image");

  if (in.match_step < 1)
    throw Error("densify: match_step is " + std::to_string(in.match_step) + ", not >= 1");

  Stopwatch t;
  DensifyInputs inputs = in;
  if (params_.plane_window > 0) smoothed_.resize(w, h);  // ready whenever the step comes back
  if (!in.planar.empty()) {
    inputs.sparse = in.planar;
    if (params_.plane_window > 0) planes_.reserve(w, in.match_step, params_.plane_window / 2);
  } else if (params_.plane_window > 0) {
    smooth_matches(params_, planes_, in.sparse, in.match_step, smoothed_.view());
    inputs.sparse = smoothed_.cview();
  }
  timings_.planes_ms = t.lap_ms();
  build_system(inputs);
  timings_.build_ms = t.lap_ms();

  if (!has_solution_ || !solution_.view().same_size(w, h)) {
    // Cold start: each pixel's sparse value, or for a hole its hint (the value of the row's
    // surface it is filled towards; 0 where a row has none), which is already near the solution.
    solution_.resize(w, h);
    for (int y = 0; y < h; ++y) {
      const float* s = inputs.sparse.row(y);
      const float* hint = hint_.row(y);
      float* x0 = solution_.row(y);
      for (int x = 0; x < w; ++x) x0[x] = kernels::pixel::known_value(s[x]) ? s[x] : hint[x];
    }
  }
  report_ = solver_->solve(system_, rhs_.cview(), solution_.view());
  // Disparities past any image's (1e20 and up overflow the solver's float sums) or a non-finite
  // contour strength leave no finite solution: an error, never a "dense" map of NaN, and the next
  // frame starts cold rather than from it.
  has_solution_ = std::isfinite(report_.final_residual);
  if (!has_solution_)
    throw Error(
        "densify: the solve found no finite solution (a sparse or previous disparity far past "
        "any image's, or a contour strength that is not finite)");
  timings_.solve_ms = t.lap_ms();
  finish(dense);
  timings_.median_ms = t.lap_ms();
  if (refines(w, h) && !in.right.empty() && !in.image.empty()) {
    refiner_->refine(in.photometric_left.empty() ? in.image : in.photometric_left, in.right,
                     params_.photometric, dense.view());
    // Its linearised steps can overshoot where the images say little (flat ground, a small
    // alpha): the refined map keeps to the data's range, as the solution does.
    clamp_to_data_range(dense.view());
  }
  timings_.refine_ms = t.lap_ms();
  timings_.total_ms = t.total_ms();
}

}  // namespace dco::densify
