#include "dco/pipeline/contour/flow_cue.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/video/tracking.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/pipeline/contour/flow_field_worker.hpp"
#include "dco/pipeline/contour/flow_fusion.hpp"
#include "dco/pipeline/contour/separable_filters.hpp"
#include "dco/pipeline/row_team.hpp"

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
void check_optional(ImageView<const T> v, ImageView<const std::uint8_t> like, const char* name) {
  if (v.empty()) return;
  if (v.channels != 1 || !v.same_size(like))
    throw Error(std::string("contour: ") + name + " is " + size_text(v) + ", expected " +
                std::to_string(like.width) + "x" + std::to_string(like.height) + "x1");
}

bool same_pixels(ImageView<const std::uint8_t> a, const Image<std::uint8_t>& b) {
  if (!a.same_size(b.cview())) return false;
  for (int y = 0; y < a.height; ++y)
    if (std::memcmp(a.row(y), b.row(y), static_cast<std::size_t>(a.width)) != 0) return false;
  return true;
}

// Mat::setTo allocates on every call; a row memset does not.
void zero(cv::Mat& m) {
  for (int y = 0; y < m.rows; ++y) std::memset(m.ptr(y), 0, m.cols * m.elemSize());
}

}  // namespace

void check_contour_input(const ContourParams& params, const ContourInputs& in) {
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
  check_optional(in.stereo_cue, in.centre, "stereo_cue");
  check_optional(in.flow_cue, in.centre, "flow_cue");
  if (!in.flow_cue.empty() && !params.use_flow)
    throw Error("contour: a flow cue was given with use_flow off");
  if (!in.flow_cue.empty() && (in.neighbour_a.empty() || in.neighbour_b.empty()))
    throw Error("contour: a flow cue was given for a window without both neighbours");
  if (in.m_intensity.empty() != in.direction.empty())
    throw Error("contour: m_intensity and direction come together or not at all");
  check_optional(in.m_intensity, in.image, "m_intensity");
  check_optional(in.direction, in.image, "direction");
  check_optional(in.canny_classes, in.image, "canny_classes");
}

void check_flow_window(const ContourParams& params, const ContourInputs& in) {
  if (!params.use_flow) throw Error("contour: a flow cue was asked for with use_flow off");
  if (in.centre.empty() || in.centre.channels != 1)
    throw Error("contour: the centre frame must be a non-empty grey image, got " +
                size_text(in.centre));
  if (in.neighbour_a.empty() || in.neighbour_b.empty())
    throw Error("contour: the flow cue needs both neighbours of the centre frame");
  check_optional(in.neighbour_a, in.centre, "neighbour_a");
  check_optional(in.neighbour_b, in.centre, "neighbour_b");
}

struct FlowCue::State {
  explicit State(const ContourParams& p)
      : params(p), rows(pipeline::RowTeam::threads_for(p.row_threads)) {}
  ContourParams params;
  pipeline::RowTeam rows;           // shares the steps after DIS
  std::vector<float> part_largest;  // per thread of `rows`: the largest value of its rows
  cv::Ptr<cv::DISOpticalFlow> dis;
  cv::Mat flow_a, flow_b;  // CV_32FC2, kept so DIS writes into the same memory every frame
  // With reuse_flow: the last call's field the next window can use and the two images it joins,
  // centre -> neighbour_b (t -> t+1) with lookahead 1, centre -> neighbour_a (t -> t-1) with 0.
  cv::Mat last_field;
  Image<std::uint8_t> last_centre, last_neighbour;
  bool has_last = false;
  // prepare_next made flow_a, speed, amplitude_a and contrast_a from last_field.
  bool next_prepared = false;
  cv::Mat centre_copy, neighbour_copy, neighbour_b_copy;  // continuous copies of padded views
  std::unique_ptr<FlowFieldWorker> field_b;  // with parallel_flow: computes flow_b meanwhile
  Image<float> speed, speed_b, amplitude_a, amplitude_b, contrast_a, contrast_b, fused, tmp;
  FlowInversionScratch inversion;
};

FlowCue::FlowCue(const ContourParams& params) : s_(std::make_unique<State>(params)) {
  s_->part_largest.resize(static_cast<std::size_t>(s_->rows.threads()));
  s_->dis = cv::DISOpticalFlow::create(dis_preset(params.dis_preset));
  if (parallel_flow_fields(params))
    s_->field_b = std::make_unique<FlowFieldWorker>(
        cv::DISOpticalFlow::create(dis_preset(params.dis_preset)));
}

FlowCue::~FlowCue() = default;

