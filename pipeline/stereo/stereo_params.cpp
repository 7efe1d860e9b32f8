#include "dco/pipeline/stereo/stereo_params.hpp"

#include <string>

#include "dco/core/config.hpp"
#include "dco/core/error.hpp"

namespace dco::stereo {
namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw Error("stereo parameters: " + what);
}

}  // namespace

void register_params(ConfigSchema& s, StereoParams& p) {
  s.add("stereo.max_disparity", &p.max_disparity, 1, kMaxDisparityLimit,
        "largest disparity searched, pixels of the input image (matching at half size searches "
        "half of it, rounded down: 81 searches as 80)");
  s.add("stereo.internal_resolution", &p.internal_resolution, {"auto", "full", "half"},
        "auto = half size when the input is wider than 640 px");
  s.add("stereo.search_range", &p.search_range, {"auto", "full", "guided", "temporal"},
        "guided = each tile of 128 columns of a row searches only the disparities a half-size "
        "pass finds near it; temporal = those near the previous frame's map and a quarter-size "
        "pass (a sequence's first frame: guided); auto = temporal on the CPU when over 64 "
        "internal disparities, full on CUDA");
  s.add("stereo.row_threads", &p.row_threads, 0, 16,
        "threads sharing the CPU stage's rows (input preparation, census, the disparity search in "
        "bands, boundary refinement), the stage's own included (0 = auto: 1 below 4 usable "
        "CPUs, else half of them, at most 4)");
  s.add("stereo.use_color", &p.use_color, "AD cost and arms on colour when the input has it");
  s.add("stereo.exposure_balance", &p.exposure_balance,
        "map the right camera's levels onto the left's before matching (a gain and offset per "
        "channel, fitted to the matches)");
  s.add("stereo.exposure_balance_levels", &p.exposure_balance_levels, 1, 255,
        "a new fit replaces the map (or the lens fall-off) when it moves some grey level by this "
        "many or more");
  s.add("stereo.lens_falloff", &p.lens_falloff,
        "correct both images for a brightness fall-off towards the corners shared by the two "
        "lenses (1 − k r², fitted to the matches) before matching");
  s.add("stereo.vertical_alignment", &p.vertical_alignment,
        "move the right image by the vertical offset between the cameras' rows and turn it back "
        "by their roll (both fitted to the matches) before matching");
  s.add("stereo.lambda_ad", &p.lambda_ad, 0.01, 1000.0, "λ_AD of Eq. 1");
  s.add("stereo.lambda_census", &p.lambda_census, 0.01, 1000.0,
        "λ_census of Eq. 1 (the paper: 40)");
  s.add("stereo.gamma_l", &p.gamma_l, 0.0, 100.0, "γ_L of Eq. 1 (edge control)");
  s.add("stereo.epsilon", &p.epsilon, 0.001, 100.0, "ε of Eq. 1 (correction)");
  s.add("stereo.census_width", &p.census_width, 1, 63,
        "census window width, odd; the window holds 2..65 pixels (a 64-bit signature)");
  s.add("stereo.census_height", &p.census_height, 1, 63,
        "census window height, odd; width x height within 2..65");
  s.add("stereo.arm_max", &p.arm_max, 2, 255,
        "longest cross arm L1, input pixels (halved, rounded down, at half size); at least "
        "arm_short");
  s.add("stereo.arm_short", &p.arm_short, 0, 255, "arm length L2 beyond which tau2 applies");
  s.add("stereo.tau1", &p.tau1, 1, 255, "colour threshold of the arms");
  s.add("stereo.tau2", &p.tau2, 1, 255, "stricter colour threshold beyond arm_short; at most tau1");
  s.add("stereo.smooth_arms", &p.smooth_arms,
        "median-smooth the arm lengths across the arm direction");
  s.add("stereo.aggregation_passes", &p.aggregation_passes, 1, 8,
        "alternating cross-aggregation passes (Eq. 2)");
  s.add("stereo.lr_max_diff", &p.lr_max_diff, 0, 16, "left-right check tolerance, internal px");
  s.add("stereo.uniqueness", &p.uniqueness, 0.0, 0.9,
        "best cost must be this fraction below the next non-adjacent one (0 = off)");
  s.add("stereo.vote_iterations", &p.vote_iterations, 0, 16, "histogram-vote iterations (Eq. 4)");
  s.add("stereo.vote_min_count", &p.vote_min_count, 1, 100000,
        "reliable pixels a region needs for its vote to count (with vote_iterations > 0, as the "
        "three below)");
  s.add("stereo.vote_min_ratio", &p.vote_min_ratio, 0.0, 1.0,
        "share of the votes the winning disparity needs");
  s.add("stereo.vote_tolerance", &p.vote_tolerance, 0, 16,
        "a pixel within this of the winning disparity keeps its own value");
  s.add("stereo.vote_fill", &p.vote_fill, "votes also fill pixels that failed the checks");
  s.add("stereo.max_neighbour_jump", &p.max_neighbour_jump, -1, 64,
        "drop pixels behind a nearer neighbour by more than this (internal px, -1 = off)");
  s.add("stereo.speckle_size", &p.speckle_size, 0, 100000,
        "drop islands of at most this many internal pixels after the checks (0 = off)");
  s.add("stereo.speckle_range", &p.speckle_range, 0, 64,
        "largest step between neighbours of one island, internal px (the neighbour-jump check "
        "runs first: values of max_neighbour_jump and above change nothing)");
  s.add("stereo.subpixel", &p.subpixel,
        "equiangular (V) fit of the winning cost and its neighbours");
  s.add("stereo.boundary_radius", &p.boundary_radius, 0, 15,
        "half size of the input-resolution window that picks the side of a depth edge when "
        "matching at half size, input px (0 = off)");
  s.add("stereo.boundary_ratio", &p.boundary_ratio, 0.01, 1.0,
        "the side picked must cost at most this fraction of the other side");
  s.add("stereo.boundary_hole_reach", &p.boundary_hole_reach, 0, 16,
        "how far along its row a pixel without a value and no depth edge within 2 internal px "
        "looks for the two sides, internal px (2 or less = not at all); like boundary_ratio and "
        "boundary_hole_ratio, only when matching at half size and with boundary_radius > 0");
  s.add("stereo.boundary_hole_ratio", &p.boundary_hole_ratio, 0.01, 1.0,
        "the side picked for such a pixel must cost at most this fraction of the other side");
}

