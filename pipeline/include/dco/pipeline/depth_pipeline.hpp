#pragma once

#include <array>
#include <cstdint>
#include <memory>

#include "dco/core/image.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"
#include "dco/pipeline/contour/gated_canny.hpp"
#include "dco/pipeline/contour/stereo_cue.hpp"
#include "dco/pipeline/densify/densifier.hpp"
#include "dco/pipeline/stereo/lens_falloff.hpp"
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
// Throws dco::Error when frames of this size cannot go through the stages under these params
// (the census window, max disparity and DIS limits, which depend on the size): a source's size
// is known before its first frame, so a configuration is refused before it runs.
void check_frame_size(const PipelineParams& params, int width, int height);

// A frame's number in its sequence. 64 bits: a service that runs for years at any frame rate
// never wraps it.
using FrameIndex = std::int64_t;

// Everything the pipeline knows about one frame once it is done.
struct DepthResult {
  FrameIndex index = -1;
  Image<std::uint8_t> image;  // grey left image, input resolution
  // Grey right image, input resolution, on the left's rows and levels (the stereo stage's camera
  // correction); empty unless the densifier's photometric refinement reads it.
  Image<std::uint8_t> right;
  // Grey left image through the stereo stage's lens fall-off correction, as the refinement
  // compares it with `right`; empty where the stage has no such correction (then `image`).
  Image<std::uint8_t> photometric_left;
  Image<float> sparse;              // input px, +inf where the stereo checks left no value
  Image<float> planar;              // sparse after densify::smooth_matches, when planes_done
  bool planes_done = false;         // the stereo thread ran smooth_matches (else the densify step)
  bool early_contour_done = false;  // the stereo thread made m_intensity (else the contour step)
  Image<float> dense;               // input px, every pixel set
  Image<float> m_fuse;              // internal resolution, [0, 1]
  Image<float> m_intensity;         // input resolution, [0, 1]
  Image<std::uint8_t> contours;     // input resolution, 255 on depth contours
  stereo::StereoTimings stereo_timings;
  stereo::CameraCorrection camera_correction;  // the stereo stage's, after this frame
  int stereo_scale = 1;  // the stereo stage's internal downscale (its matches' grid)
  contour::ContourTimings contour_timings;
  densify::DensifyTimings densify_timings;
  densify::SolverReport solver;
  bool flow_cue = false;  // the frame had both flow neighbours
};

// What the stereo step leaves of one frame for the contour and densify steps.
struct StereoSlot {
  FrameIndex index = -1;
  Image<std::uint8_t> image;          // grey left image, input resolution
  Image<std::uint8_t> small;          // grey left image at the stereo stage's internal resolution
  Image<std::uint8_t> small_colour;   // scratch: the colour image downscaled before its grey
  Image<std::uint8_t> right;          // as DepthResult::right
  Image<std::uint8_t> right_scratch;  // working memory of corrected_right_grey
  Image<std::uint8_t> photometric_left;  // as DepthResult::photometric_left
  stereo::FalloffCorrection falloff;     // the fall-off's table for both
  Image<float> raw_disparity;            // internal px, every pixel
  Image<float> sparse;                   // input px
  Image<float> planar;                   // sparse after densify::smooth_matches, when planes_done
  // When early_contour_done: the image's M_I, gradient directions and Canny classes, and (with
  // contour.use_stereo) the stereo cue of raw_disparity.
  Image<float> m_intensity;
  Image<std::uint8_t> direction;
  Image<std::uint8_t> canny_classes;
  Image<float> stereo_cue;
  stereo::StereoTimings stereo_timings;
  stereo::CameraCorrection camera_correction;
  int stereo_scale = 1;  // internal downscale of the stage
  bool planes_done = false;
  double planes_ms = 0;  // the time smooth_matches took
  bool early_contour_done = false;
  bool stereo_cue_done = false;
  double gradients_ms = 0, stereo_cue_ms = 0;  // the times they took
  // When flow_cue_done: the flow cue of the causal window this frame ends, and its steps' times.
  Image<float> flow_cue;
  contour::ContourTimings flow_timings;
  bool flow_cue_done = false;
};