bool FlowCue::prepare_next() {
  State& s = *s_;
  s.next_prepared = false;
  if (!s.has_last || s.params.lookahead != 1) return false;
  // The sizes of the call that made last_field: the next one resizes nothing if it reuses it.
  const int cw = s.last_centre.width(), ch = s.last_centre.height();
  for (Image<float>* img : {&s.speed, &s.amplitude_a, &s.contrast_a}) img->resize(cw, ch);
  s.flow_a.create(ch, cw, CV_32FC2);
  invert_flow(as_view<float>(static_cast<const cv::Mat&>(s.last_field)), s.inversion,
              as_view<float>(s.flow_a));
  // compute()'s steps of that field, as it makes them.
  const ImageView<const float> fa = as_view<float>(static_cast<const cv::Mat&>(s.flow_a));
  const auto distance = static_cast<float>(s.params.projection_distance);
  s.rows.run(ch, [&](int, int begin, int end) { flow_speed_rows(fa, begin, end, s.speed.view()); });
  s.rows.run(ch, [&](int, int begin, int end) {
    flow_amplitude_rows(s.speed.cview(), begin, end, s.amplitude_a.view());
  });
  s.rows.run(ch, [&](int, int begin, int end) {
    projection_contrast_rows(fa, distance, begin, end, s.contrast_a.view());
  });
  s.next_prepared = true;
  return true;
}

namespace {

void refuse_flow_size(const std::string& size, const std::string& preset) {
  throw Error("contour: the internal frame " + size +
              " is too small for DIS optical flow with the '" + preset +
              "' preset (use a larger internal resolution, another preset or use_flow=false)");
}

}  // namespace

void FlowCue::check_size(ImageView<const std::uint8_t> centre) const {
  if (!dis_handles(s_->dis, centre.width, centre.height))
    refuse_flow_size(size_text(centre), s_->params.dis_preset);
}

void check_flow_size(const ContourParams& params, int width, int height) {
  if (!params.use_flow) return;
  if (!dis_handles(cv::DISOpticalFlow::create(dis_preset(params.dis_preset)), width, height))
    refuse_flow_size(std::to_string(width) + "x" + std::to_string(height), params.dis_preset);
}

void FlowCue::compute_alone(const ContourInputs& in, Image<float>& out, ContourTimings& timings) {
  check_flow_window(s_->params, in);
  check_size(in.centre);
  out.resize(in.centre.width, in.centre.height);
  timings = {};
  Stopwatch t;
  compute(in, out.view(), timings, t);
  timings.total_ms = t.total_ms();
}

