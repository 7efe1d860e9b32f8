#include "dco/core/stopwatch.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"
#include "dco/pipeline/contour/flow_cue.hpp"
#include "dco/pipeline/contour/gated_canny.hpp"
#include "dco/pipeline/contour/separable_filters.hpp"
#include "dco/pipeline/contour/stereo_cue.hpp"

namespace dco::contour {
namespace {

void max_into(ImageView<const float> a, ImageView<float> inout) {
  for (int y = 0; y < inout.height; ++y) {
    const float* s = a.row(y);
    float* d = inout.row(y);
    for (int x = 0; x < inout.width; ++x) d[x] = s[x] > d[x] ? s[x] : d[x];
  }
}

class CpuContourExtractor final : public ContourExtractor {
 public:
  explicit CpuContourExtractor(const ContourParams& params) : params_(params), flow_cue_(params) {
    validate(params_);
    thresholds_ = {static_cast<float>(params_.t_high), static_cast<float>(params_.t_low),
                   static_cast<float>(params_.t_depth)};
  }

  void compute(const ContourInputs& in, ContourOutputs& out) override {
    check_contour_input(params_, in);
    const bool flow = params_.use_flow && !in.neighbour_a.empty() && !in.neighbour_b.empty();
    const bool given_flow = !in.flow_cue.empty();
    // Also on a sequence's first frames, which have no flow yet: a frame too small for DIS fails
    // there, before any output, not two frames later.
    if (params_.use_flow && !given_flow) flow_cue_.check_size(in.centre);
    Stopwatch t;
    timings_ = {};
    prepare(in, out);

    const bool stereo = params_.use_stereo && (!in.disparity.empty() || !in.stereo_cue.empty());
    if (given_flow) {
      out.m_fuse.copy_from(in.flow_cue);
    } else if (flow) {
      flow_cue_.compute(in, out.m_fuse.view(), timings_, t);
    } else if (!stereo) {
      out.m_fuse.fill(0.0f);  // no cue at all: the gate rejects everything when t_depth > 0
    }
    if (stereo) {
      const auto make_cue = [&](Image<float>& into) {
        stereo_cue(in.disparity, static_cast<float>(params_.stereo_jump), params_.box_size,
                   cue_scratch_, into);
      };
      // Without the flow cue the stereo cue is the filter itself.
      if (!flow && in.stereo_cue.empty()) {
        make_cue(out.m_fuse);
      } else if (!flow) {
        out.m_fuse.copy_from(in.stereo_cue);
      } else {
        if (in.stereo_cue.empty()) make_cue(stereo_cue_);
        max_into(in.stereo_cue.empty() ? stereo_cue_.cview() : in.stereo_cue, out.m_fuse.view());
      }
      timings_.stereo_cue_ms = t.lap_ms();
    }

    ImageView<const float> m_intensity = in.m_intensity;
    ImageView<const std::uint8_t> direction = in.direction;
    if (m_intensity.empty()) {
      intensity_gradients(in.image, gradient_scratch_, out.m_intensity, direction_);
      m_intensity = out.m_intensity.cview();
      direction = direction_.cview();
      timings_.gaussian_ms = t.lap_ms();
    }
    if (!in.canny_classes.empty())
      gated_canny_classified(in.canny_classes, out.m_fuse.cview(), thresholds_, out.contours.view(),
                             canny_);
    else
      gated_canny(m_intensity, direction, out.m_fuse.cview(), thresholds_, out.contours.view(),
                  canny_);
    timings_.canny_ms = t.lap_ms();
    timings_.total_ms = t.total_ms();
  }

  const ContourTimings& last_timings() const override { return timings_; }

  bool prepare_next() override { return params_.use_flow && flow_cue_.prepare_next(); }

  void flow_cue(const ContourInputs& in, Image<float>& out, ContourTimings& timings) override {
    flow_cue_.compute_alone(in, out, timings);
  }

 private:
  // Sizes every buffer; after the first frame of a given size nothing here allocates.
  void prepare(const ContourInputs& in, ContourOutputs& out) {
    const int cw = in.centre.width, ch = in.centre.height;
    const int iw = in.image.width, ih = in.image.height;
    out.m_fuse.resize(cw, ch);
    out.contours.resize(iw, ih);
    // The gradients' buffers too when the inputs carry them, so that a frame without them does
    // not allocate.
    gradient_scratch_.resize(iw);
    direction_.resize(iw, ih);
    // The stereo cue's buffers too when the inputs carry it, so that a frame without it does
    // not allocate.
    for (Image<float>* img : {&cue_scratch_.jumps, &cue_scratch_.tmp, &stereo_cue_})
      img->resize(cw, ch);
  }

  ContourParams params_;
  CannyThresholds thresholds_;
  FlowCue flow_cue_;
  StereoCueScratch cue_scratch_;
  Image<float> stereo_cue_;
  GradientScratch gradient_scratch_;
  Image<std::uint8_t> direction_;
  CannyScratch canny_;
  ContourTimings timings_;
};

}  // namespace

std::unique_ptr<ContourExtractor> make_cpu_contour_extractor(const ContourParams& params) {
  return std::make_unique<CpuContourExtractor>(params);
}

std::unique_ptr<ContourExtractor> make_contour_extractor(const ContourExtractorFactory& factory,
                                                         const ContourParams& params) {
  return factory ? factory(params) : make_cpu_contour_extractor(params);
}

}  // namespace dco::contour
