#include "dco/pipeline/depth_pipeline.hpp"

#include "dco/core/config.hpp"
#include "dco/core/error.hpp"
#include "dco/core/stopwatch.hpp"
#include "dco/pipeline/contour/flow_cue.hpp"
#include "dco/pipeline/stereo/exposure_balance.hpp"
#include "dco/pipeline/stereo/image_ops.hpp"
#include "dco/pipeline/stereo/vertical_alignment.hpp"

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

void check_frame_size(const PipelineParams& params, int width, int height) {
  stereo::check_stereo_size(params.stereo, width, height);
  // The contour stage works on the stereo stage's internal frames.
  const int scale = stereo::internal_scale(params.stereo, width);
  contour::check_flow_size(params.contour, width / scale, height / scale);
}

void prepare_frame(const stereo::StereoParams& params, ImageView<const std::uint8_t> left,
                   FrameIndex index, StereoSlot& slot) {
  slot.index = index;
  slot.flow_cue_done = false;
  slot.image.resize(left.width, left.height);
  if (left.channels == 3)
    stereo::bgr_to_gray(left, slot.image.view());
  else
    slot.image.copy_from(left);
  // The stereo stage's own order: downscale the input as it is, then take the grey of colour.
  const int scale = stereo::internal_scale(params, left.width);
  if (scale == 1) {
    slot.small.resize(left.width, left.height);
    slot.small.copy_from(slot.image.cview());
    return;
  }
  slot.small.resize(left.width / 2, left.height / 2);
  if (left.channels == 3) {
    slot.small_colour.resize(left.width / 2, left.height / 2, 3);
    stereo::downsample_half(left, slot.small_colour.view());
    stereo::bgr_to_gray(slot.small_colour.cview(), slot.small.view());
  } else {
    stereo::downsample_half(left, slot.small.view());
  }
}

void corrected_right_grey(ImageView<const std::uint8_t> right,
                          const stereo::CameraCorrection& correction,
                          stereo::FalloffCorrection& falloff, Image<std::uint8_t>& scratch,
                          Image<std::uint8_t>& out) {
  // The camera alignment's own steps, in its order: the rows, then the levels table; then the
  // grey, then the lens fall-off. Each step writes the buffer the one before did not, so that the
  // last ends in `out`.
  const stereo::RowAlignment rows{correction.row_offset, correction.roll};
  const bool align = !rows.identity(), levels = !correction.same_levels();
  const bool colour = right.channels == 3, flat = correction.falloff != 0;
  int steps_left = int{align} + int{levels} + int{colour} + int{flat};
  const auto next = [&]() -> Image<std::uint8_t>& { return --steps_left % 2 == 0 ? out : scratch; };
  ImageView<const std::uint8_t> v = right;
  if (align) {
    Image<std::uint8_t>& to = next();
    stereo::align_rows(v, rows, to);
    v = to.cview();
  }
  if (levels) {
    stereo::ExposureTable table;
    table.build(correction.levels);
    Image<std::uint8_t>& to = next();
    table.apply(v, to);
    v = to.cview();
  }
  if (colour) {
    Image<std::uint8_t>& to = next();
    to.resize(v.width, v.height);
    stereo::bgr_to_gray(v, to.view());
    v = to.cview();
  }
  if (flat) {
    falloff.build(stereo::LensFalloff{correction.falloff}, v.width, v.height, 1);
    falloff.apply(v, next());
    return;
  }
  if (!align && !levels && !colour) {
    out.resize(v.width, v.height);
    out.copy_from(v);
  }
}

void corrected_left_grey(ImageView<const std::uint8_t> left,
                         const stereo::CameraCorrection& correction,
                         stereo::FalloffCorrection& falloff, Image<std::uint8_t>& scratch,
                         Image<std::uint8_t>& out) {
  if (correction.falloff == 0) {
    out.resize(0, 0);
    return;
  }
  ImageView<const std::uint8_t> v = left;
  if (left.channels == 3) {
    scratch.resize(left.width, left.height);
    stereo::bgr_to_gray(left, scratch.view());
    v = scratch.cview();
  }
  falloff.build(stereo::LensFalloff{correction.falloff}, v.width, v.height, 1);
  falloff.apply(v, out);
}