// Working memory of early_contour_frame.
struct EarlyContourScratch {
  contour::GradientScratch gradients;
  contour::StereoCueScratch cue;
};

// The steps of one frame, shared by DepthPipeline and the real-time runtime (pipeline/runtime),
// so both give the same bytes.
// 1. The grey images of the left view; `small` equals the stereo stage's internal grey image.
//    Cheap, and with lookahead 1 all the previous frame's contour step needs of this frame.
void prepare_frame(const stereo::StereoParams& params, ImageView<const std::uint8_t> left,
                   FrameIndex index, StereoSlot& slot);
// 2. The sparse stage: sparse and raw disparity, timings (independent of step 1), and with
//    `keep_right` the corrected grey right image (and, with a lens fall-off correction, the
//    corrected grey left one). Throws dco::Error on bad input.
void stereo_frame(stereo::StereoMatcher& matcher, ImageView<const std::uint8_t> left,
                  ImageView<const std::uint8_t> right, StereoSlot& slot, bool keep_right);
// The right view as the photometric refinement reads it: brought onto the left's rows and levels
// by `correction` as the stereo stage's camera alignment does it, then grey, then through the
// lens fall-off correction (`falloff`, built for it here). `scratch` is working memory.
void corrected_right_grey(ImageView<const std::uint8_t> right,
                          const stereo::CameraCorrection& correction,
                          stereo::FalloffCorrection& falloff, Image<std::uint8_t>& scratch,
                          Image<std::uint8_t>& out);
// The left view as the refinement reads it beside that: grey (`scratch` holds it for colour),
// then through the lens fall-off correction; `out` is emptied where `correction` has none.
void corrected_left_grey(ImageView<const std::uint8_t> left,
                         const stereo::CameraCorrection& correction,
                         stereo::FalloffCorrection& falloff, Image<std::uint8_t>& scratch,
                         Image<std::uint8_t>& out);
// 2b. The densify stage's first step, which needs only the sparse map: its matches along local
//    planes (densify::smooth_matches), run after step 2 when `here`, so that the stereo thread
//    can carry it when the contour and densify steps take longer. Without `here` the densify
//    step runs it; the slot's planar map and `planes` are still sized, so that neither allocates
//    when the step moves. The output is the same bytes either way.
void plane_frame(const densify::DensifyParams& params, densify::MatchPlaneSmoother& planes,
                 StereoSlot& slot, bool here = true);
// 2c. The contour step's work on this frame alone: the image's intensity gradients and their
//    Canny classes (contour::intensity_gradients_and_classes: M_I, directions, the suppression
//    and dual threshold before the gate) and, with params.use_stereo, the stereo cue of its raw
//    disparity (contour::stereo_cue). Run after steps 1 and 2 when `here`, so that
//    the stereo thread can carry it. Without `here` the contour step does it; the slot's images
//    and `scratch` are still sized. The output is the same bytes either way.
void early_contour_frame(const contour::ContourParams& params, EarlyContourScratch& scratch,
                         StereoSlot& slot, bool here = true);
// 2d. With lookahead 0: the flow cue of the window `centre` ends (contour::ContourExtractor::
//    flow_cue), which needs only the grey images of step 1, so a thread can make it while the
//    centre's stereo runs; the contour step then takes it. The output is the same bytes either way.
void flow_cue_frame(contour::ContourExtractor& extractor, StereoSlot& centre,
                    const StereoSlot& neighbour_a, const StereoSlot& neighbour_b);
// 3. Contours of `centre` given its flow neighbours (the flow cue needs both; nullptr when
//    missing). Fills the contour fields of `out` and copies the centre's index, image, sparse and
//    planar maps and stereo timings into it.
void contour_frame(contour::ContourExtractor& extractor, const StereoSlot& centre,
                   const StereoSlot* neighbour_a, const StereoSlot* neighbour_b, DepthResult& out);
