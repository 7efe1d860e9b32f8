#include <sstream>
#include <string>

#include "dco/core/config.hpp"
#include "dco/core/error.hpp"
#include "dco/core/usable_cpus.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"

namespace dco::contour {
namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw Error("contour parameters: " + what);
}

}  // namespace

void register_params(ConfigSchema& s, ContourParams& p) {
  s.add("contour.use_flow", &p.use_flow, "optical-flow cue from the neighbouring frames (§5.1)");
  s.add("contour.dis_preset", &p.dis_preset, {"ultrafast", "fast", "medium"},
        "cv::DISOpticalFlow preset");
  s.add("contour.parallel_flow", &p.parallel_flow, {"auto", "on", "off"},
        "the two flow fields on two threads at once (same output); auto = on with 4 or more "
        "usable CPUs; with reuse_flow only for the frames whose field cannot be reused (a "
        "sequence's first, one after a dropped frame)");
  s.add("contour.reuse_flow", &p.reuse_flow,
        "one DIS run per frame instead of two: with lookahead 0 the field t -> t-2 is the fresh "
        "t -> t-1 carried on by the previous frame's t-1 -> t-2, with lookahead 1 the field "
        "t -> t-1 is the previous frame's t-1 -> t inverted");
  s.add("contour.row_threads", &p.row_threads, 0, 16,
        "threads sharing the flow cue's row-wise steps after DIS, the stage's own included (0 = "
        "auto: 1 below 4 usable CPUs, else half of them, at most 4)");
  s.add("contour.projection_distance", &p.projection_distance, 1, 64,
        "|p p0| = |p p1| of the projection test (Eq. 9), internal px");
  s.add("contour.box_size", &p.box_size, 1, 255,
        "box filter widening the depth-contour filter (§5.2), odd, internal px");
  s.add("contour.flow_floor", &p.flow_floor, 0.0, 1000.0,
        "the flow cue is divided by max(its maximum, this); internal px of flow change per px; 0 "
        "or at least 1e-06");
  s.add("contour.use_stereo", &p.use_stereo, "disparity-jump cue from the stereo map");
  s.add("contour.stereo_jump", &p.stereo_jump, 0.001, 1000.0,
        "disparity jump (internal px) that counts as a full-strength depth edge");
  s.add("contour.lookahead", &p.lookahead, 0, 1,
        "0 = causal window (t-2, t-1, t); 1 = (t-1, t, t+1), output one frame late");
  s.add("contour.t_high", &p.t_high, 0.0, 1.0, "T_high of the dual threshold (§5.3.1)");
  s.add("contour.t_low", &p.t_low, 0.0, 1.0,
        "T_low of the dual threshold (§5.3.1); at most t_high");
  s.add("contour.t_depth", &p.t_depth, 0.0, 1.0,
        "T_depth: pixels whose depth-contour filter is below it are no contour (§5.3.2)");
}

bool parallel_flow_fields(const ContourParams& p) {
  return p.use_flow &&
         (p.parallel_flow == "on" || (p.parallel_flow == "auto" && usable_cpus() >= 4));
}

void validate(const ContourParams& p) {
  require(p.dis_preset == "ultrafast" || p.dis_preset == "fast" || p.dis_preset == "medium",
          "dis_preset must be ultrafast, fast or medium, not '" + p.dis_preset + "'");
  require(p.parallel_flow == "auto" || p.parallel_flow == "on" || p.parallel_flow == "off",
          "parallel_flow must be auto, on or off, not '" + p.parallel_flow + "'");
  require(p.row_threads >= 0 && p.row_threads <= 16,
          "row_threads must be in 0..16 (0 = auto), not " + std::to_string(p.row_threads));
  require(p.projection_distance >= 1 && p.projection_distance <= 64,
          "projection_distance must be in 1..64, not " + std::to_string(p.projection_distance));
  require(p.box_size >= 1 && p.box_size <= 255 && p.box_size % 2 == 1,
          "box_size must be odd and in 1..255, not " + std::to_string(p.box_size));
  // A floor so small that its reciprocal overflows a float (a subnormal) made a still frame's
  // flow cue 0 * inf = NaN everywhere, which the densifier then cannot solve.
  if (!(p.flow_floor == 0 || p.flow_floor >= ContourParams::kMinFlowFloor)) {
    std::ostringstream what;
    what << "flow_floor must be 0 or at least " << ContourParams::kMinFlowFloor << ", not "
         << p.flow_floor;
    require(false, what.str());
  }
  require(p.stereo_jump > 0, "stereo_jump must be positive, not " + std::to_string(p.stereo_jump));
  require(p.lookahead == 0 || p.lookahead == 1,
          "lookahead must be 0 or 1, not " + std::to_string(p.lookahead));
  require(p.t_low >= 0 && p.t_low <= 1, "t_low must be in [0, 1], not " + std::to_string(p.t_low));
  require(p.t_high >= 0 && p.t_high <= 1,
          "t_high must be in [0, 1], not " + std::to_string(p.t_high));
  require(p.t_low <= p.t_high, "t_low (" + std::to_string(p.t_low) + ") must not exceed t_high (" +
                                   std::to_string(p.t_high) + ")");
  require(p.t_depth >= 0 && p.t_depth <= 1,
          "t_depth must be in [0, 1], not " + std::to_string(p.t_depth));
}

}  // namespace dco::contour
