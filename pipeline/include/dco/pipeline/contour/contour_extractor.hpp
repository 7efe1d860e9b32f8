#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "dco/core/image.hpp"

namespace dco {
class ConfigSchema;
}

namespace dco::contour {

// Parameters of the depth-contour stage (§5). Thresholds are on values normalised to [0, 1].
struct ContourParams {
  // Flow cue (§5.1–5.2): DIS optical flow from the centre frame to its two neighbours.
  bool use_flow = true;
  std::string dis_preset = "fast";  // ultrafast | fast | medium (cv::DISOpticalFlow presets)
  int projection_distance = 2;      // |p p0| = |p p1| of Eq. 9, internal pixels
  int box_size = 9;                 // box filter that widens M_fuse (§5.2), internal pixels
  // The two flow fields (t -> t-1, t -> t+1) on two threads at once: "on", "off", or "auto" = on
  // where at least four CPUs are usable. Same output either way.
  std::string parallel_flow = "auto";
  // DIS runs once per frame instead of twice where the previous frame's window shares two images
  // with this one: with lookahead 1 frame t's field t -> t-1 is the previous frame's field
  // t-1 -> t inverted (invert_flow); with lookahead 0 its field t -> t-2 is the fresh t -> t-1
  // followed by the previous frame's t-1 -> t-2 (compose_flow).
  bool reuse_flow = true;
  // Threads that share the flow cue's row-wise steps after DIS (amplitudes, projection test,
  // fusion, box filter, normalisation), the stage's own included (RowTeam::threads_for: 0 =
  // auto, 1 below 4 usable CPUs). Same output however many.
  int row_threads = 0;
  // The flow cue is divided by max(its maximum, flow_floor) (the normalisation of §5.3.2). With
  // the paper's plain maximum a still scene's flow noise (|flow| of a few hundredths of a pixel)
  // is stretched to full strength and opens the gate everywhere; motion of about 1 internal px
  // per frame already reaches the floor. Units: flow change (px) per px, after the box filter.
  double flow_floor = 0.1;  // 0 or at least kMinFlowFloor
  static constexpr double kMinFlowFloor = 1e-6;
  // Stereo cue: jumps of the stereo disparity (a stereo pair is a horizontal motion), so a static
  // scene still has depth contours.
  bool use_stereo = true;
  double stereo_jump = 2.0;  // disparity jump (internal px) that counts as a full-strength edge
  // Window: 0 = causal (t-2, t-1, t); 1 = (t-1, t, t+1), output one frame late. The causal window
  // is the default: on the synthetic sequences and the Karlsruhe clip it scores as the centred
  // one, and a headset needs the frame interval it saves (bench/RESULTS.md).
  int lookahead = 0;
  // Gated Canny (§5.3).
  double t_high = 0.06;
  double t_low = 0.03;
  double t_depth = 0.03;
};

void register_params(ConfigSchema& schema, ContourParams& params);
void validate(const ContourParams& params);  // throws dco::Error

// contour.parallel_flow on this machine: true when the flow cue computes its two fields on two
// threads (with use_flow, "on", or "auto" with at least four usable CPUs). Without the flow no
// worker thread is started.
bool parallel_flow_fields(const ContourParams& params);

// Inputs for frame t. Neighbour images may be empty (a single frame, a window not yet full):
// without both of them the flow cue is zero and only the stereo cue remains. compute() throws
// dco::Error on inconsistent sizes and on internal frames too small for the DIS preset.
struct ContourInputs {
  ImageView<const std::uint8_t> image;        // grey frame t at input resolution (Canny)
  ImageView<const std::uint8_t> centre;       // grey frame t at internal resolution
  ImageView<const std::uint8_t> neighbour_a;  // t-1 (lookahead 1) or t-1 (lookahead 0)
  ImageView<const std::uint8_t> neighbour_b;  // t+1 (lookahead 1) or t-2 (lookahead 0)
  ImageView<const float> disparity;           // internal px, dense (e.g. the WTA map); optional
  // The image's M_I and gradient directions (intensity_gradients) when the caller made them,
  // both or neither: then compute() reads them and leaves out.m_intensity alone, which is the
  // caller's to carry (so another thread can take that step off the stage).
  ImageView<const float> m_intensity;
  ImageView<const std::uint8_t> direction;
  // The stereo cue of `disparity` (stereo_cue with stereo_jump and box_size) when the caller made
  // it: then compute() takes it instead (with use_stereo).
  ImageView<const float> stereo_cue;
  // The image's Canny classes (canny_classes of its M_I and directions with t_low and t_high)
  // when the caller made them: then compute() gates those (gated_canny_classified) instead of
  // classifying the gradients. A stage may also ignore them: the edges are the same bytes.
  ImageView<const std::uint8_t> canny_classes;
  // The flow cue of this window (ContourExtractor::flow_cue) when the caller made it, e.g. while
  // the frame's disparity was still being computed: then compute() takes it instead of running
  // the flow. Only with use_flow and both neighbours.
  ImageView<const float> flow_cue;
};

// Milliseconds per step of the last compute(), named after Table 2: flow = both fields (DIS or
// reused), amplitude = Eq. 6-8 on both, fusion = projection test and Eq. 12, box and normalise =
// the flow cue's, stereo_cue = disparity jumps with their box filter and the max with the flow cue,
// gaussian = the 5x5 blur and the Sobel gradients (0 when the inputs carry them), canny =
// suppression, gate and hysteresis (the gate and hysteresis when the inputs carry the classes).
struct ContourTimings {
  double flow_ms = 0, amplitude_ms = 0, fusion_ms = 0, box_ms = 0, normalise_ms = 0,
         stereo_cue_ms = 0, gaussian_ms = 0, canny_ms = 0, total_ms = 0;
  int dis_fields = 0;  // DIS runs of the call: 2, 1 with a reused field, 0 without the flow cue
};

// Outputs, resized on first use:
//  m_fuse      internal resolution, [0, 1]: how likely a depth edge is near each pixel, the larger
//              of the flow and stereo cues (all 0 when neither is available);
//  m_intensity input resolution, [0, 1]: Sobel magnitude of the blurred image divided by the
//              largest one 8-bit input allows (M_I of Eq. 17), a fixed scale on every frame
//              (left alone when the inputs carry it);
//  contours    input resolution, 255 on a depth contour (B_dp of Eq. 16), else 0.
struct ContourOutputs {
  Image<float> m_fuse;
  Image<float> m_intensity;
  Image<std::uint8_t> contours;
};

class ContourExtractor {
 public:
  virtual ~ContourExtractor() = default;
  virtual void compute(const ContourInputs& in, ContourOutputs& out) = 0;
  virtual const ContourTimings& last_timings() const = 0;
  // Work of the next compute() that the last one's results allow, done now, e.g. by a thread
  // that would otherwise wait; never concurrently with compute(). The next compute() takes it
  // only if its window is the one it was made for. Returns whether there was any (the CPU stage:
  // the last field to the next frame turned round, with its speed, amplitude and projection
  // contrast, under reuse_flow with lookahead 1).
  virtual bool prepare_next() { return false; }
  // The flow cue of the window of `in` alone, as compute() makes it (the centre and both
  // neighbours are read, nothing else): into `out`, sized here, with the times of its steps
  // (flow, amplitude, fusion, box, normalise, dis_fields) in `timings`. It needs no disparity, so
  // a caller can run it while the centre's stereo runs and hand the result to compute() as
  // ContourInputs::flow_cue; never concurrently with compute() or prepare_next(). Throws
  // dco::Error as compute() does, and when use_flow is off or a neighbour is missing.
  virtual void flow_cue(const ContourInputs& in, Image<float>& out, ContourTimings& timings) = 0;
};

std::unique_ptr<ContourExtractor> make_cpu_contour_extractor(const ContourParams& params);

// Makes the stage of a backend (CPU, CUDA); an empty factory means the CPU one.
using ContourExtractorFactory =
    std::function<std::unique_ptr<ContourExtractor>(const ContourParams&)>;
std::unique_ptr<ContourExtractor> make_contour_extractor(const ContourExtractorFactory& factory,
                                                         const ContourParams& params);

}  // namespace dco::contour