void stereo_frame(stereo::StereoMatcher& matcher, ImageView<const std::uint8_t> left,
                  ImageView<const std::uint8_t> right, StereoSlot& slot, bool keep_right) {
  matcher.compute(left, right, slot.sparse);
  slot.stereo_timings = matcher.last_timings();
  slot.camera_correction = matcher.last_correction();
  slot.stereo_scale = matcher.last_scale();
  const ImageView<const float> raw = matcher.internal_raw_disparity();
  slot.raw_disparity.resize(raw.width, raw.height);
  slot.raw_disparity.copy_from(raw);
  if (keep_right) {
    corrected_right_grey(right, slot.camera_correction, slot.falloff, slot.right_scratch,
                         slot.right);
    corrected_left_grey(left, slot.camera_correction, slot.falloff, slot.right_scratch,
                        slot.photometric_left);
  } else {
    slot.right.resize(0, 0);
    slot.photometric_left.resize(0, 0);
  }
}

void plane_frame(const densify::DensifyParams& params, densify::MatchPlaneSmoother& planes,
                 StereoSlot& slot, bool here) {
  Stopwatch t;
  slot.planar.resize(slot.sparse.width(), slot.sparse.height());
  slot.planes_done = here;
  slot.planes_ms = 0;
  if (!here) {
    if (params.plane_window > 0)
      planes.reserve(slot.sparse.width(), slot.stereo_scale, params.plane_window / 2);
    return;
  }
  densify::smooth_matches(params, planes, slot.sparse.cview(), slot.stereo_scale,
                          slot.planar.view());
  slot.planes_ms = t.lap_ms();
}

void early_contour_frame(const contour::ContourParams& params, EarlyContourScratch& scratch,
                         StereoSlot& slot, bool here) {
  Stopwatch t;
  slot.early_contour_done = here;
  slot.stereo_cue_done = here && params.use_stereo;
  slot.gradients_ms = slot.stereo_cue_ms = 0;
  if (!here) {
    // Sized all the same, so that nothing allocates when the step moves here.
    const int w = slot.image.width(), h = slot.image.height();
    slot.m_intensity.resize(w, h);
    scratch.gradients.resize(w);
    slot.direction.resize(w, h);
    slot.canny_classes.resize(w, h);
    const int cw = slot.raw_disparity.width(), ch = slot.raw_disparity.height();
    for (Image<float>* img : {&slot.stereo_cue, &scratch.cue.jumps, &scratch.cue.tmp})
      img->resize(cw, ch);
    return;
  }
  const contour::CannyThresholds thresholds{static_cast<float>(params.t_high),
                                            static_cast<float>(params.t_low),
                                            static_cast<float>(params.t_depth)};
  contour::intensity_gradients_and_classes(slot.image.cview(), thresholds, scratch.gradients,
                                           slot.m_intensity, slot.direction, slot.canny_classes);
  slot.gradients_ms = t.lap_ms();
  if (!slot.stereo_cue_done) return;
  contour::stereo_cue(slot.raw_disparity.cview(), static_cast<float>(params.stereo_jump),
                      params.box_size, scratch.cue, slot.stereo_cue);
  slot.stereo_cue_ms = t.lap_ms();
}

void flow_cue_frame(contour::ContourExtractor& extractor, StereoSlot& centre,
                    const StereoSlot& neighbour_a, const StereoSlot& neighbour_b) {
  contour::ContourInputs in;
  in.centre = centre.small.cview();
  in.neighbour_a = neighbour_a.small.cview();
  in.neighbour_b = neighbour_b.small.cview();
  extractor.flow_cue(in, centre.flow_cue, centre.flow_timings);
  centre.flow_cue_done = true;
}

namespace {

// The contour step proper and the result's fields other than the image, sparse and planar maps.
void contours_of(contour::ContourExtractor& extractor, const StereoSlot& centre,
                 const StereoSlot* neighbour_a, const StereoSlot* neighbour_b, DepthResult& out) {
  const bool flow = neighbour_a != nullptr && neighbour_b != nullptr;
  contour::ContourInputs in;
  in.image = centre.image.cview();
  in.centre = centre.small.cview();
  in.disparity = centre.raw_disparity.cview();
  if (flow) {
    in.neighbour_a = neighbour_a->small.cview();
    in.neighbour_b = neighbour_b->small.cview();
  }
  if (centre.early_contour_done) {
    in.m_intensity = centre.m_intensity.cview();
    in.direction = centre.direction.cview();
    in.canny_classes = centre.canny_classes.cview();
  }
  if (centre.stereo_cue_done) in.stereo_cue = centre.stereo_cue.cview();
  if (flow && centre.flow_cue_done) in.flow_cue = centre.flow_cue.cview();
  contour::ContourOutputs contours{std::move(out.m_fuse), std::move(out.m_intensity),
                                   std::move(out.contours)};
  extractor.compute(in, contours);
  out.m_fuse = std::move(contours.m_fuse);
  out.m_intensity = std::move(contours.m_intensity);
  out.contours = std::move(contours.contours);
  out.contour_timings = extractor.last_timings();
  if (centre.early_contour_done) {
    out.contour_timings.gaussian_ms = centre.gradients_ms;
    out.contour_timings.stereo_cue_ms += centre.stereo_cue_ms;  // and the extractor's max with it
  }
  if (!in.flow_cue.empty()) {  // the flow steps' times are the early run's
    const contour::ContourTimings& f = centre.flow_timings;
    contour::ContourTimings& c = out.contour_timings;
    c.flow_ms = f.flow_ms, c.amplitude_ms = f.amplitude_ms, c.fusion_ms = f.fusion_ms;
    c.box_ms = f.box_ms, c.normalise_ms = f.normalise_ms, c.dis_fields = f.dis_fields;
    c.total_ms += f.total_ms;
  }

  out.index = centre.index;
  out.planes_done = centre.planes_done;
  out.early_contour_done = centre.early_contour_done;
  out.densify_timings.planes_ms = centre.planes_ms;
  out.stereo_timings = centre.stereo_timings;
  out.camera_correction = centre.camera_correction;
  out.stereo_scale = centre.stereo_scale;
  out.flow_cue = flow;
}

}  // namespace

