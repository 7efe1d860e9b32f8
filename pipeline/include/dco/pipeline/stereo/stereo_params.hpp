#pragma once

#include <string>

namespace dco {
class ConfigSchema;
}

namespace dco::stereo {

// The largest stereo.max_disparity the stage takes (input pixels).
inline constexpr int kMaxDisparityLimit = 1024;

// Parameters of the sparse AD-census stage. Defaults follow the paper's §7.2 for the cost
// (λ_AD, λ_census, γ_L, ε); the cross-window and voting thresholds follow Mei et al. 2011, which
// the paper's two-stage design builds on. Lengths are in pixels of the internal resolution.
struct StereoParams {
  // Largest disparity searched, in pixels of the input image (the search is 0..max_disparity).
  int max_disparity = 64;
  // "auto": half width and height when the input is wider than 640 px, else full; "full"; "half".
  std::string internal_resolution = "auto";
  bool use_color = true;  // AD and arms on colour when the input has three channels
  // Map the right camera's grey levels onto the left's before matching (exposure_balance.hpp):
  // a gain and offset per channel, fitted to the matches of the frames before; a new fit is
  // taken when it moves some level by exposure_balance_levels or more.
  bool exposure_balance = true;
  int exposure_balance_levels = 6;
  // Correct both images for a lens fall-off towards the corners shared by the two cameras
  // (lens_falloff.hpp), fitted to the matches of the frames before; a new fit is taken when it
  // moves some level by exposure_balance_levels or more.
  bool lens_falloff = true;
  // Move the right image by the vertical offset between the cameras' rows, fitted to the matches
  // of the frames before (vertical_alignment.hpp): what a drifted calibration leaves.
  bool vertical_alignment = true;
  // Which disparities each row searches. "full": all of 0..max. "guided": a pass at half the
  // internal size first, then each internal row searches only the 16-disparity batches that its
  // map reaches near the row (search_guide.hpp); images too small for that pass search all.
  // "temporal": after a sequence's first frame (guided), the batches near the previous frame's
  // map and near a pass at a quarter of the internal size, which finds what came into view (a
  // thin object on its own takes a frame or two longer). "auto": temporal on the CPU backend
  // when the search spans more than four batches, full on CUDA, whose cost volume is not the
  // bottleneck.
  std::string search_range = "auto";
  // Threads that share the CPU stage's rows (the input downscaled, grey and packed, the census,
  // the disparity search in bands, the boundary refinement), the stage's own included
  // (RowTeam::threads_for: 0 = auto, 1 below 4 usable CPUs). Same output however many.
  int row_threads = 0;

  // Matching cost, Eq. 1. The paper's λ_census is 40; 30 gives a denser and more exact sparse map
  // and dense map on the shared scenes (bench/RESULTS.md, "Matching cost and support windows
  // re-measured").
  double lambda_ad = 10.0;
  double lambda_census = 30.0;
  double gamma_l = 1.0;
  double epsilon = 0.8;
  int census_width = 9;   // odd; census_width * census_height - 1 <= 64
  int census_height = 7;  // odd

  // Adaptive cross-support windows (§4.1): arms grow while the colour stays within tau1 of the
  // anchor (and of the previous pixel); beyond arm_short they need the stricter tau2. Lengths are
  // in input pixels (divided by the internal downscale), so a window covers the same part of
  // the scene at any internal resolution. The stricter part starts at 10 px with tau2 4 (the
  // AD-census values 17 and 6 let windows run further across faint edges; same section).
  int arm_max = 34;
  int arm_short = 10;
  int tau1 = 20;
  int tau2 = 4;
  bool smooth_arms = true;  // 3-tap median of the arm lengths across the arm direction

  // Cost aggregation over the support region, Eq. 2: alternating horizontal-first and
  // vertical-first passes.
  int aggregation_passes = 1;

  // Checks that decide which pixels the sparse map keeps.
  int lr_max_diff = 1;         // left-right consistency, internal pixels
  double uniqueness = 0.15;    // best cost must beat the best non-adjacent cost by this fraction
  int max_neighbour_jump = 1;  // drop pixels behind a larger jump (internal px; -1 off)
  // Drop islands of at most speckle_size pixels (internal) whose neighbours differ by at most
  // speckle_range: isolated wrong matches that survived the checks (0 = off).
  int speckle_size = 4;
  int speckle_range = 1;

  // Iterated histogram vote, Eq. 4, among reliable pixels of the support region.
  int vote_iterations = 0;
  int vote_min_count = 20;      // support needed for a vote to decide
  double vote_min_ratio = 0.4;  // share of the support the winning disparity needs
  int vote_tolerance = 1;       // a pixel this close to the winner keeps its own value
  bool vote_fill = false;       // votes also give values to pixels that failed the checks

  bool subpixel = true;

  // Boundary refinement when matching at half size (kernels/boundary_pixel.hpp): around depth
  // edges, each input pixel takes the far or the near side's value by a grey-level match over a
  // (2 * boundary_radius + 1)^2 window at input resolution (input px; 0 = off). The winning
  // side's cost must be at most boundary_ratio of the other's, else the pixel gets no value.
  int boundary_radius = 3;
  double boundary_ratio = 0.4;
  // Input pixels without a value and no depth edge within 2 internal px look for the two sides
  // up to boundary_hole_reach internal px along their row, and a side must then cost at most
  // boundary_hole_ratio of the other's (2 or less = no such search).
  int boundary_hole_reach = 4;
  double boundary_hole_ratio = 0.3;
};

// Registers every field under "stereo.<name>" with its valid range.
void register_params(ConfigSchema& schema, StereoParams& params);

// Throws dco::Error naming the first invalid field.
void validate(const StereoParams& params);

}  // namespace dco::stereo