void FlowCue::compute(const ContourInputs& in, ImageView<float> dst, ContourTimings& timings,
                      Stopwatch& t) {
  State& s = *s_;
  const int cw = in.centre.width, ch = in.centre.height;
  for (Image<float>* img : {&s.speed, &s.speed_b, &s.amplitude_a, &s.amplitude_b, &s.contrast_a,
                            &s.contrast_b, &s.fused, &s.tmp})
    img->resize(cw, ch);
  s.flow_a.create(ch, cw, CV_32FC2);
  s.flow_b.create(ch, cw, CV_32FC2);

  const cv::Mat centre = continuous(in.centre, s.centre_copy);
  // The window's content, not frame numbers, decides whether the last call's field serves. With
  // lookahead 1 the previous frame's field t-1 -> t is this frame's t -> t-1 turned round; with
  // lookahead 0 the previous frame's t-1 -> t-2 carries this frame's fresh t -> t-1 on to t-2.
  const bool centred = s.params.lookahead == 1;
  // The last call's neighbour is this window's centre (lookahead 1) or its neighbour_b (0).
  const ImageView<const std::uint8_t> last_neighbour_now = centred ? in.centre : in.neighbour_b;
  const bool reuse = s.params.reuse_flow && s.has_last &&
                     same_pixels(in.neighbour_a, s.last_centre) &&
                     same_pixels(last_neighbour_now, s.last_neighbour);
  timings.dis_fields = reuse ? 1 : 2;
  // The field to the previous frame and its steps up to the fusion, when prepare_next made them.
  const bool prepared = std::exchange(s.next_prepared, false) && reuse && centred;
  // A flow Mat of the right size is taken by DIS as a candidate initial flow; zero what DIS
  // writes so that frame t's result depends on its window only, not on the previous call.
  if (!reuse || !centred) zero(s.flow_a);  // otherwise invert_flow writes every pixel
  if (!reuse || centred) zero(s.flow_b);   // otherwise compose_flow does
  const auto view_of = [](const cv::Mat& m) { return as_view<float>(m); };
  if (reuse && centred) {
    s.dis->calc(centre, continuous(in.neighbour_b, s.neighbour_copy), s.flow_b);
    if (!prepared) invert_flow(view_of(s.last_field), s.inversion, as_view<float>(s.flow_a));
  } else if (reuse) {
    s.dis->calc(centre, continuous(in.neighbour_a, s.neighbour_copy), s.flow_a);
    compose_flow(view_of(s.flow_a), view_of(s.last_field), as_view<float>(s.flow_b));
  } else if (s.field_b) {
    const cv::Mat neighbour_a = continuous(in.neighbour_a, s.neighbour_copy);
    const cv::Mat neighbour_b = continuous(in.neighbour_b, s.neighbour_b_copy);
    s.field_b->start(centre, neighbour_b, s.flow_b);
    try {
      s.dis->calc(centre, neighbour_a, s.flow_a);
    } catch (...) {
      try {
        s.field_b->wait();  // it reads the locals above
      } catch (...) {       // the first error is the one reported
      }
      throw;
    }
    s.field_b->wait();
  } else {
    s.dis->calc(centre, continuous(in.neighbour_a, s.neighbour_copy), s.flow_a);
    s.dis->calc(centre, continuous(in.neighbour_b, s.neighbour_copy), s.flow_b);
  }
  timings.flow_ms = t.lap_ms();

  // The steps after DIS work row by row; a step that reads a neighbouring row of an earlier one
  // (the amplitude, the box filter's two passes, the division by the largest value) waits for it
  // on every block of rows.
  const ImageView<const float> fa = as_view<float>(static_cast<const cv::Mat&>(s.flow_a));
  const ImageView<const float> fb = as_view<float>(static_cast<const cv::Mat&>(s.flow_b));
  const bool field_a = !prepared;
  s.rows.run(ch, [&](int, int begin, int end) {
    if (field_a) flow_speed_rows(fa, begin, end, s.speed.view());
    flow_speed_rows(fb, begin, end, s.speed_b.view());
  });
  s.rows.run(ch, [&](int, int begin, int end) {
    if (field_a) flow_amplitude_rows(s.speed.cview(), begin, end, s.amplitude_a.view());
    flow_amplitude_rows(s.speed_b.cview(), begin, end, s.amplitude_b.view());
  });
  timings.amplitude_ms = t.lap_ms();

  const auto distance = static_cast<float>(s.params.projection_distance);
  s.rows.run(ch, [&](int, int begin, int end) {
    if (field_a) projection_contrast_rows(fa, distance, begin, end, s.contrast_a.view());
    projection_contrast_rows(fb, distance, begin, end, s.contrast_b.view());
    fuse_amplitude_rows(s.amplitude_a.cview(), s.contrast_a.cview(), s.amplitude_b.cview(),
                        s.contrast_b.cview(), begin, end, s.fused.view());
  });
  timings.fusion_ms = t.lap_ms();

  if (s.params.reuse_flow) {
    // Kept for the next frame: the field and the two images it joins (swapped, not copied, so
    // the next frame's DIS writes into the buffer this one read).
    std::swap(centred ? s.flow_b : s.flow_a, s.last_field);
    const ImageView<const std::uint8_t> neighbour = centred ? in.neighbour_b : in.neighbour_a;
    s.last_centre.resize(cw, ch);
    s.last_centre.copy_from(in.centre);
    s.last_neighbour.resize(cw, ch);
    s.last_neighbour.copy_from(neighbour);
    s.has_last = true;
  }
  const int box = s.params.box_size;
  std::fill(s.part_largest.begin(), s.part_largest.end(), 0.0f);  // parts left without rows
  s.rows.run(ch, [&](int, int begin, int end) {
    box_vertical_rows(s.fused.cview(), box, begin, end, s.tmp.view());
  });
  s.rows.run(ch, [&](int part, int begin, int end) {
    box_horizontal_rows(s.tmp.cview(), box, begin, end, dst);
    s.part_largest[static_cast<std::size_t>(part)] = largest_value(dst, begin, end);
  });
  timings.box_ms = t.lap_ms();
  // normalise_by_max, its largest value taken from the blocks' own.
  float largest = 0.0f;
  for (int part = 0; part < s.rows.threads(); ++part)
    largest = std::max(largest, s.part_largest[static_cast<std::size_t>(part)]);
  const float divisor = std::max(largest, static_cast<float>(s.params.flow_floor));
  if (divisor >= kLeastFlowDivisor)
    s.rows.run(ch, [&](int, int begin, int end) { divide_rows(dst, divisor, begin, end); });
  timings.normalise_ms = t.lap_ms();
}

}  // namespace dco::contour