void contour_frame(contour::ContourExtractor& extractor, const StereoSlot& centre,
                   const StereoSlot* neighbour_a, const StereoSlot* neighbour_b, DepthResult& out) {
  contours_of(extractor, centre, neighbour_a, neighbour_b, out);
  if (centre.early_contour_done) {
    out.m_intensity.resize(centre.m_intensity.width(), centre.m_intensity.height());
    out.m_intensity.copy_from(centre.m_intensity.cview());
  }
  out.image.resize(centre.image.width(), centre.image.height());
  out.image.copy_from(centre.image.cview());
  out.right.resize(centre.right.width(), centre.right.height());
  out.right.copy_from(centre.right.cview());
  out.photometric_left.resize(centre.photometric_left.width(), centre.photometric_left.height());
  out.photometric_left.copy_from(centre.photometric_left.cview());
  out.sparse.resize(centre.sparse.width(), centre.sparse.height());
  out.sparse.copy_from(centre.sparse.cview());
  out.planar.resize(centre.planar.width(), centre.planar.height());
  if (centre.planes_done) out.planar.copy_from(centre.planar.cview());
}

void contour_frame_moving_maps(contour::ContourExtractor& extractor, StereoSlot& centre,
                               const StereoSlot* neighbour_a, const StereoSlot* neighbour_b,
                               DepthResult& out) {
  contours_of(extractor, centre, neighbour_a, neighbour_b, out);
  // Three or four full-size maps a frame, some 8-12 MB at 1280x720, not copied on the contour
  // thread. The slot keeps maps of its own size (only the first frames allocate): the next frame
  // in it, and whatever sizes other slots like it, find their room.
  out.image.resize(centre.image.width(), centre.image.height());
  out.right.resize(centre.right.width(), centre.right.height());
  out.photometric_left.resize(centre.photometric_left.width(), centre.photometric_left.height());
  out.sparse.resize(centre.sparse.width(), centre.sparse.height());
  out.planar.resize(centre.planar.width(), centre.planar.height());
  out.image.swap(centre.image);
  out.right.swap(centre.right);
  out.photometric_left.swap(centre.photometric_left);
  out.sparse.swap(centre.sparse);
  out.planar.swap(centre.planar);
  if (centre.early_contour_done) {
    out.m_intensity.resize(centre.m_intensity.width(), centre.m_intensity.height());
    out.m_intensity.swap(centre.m_intensity);
  }
}

densify::DensifyInputs densify_inputs(const DepthResult& r, ImageView<const float> previous) {
  densify::DensifyInputs d;
  d.sparse = r.sparse.cview();
  d.m_fuse = r.m_fuse.cview();
  d.m_intensity = r.m_intensity.cview();
  d.contours = r.contours.cview();
  d.image = r.image.cview();
  d.right = r.right.cview();
  d.photometric_left = r.photometric_left.cview();
  d.previous = previous;
  d.match_step = r.stereo_scale;
  if (r.planes_done) d.planar = r.planar.cview();
  return d;
}

void densify_frame(densify::Densifier& densifier, DepthResult& out) {
  // The densifier's own last solution is the previous frame's dense map (Eq. 18).
  const ImageView<const float> last = densifier.last_solution();
  densifier.compute(
      densify_inputs(out, last.same_size(out.sparse.view()) ? last : ImageView<const float>{}),
      out.dense);
  // The planes were the stereo thread's (plane_frame): their time came with the result.
  const double planes_ms = out.densify_timings.planes_ms;
  out.densify_timings = densifier.last_timings();
  if (out.planes_done) out.densify_timings.planes_ms = planes_ms;
  out.solver = densifier.last_report();
}