// The same, but the centre's image, sparse and planar maps move into `out` instead of being
// copied: the slot takes `out`'s buffers for them in exchange, same sizes, contents stale. For
// callers that read no more of those maps from the slot (the next frame's steps overwrite them).
void contour_frame_moving_maps(contour::ContourExtractor& extractor, StereoSlot& centre,
                               const StereoSlot* neighbour_a, const StereoSlot* neighbour_b,
                               DepthResult& out);
// What the densifier reads of a result the contour step filled; `previous` is the stability
// term's previous frame (empty for none).
densify::DensifyInputs densify_inputs(const DepthResult& r, ImageView<const float> previous);
// 4. Densification of a result the contour step filled. The densifier's last solution is the
//    previous frame's dense map (Eq. 18), so results go through it in order.
void densify_frame(densify::Densifier& densifier, DepthResult& out);

// Sizes every image of `out` as in `model`, a filled entry, so that a pooled entry has its room
// before its first frame: the steps above then resize without allocating.
void size_like(const StereoSlot& model, StereoSlot& out);
void size_like(const DepthResult& model, DepthResult& out);

// Frame numbers of one contour window; -1 where a frame does not exist.
struct ContourWindow {
  FrameIndex centre = -1, neighbour_a = -1, neighbour_b = -1;
};
// The window frame `newest` completes: with lookahead 1 the previous frame's (none for frame 0),
// with lookahead 0 its own.
ContourWindow window_on_arrival(int lookahead, FrameIndex newest);
// With lookahead 1, the window of the sequence's last frame, which has no successor.
ContourWindow window_at_end(FrameIndex last);

// Makers of the stages that run on more than one backend; an empty one makes the CPU stage.
struct StageFactories {
  stereo::StereoMatcherFactory stereo;
  contour::ContourExtractorFactory contour;
  densify::SystemSolverFactory densify_solver;  // the densifier builds its system on the CPU
  densify::PhotometricRefinementFactory photometric_refinement;
  bool on_gpu = false;  // these stages compute on a GPU (their early contour work stays with them)
};

// Stereo -> contour -> densify, one frame after the other, on the calling thread (the offline
// tools and the tests; the real-time runtime runs the same stages on their own threads).
// The contour window follows contour.lookahead: with 1 it is centred on frame t, so t's result
// comes out when t+1 is pushed and `finish` releases the last one; with 0 it is causal and every
// push returns its own frame. The densifier's stability term and warm start use the previous
// frame's dense map.
class DepthPipeline {
 public:
  // `stages` makes the stereo and contour stages, the densify solver and the photometric
  // refinement (empty: the CPU ones).
  explicit DepthPipeline(const PipelineParams& params, const StageFactories& stages = {});

  // left/right: a rectified pair (8-bit, 1 or 3 channels). Returns true when `out` was filled.
  bool push(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
            DepthResult& out);
  // Releases a frame still waiting for its successor (lookahead 1). Returns true if it did.
  bool finish(DepthResult& out);
  // Starts a new, unrelated sequence.
  void reset();

  const PipelineParams& params() const { return params_; }

 private:
  StereoSlot& slot_of(FrameIndex index) {
    return slots_[static_cast<std::size_t>(index) % slots_.size()];
  }
  void finish_frame(const ContourWindow& window, DepthResult& out);

  PipelineParams params_;
  std::unique_ptr<stereo::StereoMatcher> stereo_;
  std::unique_ptr<contour::ContourExtractor> contour_;
  densify::Densifier densifier_;
  densify::MatchPlaneSmoother planes_;
  EarlyContourScratch early_contour_;
  // The contour step's work on a frame alone as a step of its own (early_contour_frame), as the
  // runtime's stereo thread does it, with a CPU contour stage; a GPU one does it beside its flow.
  bool early_contour_apart_;
  std::array<StereoSlot, 3> slots_;
  FrameIndex next_index_ = 0;   // index of the next pushed frame
  FrameIndex next_output_ = 0;  // index of the next frame to finish
};

}  // namespace dco::pipeline
