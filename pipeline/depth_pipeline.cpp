#include "dco/pipeline/depth_pipeline.hpp"

#include "dco/core/config.hpp"
#include "dco/core/error.hpp"
#include "dco/pipeline/stereo/image_ops.hpp"

namespace dco::pipeline {

void register_params(ConfigSchema& schema, PipelineParams& params) {
  stereo::register_params(schema, params.stereo);
  contour::register_params(schema, params.contour);
  densify::register_params(schema, params.densify);
}

void validate(const PipelineParams& params) {
  stereo::validate(params.stereo);
  contour::validate(params.contour);
  densify::validate(params.densify);
}

DepthPipeline::DepthPipeline(const PipelineParams& params)
    : params_(params),
      stereo_(stereo::make_cpu_stereo_matcher(params.stereo)),
      contour_(contour::make_cpu_contour_extractor(params.contour)),
      densifier_(params.densify) {
  validate(params_);
}

void DepthPipeline::reset() {
  next_index_ = 0;
  next_output_ = 0;
  densifier_.reset();
  for (Slot& s : slots_) s.index = -1;
}

bool DepthPipeline::push(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                         DepthResult& out) {
  if (next_index_ > 0) {
    const Slot& last = slot_of(next_index_ - 1);
    if (!last.image.view().same_size(left))
      throw Error("pipeline: frame " + std::to_string(next_index_) + " is " +
                  std::to_string(left.width) + "x" + std::to_string(left.height) +
                  " but the sequence started at " + std::to_string(last.image.width()) + "x" +
                  std::to_string(last.image.height()) + "; call reset() for a new sequence");
  }
  // With lookahead 1 the slot being overwritten (t-3) has been finished already.
  Slot& slot = slot_of(next_index_);
  stereo_->compute(left, right, slot.sparse);
  slot.index = next_index_;
  slot.stereo_timings = stereo_->last_timings();
  slot.image.resize(left.width, left.height);
  if (left.channels == 3)
    stereo::bgr_to_gray(left, slot.image.view());
  else
    slot.image.copy_from(left);
  const ImageView<const std::uint8_t> small = stereo_->internal_left_gray();
  slot.small.resize(small.width, small.height);
  slot.small.copy_from(small);
  const ImageView<const float> raw = stereo_->internal_raw_disparity();
  slot.raw_disparity.resize(raw.width, raw.height);
  slot.raw_disparity.copy_from(raw);
  const int t = next_index_++;

  if (params_.contour.lookahead == 0) {
    finish_frame(t, t - 1, t - 2, out);
    next_output_ = t + 1;
    return true;
  }
  if (t == 0) return false;  // frame 0 waits for frame 1
  finish_frame(t - 1, t - 2, t, out);
  next_output_ = t;
  return true;
}

bool DepthPipeline::finish(DepthResult& out) {
  if (next_output_ >= next_index_) return false;
  const int t = next_output_;
  finish_frame(t, t - 1, -1, out);  // no successor: the flow cue needs both neighbours
  next_output_ = t + 1;
  return true;
}

void DepthPipeline::finish_frame(int centre, int neighbour_a, int neighbour_b, DepthResult& out) {
  const Slot& c = slot_of(centre);
  const bool flow = neighbour_a >= 0 && neighbour_b >= 0;
  contour::ContourInputs in;
  in.image = c.image.cview();
  in.centre = c.small.cview();
  in.disparity = c.raw_disparity.cview();
  if (flow) {
    in.neighbour_a = slot_of(neighbour_a).small.cview();
    in.neighbour_b = slot_of(neighbour_b).small.cview();
  }
  contour::ContourOutputs contours{std::move(out.m_fuse), std::move(out.m_intensity),
                                   std::move(out.contours)};
  contour_->compute(in, contours);
  out.m_fuse = std::move(contours.m_fuse);
  out.m_intensity = std::move(contours.m_intensity);
  out.contours = std::move(contours.contours);

  densify::DensifyInputs d;
  d.sparse = c.sparse.cview();
  d.m_fuse = out.m_fuse.cview();
  d.m_intensity = out.m_intensity.cview();
  d.contours = out.contours.cview();
  d.image = c.image.cview();
  // The densifier's own last solution is the previous frame's dense map (Eq. 18).
  const ImageView<const float> previous = densifier_.last_solution();
  if (previous.same_size(c.sparse.view())) d.previous = previous;
  densifier_.compute(d, out.dense);

  out.index = centre;
  out.image.resize(c.image.width(), c.image.height());
  out.image.copy_from(c.image.cview());
  out.sparse.resize(c.sparse.width(), c.sparse.height());
  out.sparse.copy_from(c.sparse.cview());
  out.stereo_timings = c.stereo_timings;
  out.contour_timings = contour_->last_timings();
  out.densify_timings = densifier_.last_timings();
  out.solver = densifier_.last_report();
  out.flow_cue = flow;
}

}  // namespace dco::pipeline