namespace {

template <typename T>
void size_image_like(const Image<T>& model, Image<T>& out) {
  out.resize(model.width(), model.height(), model.channels());
}

}  // namespace

void size_like(const StereoSlot& model, StereoSlot& out) {
  size_image_like(model.image, out.image);
  size_image_like(model.small, out.small);
  size_image_like(model.small_colour, out.small_colour);
  size_image_like(model.right, out.right);
  size_image_like(model.right_scratch, out.right_scratch);
  size_image_like(model.photometric_left, out.photometric_left);
  size_image_like(model.raw_disparity, out.raw_disparity);
  size_image_like(model.sparse, out.sparse);
  size_image_like(model.planar, out.planar);
  size_image_like(model.m_intensity, out.m_intensity);
  size_image_like(model.direction, out.direction);
  size_image_like(model.canny_classes, out.canny_classes);
  size_image_like(model.stereo_cue, out.stereo_cue);
  size_image_like(model.flow_cue, out.flow_cue);
}

void size_like(const DepthResult& model, DepthResult& out) {
  size_image_like(model.image, out.image);
  size_image_like(model.right, out.right);
  size_image_like(model.photometric_left, out.photometric_left);
  size_image_like(model.sparse, out.sparse);
  size_image_like(model.planar, out.planar);
  size_image_like(model.dense, out.dense);
  size_image_like(model.m_fuse, out.m_fuse);
  size_image_like(model.m_intensity, out.m_intensity);
  size_image_like(model.contours, out.contours);
}

ContourWindow window_on_arrival(int lookahead, FrameIndex newest) {
  const auto frame = [](FrameIndex i) -> FrameIndex { return i >= 0 ? i : -1; };
  if (lookahead == 0) return {newest, frame(newest - 1), frame(newest - 2)};
  if (newest == 0) return {};
  return {newest - 1, frame(newest - 2), newest};
}

ContourWindow window_at_end(FrameIndex last) {
  return {last, last >= 1 ? last - 1 : -1, -1};
}

DepthPipeline::DepthPipeline(const PipelineParams& params, const StageFactories& stages)
    : params_(params),
      stereo_(stereo::make_stereo_matcher(stages.stereo, params.stereo)),
      contour_(contour::make_contour_extractor(stages.contour, params.contour)),
      densifier_(params.densify, stages.densify_solver, stages.photometric_refinement),
      early_contour_apart_(!stages.on_gpu) {
  validate(params_);
}

void DepthPipeline::reset() {
  next_index_ = 0;
  next_output_ = 0;
  stereo_->reset();
  densifier_.reset();
  for (StereoSlot& s : slots_) s.index = -1;
}

bool DepthPipeline::push(ImageView<const std::uint8_t> left, ImageView<const std::uint8_t> right,
                         DepthResult& out) {
  if (next_index_ > 0) {
    const StereoSlot& last = slot_of(next_index_ - 1);
    if (!last.image.view().same_size(left))
      throw Error("pipeline: frame " + std::to_string(next_index_) + " is " +
                  std::to_string(left.width) + "x" + std::to_string(left.height) +
                  " but the sequence started at " + std::to_string(last.image.width()) + "x" +
                  std::to_string(last.image.height()) + "; call reset() for a new sequence");
  }
  // With lookahead 1 the slot being overwritten (t-3) has been finished already.
  const FrameIndex t = next_index_;
  StereoSlot& slot = slot_of(t);
  stereo_frame(*stereo_, left, right, slot,  // first: it rejects bad input
               densifier_.refines(left.width, left.height));
  plane_frame(params_.densify, planes_, slot);
  prepare_frame(params_.stereo, left, t, slot);
  early_contour_frame(params_.contour, early_contour_, slot, early_contour_apart_);
  ++next_index_;
  const ContourWindow window = window_on_arrival(params_.contour.lookahead, t);
  if (window.centre < 0) return false;  // frame 0 waits for frame 1
  finish_frame(window, out);
  next_output_ = window.centre + 1;
  return true;
}

bool DepthPipeline::finish(DepthResult& out) {
  if (next_output_ >= next_index_) return false;
  finish_frame(window_at_end(next_output_), out);  // the flow cue needs both neighbours
  next_output_ += 1;
  return true;
}

void DepthPipeline::finish_frame(const ContourWindow& window, DepthResult& out) {
  const auto neighbour = [this](FrameIndex i) { return i >= 0 ? &slot_of(i) : nullptr; };
  contour_frame_moving_maps(*contour_, slot_of(window.centre), neighbour(window.neighbour_a),
                            neighbour(window.neighbour_b), out);
  densify_frame(densifier_, out);
}

}  // namespace dco::pipeline
