#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include <opencv2/video/tracking.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/core/stopwatch.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"
#include "dco/pipeline/contour/flow_fusion.hpp"
#include "dco/pipeline/contour/gated_canny.hpp"
#include "dco/pipeline/contour/separable_filters.hpp"
#include "dco/pipeline/contour/stereo_cue.hpp"

namespace dco::contour {
namespace {

int dis_preset(const std::string& name) {
  if (name == "ultrafast") return cv::DISOpticalFlow::PRESET_ULTRAFAST;
  if (name == "medium") return cv::DISOpticalFlow::PRESET_MEDIUM;
  return cv::DISOpticalFlow::PRESET_FAST;
}

// DIS picks its coarsest pyramid level from the frame size; when that falls below the preset's
// finest level it skips every level and returns uninitialised memory (or crashes on thin frames).
// Same formula as OpenCV's dis_flow.cpp, patch size 8 in every preset.
bool dis_handles(const cv::Ptr<cv::DISOpticalFlow>& dis, int w, int h) {
  const double patch = dis->getPatchSize();
  const int by_motion =
      static_cast<int>(std::log(std::max(w, h) / (4.0 * patch)) / std::log(2.0) + 0.5);
  const int by_size = static_cast<int>(std::log(std::min(w, h) / patch) / std::log(2.0));
  return std::min(by_motion, by_size) >= dis->getFinestScale();
}

// DIS needs continuous rows; a padded view is copied into `buffer` (sized once, then reused).
cv::Mat continuous(ImageView<const std::uint8_t> v, cv::Mat& buffer) {
  const cv::Mat m = as_mat(v);
  if (m.isContinuous()) return m;
  m.copyTo(buffer);
  return buffer;
}

template <typename T>
std::string size_text(ImageView<T> v) {
  return std::to_string(v.width) + "x" + std::to_string(v.height) + "x" +
         std::to_string(v.channels);
}

// An optional input is either absent or a single-channel image of the internal size.
template <typename T>
void check_optional(ImageView<const T> v, ImageView<const std::uint8_t> centre, const char* name) {
  if (v.empty()) return;
  if (v.channels != 1 || !v.same_size(centre))
    throw Error(std::string("contour: ") + name + " is " + size_text(v) + ", expected " +
                std::to_string(centre.width) + "x" + std::to_string(centre.height) + "x1");
}

// Mat::setTo allocates on every call; a row memset does not.
void zero(cv::Mat& m) {
  for (int y = 0; y < m.rows; ++y) std::memset(m.ptr(y), 0, m.cols * m.elemSize());
}

void max_into(ImageView<const float> a, ImageView<float> inout) {
  for (int y = 0; y < inout.height; ++y) {
    const float* s = a.row(y);
    float* d = inout.row(y);
    for (int x = 0; x < inout.width; ++x) d[x] = s[x] > d[x] ? s[x] : d[x];
  }
}

class CpuContourExtractor final : public ContourExtractor {
 public:
  explicit CpuContourExtractor(const ContourParams& params) : params_(params) {
    validate(params_);
    dis_ = cv::DISOpticalFlow::create(dis_preset(params_.dis_preset));
    thresholds_ = {static_cast<float>(params_.t_high), static_cast<float>(params_.t_low),
                   static_cast<float>(params_.t_depth)};
  }

  void compute(const ContourInputs& in, ContourOutputs& out) override {
    check_input(in);
    const bool flow = params_.use_flow && !in.neighbour_a.empty() && !in.neighbour_b.empty();
    if (flow && !dis_handles(dis_, in.centre.width, in.centre.height))
      throw Error("contour: the internal frame " + size_text(in.centre) +
                  " is too small for DIS optical flow with the '" + params_.dis_preset +
                  "' preset (use a larger internal resolution, another preset or use_flow=false)");
    Stopwatch t;
    timings_ = {};
    prepare(in, out);

    const bool stereo = params_.use_stereo && !in.disparity.empty();
    if (flow) {
      flow_cue(in, out.m_fuse.view(), t);
    } else if (!stereo) {
      out.m_fuse.fill(0.0f);  // no cue at all: the gate rejects everything when t_depth > 0
    }
    if (stereo) {
      disparity_jump_strength(in.disparity, static_cast<float>(params_.stereo_jump), jumps_.view());
      if (flow) {
        box_filter(jumps_.cview(), params_.box_size, tmp_.view(), stereo_cue_.view());
        max_into(stereo_cue_.cview(), out.m_fuse.view());
      } else {
        box_filter(jumps_.cview(), params_.box_size, tmp_.view(), out.m_fuse.view());
      }
      timings_.stereo_cue_ms = t.lap_ms();
    }

    gaussian_blur_5x5(in.image, blur_tmp_.view(), blurred_.view());
    timings_.gaussian_ms = t.lap_ms();
    sobel_magnitude(blurred_.cview(), kMaxSobelMagnitude8Bit, out.m_intensity.view(),
                    direction_.view());
    gated_canny(out.m_intensity.cview(), direction_.cview(), out.m_fuse.cview(), thresholds_,
                out.contours.view(), canny_);
    timings_.canny_ms = t.lap_ms();
    timings_.total_ms = t.total_ms();
  }

