#pragma once

#include <memory>

#include "dco/core/image.hpp"
#include "dco/core/stopwatch.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"

// The flow cue of the contour stage (§5.1–5.2) on the CPU: DIS optical flow from the centre frame
// to each neighbour, the amplitude of each field, fusion by the projection test, box filter and
// normalisation. Buffers are sized on the first frame of a size and reused. OpenCV stays out of
// this header, so the GPU stages (compiled by nvcc) can hold one.
namespace dco::contour {

class FlowCue {
 public:
  explicit FlowCue(const ContourParams& params);
  ~FlowCue();
  FlowCue(const FlowCue&) = delete;
  FlowCue& operator=(const FlowCue&) = delete;

  // Throws dco::Error when the internal frame is too small for the DIS preset.
  void check_size(ImageView<const std::uint8_t> centre) const;
  // M_fuse from the flow into `dst` (the centre's size); fills the flow steps of `timings`.
  void compute(const ContourInputs& in, ImageView<float> dst, ContourTimings& timings,
               Stopwatch& t);
  // The same for a window alone (ContourExtractor::flow_cue): checks it (check_flow_window, the
  // frame size), sizes `out`, and gives every step's time and their total in `timings`.
  void compute_alone(const ContourInputs& in, Image<float>& out, ContourTimings& timings);
  // With reuse_flow and lookahead 1: the steps of the next call's field to the previous frame
  // that this call's results allow (this call's field turned round, its speed, amplitude and
  // projection contrast), done now. The next call takes them if its window is the one they were
  // made for, else makes its own. Returns whether there were any. Never concurrently with
  // compute().
  bool prepare_next();

 private:
  struct State;
  std::unique_ptr<State> s_;
};

// Throws dco::Error when, with use_flow on, internal frames of this size are too small for the DIS
// preset (FlowCue::check_size without a FlowCue).
void check_flow_size(const ContourParams& params, int width, int height);
// Throws dco::Error unless the inputs are consistent with each other and with `params` (see
// ContourInputs).
void check_contour_input(const ContourParams& params, const ContourInputs& in);
// Throws dco::Error unless `in` is a window the flow cue can be made of alone
// (ContourExtractor::flow_cue): use_flow on, a grey centre and both neighbours of its size.
void check_flow_window(const ContourParams& params, const ContourInputs& in);

}  // namespace dco::contour