void validate(const StereoParams& p) {
  require(p.max_disparity >= 1 && p.max_disparity <= kMaxDisparityLimit,
          "max_disparity must be in 1.." + std::to_string(kMaxDisparityLimit) + ", not " +
              std::to_string(p.max_disparity));
  require(p.internal_resolution == "auto" || p.internal_resolution == "full" ||
              p.internal_resolution == "half",
          "internal_resolution must be auto, full or half, not '" + p.internal_resolution + "'");
  require(p.search_range == "auto" || p.search_range == "full" || p.search_range == "guided" ||
              p.search_range == "temporal",
          "search_range must be auto, full, guided or temporal, not '" + p.search_range + "'");
  require(p.row_threads >= 0 && p.row_threads <= 16,
          "row_threads must be in 0..16 (0 = auto), not " + std::to_string(p.row_threads));
  require(p.lambda_ad > 0 && p.lambda_census > 0, "lambda_ad and lambda_census must be positive");
  require(p.gamma_l >= 0 && p.epsilon > 0, "gamma_l must be >= 0 and epsilon > 0");
  require(p.census_width % 2 == 1 && p.census_height % 2 == 1 && p.census_width > 0 &&
              p.census_height > 0,
          "census window sides must be odd");
  require(p.census_width * p.census_height - 1 <= 64 && p.census_width * p.census_height > 1,
          "census window must hold 2..65 pixels (a 64-bit descriptor)");
  require(p.arm_max >= 2 && p.arm_max <= 255, "arm_max must be in 2..255");
  require(p.arm_short >= 0 && p.arm_short <= p.arm_max, "arm_short must be in 0..arm_max");
  require(p.tau1 <= 255 && p.tau2 >= 1 && p.tau2 <= p.tau1, "need 1 <= tau2 <= tau1 <= 255");
  require(p.aggregation_passes >= 1 && p.aggregation_passes <= 8,
          "aggregation_passes must be in 1..8");
  // The ranges of the config schema: the kernels add to these in 32-bit lanes.
  require(p.lr_max_diff >= 0 && p.lr_max_diff <= 16, "lr_max_diff must be in 0..16");
  require(p.uniqueness >= 0 && p.uniqueness < 1, "uniqueness must be in [0, 1)");
  require(p.vote_iterations >= 0 && p.vote_iterations <= 16 && p.vote_min_count >= 1 &&
              p.vote_min_count <= 100000 && p.vote_tolerance >= 0 && p.vote_tolerance <= 16,
          "vote_iterations and vote_tolerance must be in 0..16 and vote_min_count in 1..100000");
  require(p.max_neighbour_jump >= -1 && p.max_neighbour_jump <= 64,
          "max_neighbour_jump must be in -1..64");
  require(p.speckle_size >= 0 && p.speckle_size <= 100000 && p.speckle_range >= 0 &&
              p.speckle_range <= 64,
          "speckle_size must be in 0..100000 and speckle_range in 0..64");
  require(p.vote_min_ratio >= 0 && p.vote_min_ratio <= 1, "vote_min_ratio must be in [0, 1]");
  require(p.boundary_radius >= 0 && p.boundary_radius <= 15, "boundary_radius must be in 0..15");
  require(p.boundary_ratio > 0 && p.boundary_ratio <= 1, "boundary_ratio must be in (0, 1]");
  require(p.boundary_hole_reach >= 0 && p.boundary_hole_reach <= 16,
          "boundary_hole_reach must be in 0..16");
  require(p.boundary_hole_ratio > 0 && p.boundary_hole_ratio <= 1,
          "boundary_hole_ratio must be in (0, 1]");
}

}  // namespace dco::stereo