  const ContourTimings& last_timings() const override { return timings_; }

 private:
  static void check_input(const ContourInputs& in) {
    if (in.image.empty() || in.image.channels != 1)
      throw Error("contour: the input image must be a non-empty grey image, got " +
                  size_text(in.image));
    if (in.centre.empty() || in.centre.channels != 1)
      throw Error("contour: the centre frame must be a non-empty grey image, got " +
                  size_text(in.centre));
    if (in.centre.width > in.image.width || in.centre.height > in.image.height)
      throw Error("contour: the centre frame (" + size_text(in.centre) +
                  ") is larger than the input image (" + size_text(in.image) + ")");
    check_optional(in.neighbour_a, in.centre, "neighbour_a");
    check_optional(in.neighbour_b, in.centre, "neighbour_b");
    check_optional(in.disparity, in.centre, "disparity");
  }

  // Sizes every buffer; after the first frame of a given size nothing here allocates.
  void prepare(const ContourInputs& in, ContourOutputs& out) {
    const int cw = in.centre.width, ch = in.centre.height;
    const int iw = in.image.width, ih = in.image.height;
    out.m_fuse.resize(cw, ch);
    out.m_intensity.resize(iw, ih);
    out.contours.resize(iw, ih);
    for (Image<float>* img : {&speed_, &amplitude_a_, &amplitude_b_, &contrast_a_, &contrast_b_,
                              &fused_, &tmp_, &jumps_, &stereo_cue_})
      img->resize(cw, ch);
    blur_tmp_.resize(iw, ih);
    blurred_.resize(iw, ih);
    direction_.resize(iw, ih);
    flow_a_.create(ch, cw, CV_32FC2);
    flow_b_.create(ch, cw, CV_32FC2);
  }

  // §5.1–5.2: DIS flow from the centre to each neighbour, amplitude per field, fusion by the
  // projection test, box filter, normalisation.
  void flow_cue(const ContourInputs& in, ImageView<float> dst, Stopwatch& t) {
    const cv::Mat centre = continuous(in.centre, centre_copy_);
    // A flow Mat of the right size is taken by DIS as a candidate initial flow; zero it so that
    // frame t's result depends on its window only, not on the previous call.
    zero(flow_a_);
    zero(flow_b_);
    dis_->calc(centre, continuous(in.neighbour_a, neighbour_copy_), flow_a_);
    dis_->calc(centre, continuous(in.neighbour_b, neighbour_copy_), flow_b_);
    timings_.flow_ms = t.lap_ms();

    const ImageView<const float> fa = as_view<float>(static_cast<const cv::Mat&>(flow_a_));
    const ImageView<const float> fb = as_view<float>(static_cast<const cv::Mat&>(flow_b_));
    flow_amplitude(fa, speed_.view(), amplitude_a_.view());
    flow_amplitude(fb, speed_.view(), amplitude_b_.view());
    timings_.amplitude_ms = t.lap_ms();

    const auto distance = static_cast<float>(params_.projection_distance);
    projection_contrast(fa, distance, contrast_a_.view());
    projection_contrast(fb, distance, contrast_b_.view());
    fuse_amplitudes(amplitude_a_.cview(), contrast_a_.cview(), amplitude_b_.cview(),
                    contrast_b_.cview(), fused_.view());
    timings_.fusion_ms = t.lap_ms();

    box_filter(fused_.cview(), params_.box_size, tmp_.view(), dst);
    timings_.box_ms = t.lap_ms();
    normalise_by_max(dst, static_cast<float>(params_.flow_floor));
    timings_.normalise_ms = t.lap_ms();
  }

  ContourParams params_;
  CannyThresholds thresholds_;
  cv::Ptr<cv::DISOpticalFlow> dis_;
  cv::Mat flow_a_, flow_b_;  // CV_32FC2, kept so DIS writes into the same memory every frame
  cv::Mat centre_copy_, neighbour_copy_;  // continuous copies of padded input views
  Image<float> speed_, amplitude_a_, amplitude_b_, contrast_a_, contrast_b_, fused_, tmp_;
  Image<float> jumps_, stereo_cue_;
  Image<float> blur_tmp_, blurred_;
  Image<std::uint8_t> direction_;
  CannyScratch canny_;
  ContourTimings timings_;
};

}  // namespace

std::unique_ptr<ContourExtractor> make_cpu_contour_extractor(const ContourParams& params) {
  return std::make_unique<CpuContourExtractor>(params);
}

}  // namespace dco::contour
