#pragma once

#include <array>
#include <cstdint>
#include <memory>

#include "dco/core/image.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"
#include "dco/pipeline/densify/densifier.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"

namespace dco {
class ConfigSchema;
}

namespace dco::pipeline {

struct PipelineParams {
  stereo::StereoParams stereo;
  contour::ContourParams contour;
  densify::DensifyParams densify;
};

// Registers every stage's parameters ("stereo.*", "contour.*", "densify.*").
void register_params(ConfigSchema& schema, PipelineParams& params);
void validate(const PipelineParams& params);  // throws dco::Error

// Everything the pipeline knows about one frame once it is done.
struct DepthResult {
  int index = -1;
  Image<std::uint8_t> image;     // grey left image, input resolution
  Image<float> sparse;           // input px, +inf where the stereo checks left no value
  Image<float> dense;            // input px, every pixel set
  Image<float> m_fuse;           // internal resolution, [0, 1]
  Image<float> m_intensity;      // input resolution, [0, 1]
  Image<std::uint8_t> contours;  // input resolution, 255 on depth contours
  stereo::StereoTimings stereo_timings;
  contour::ContourTimings contour_timings;
  densify::DensifyTimings densify_timings;
  densify::SolverReport solver;
  bool flow_cue = false;  // the frame had both flow neighbours
};

// Stereo -> contour -> densify, one frame after the other, on the calling thread (the offline
// tools and the tests; the real-time runtime runs the same stages on their own threads).
// The contour window follows contour.lookahead: with 1 it is centred on frame t, so t's result
// comes out when t+1 is pushed and `finish` releases the last one; with 0 it is causal and every
// push returns its own frame. The densifier's stability term and warm start use the previous
// frame's dense map.
class DepthPipeline {
 public:
  explicit DepthPipeline(const PipelineParams& params);

  // left/right: a rectified pair (8-bit, 1 or 3 channels). Returns true when `out` was filled.
  bool push(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
            DepthResult& out);
  // Releases a frame still waiting for its successor (lookahead 1). Returns true if it did.
  bool finish(DepthResult& out);
  // Starts a new, unrelated sequence.
  void reset();

  const PipelineParams& params() const { return params_; }

 private:
  struct Slot {
    int index = -1;
    Image<std::uint8_t> image;   // grey, input resolution
    Image<std::uint8_t> small;   // grey, internal resolution
    Image<float> raw_disparity;  // internal px, every pixel
    Image<float> sparse;         // input px
    stereo::StereoTimings stereo_timings;
  };
  Slot& slot_of(int index) { return slots_[static_cast<std::size_t>(index) % slots_.size()]; }
  void finish_frame(int centre, int neighbour_a, int neighbour_b, DepthResult& out);

  PipelineParams params_;
  std::unique_ptr<stereo::StereoMatcher> stereo_;
  std::unique_ptr<contour::ContourExtractor> contour_;
  densify::Densifier densifier_;
  std::array<Slot, 3> slots_;
  int next_index_ = 0;   // index of the next pushed frame
  int next_output_ = 0;  // index of the next frame to finish
};

}  // namespace dco::pipeline
