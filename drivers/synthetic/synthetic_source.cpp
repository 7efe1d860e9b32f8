// synthetic://NAME: the built-in demo scene with exact ground truth (core/synthetic_scene).

#include <fmt/format.h>

#include "../src/paced_source.hpp"
#include "../src/sources.hpp"
#include "dco/core/synthetic_scene.hpp"

namespace dco::drivers {
namespace {

class SyntheticSource final : public PacedSource {
 public:
  SyntheticSource(SourceUri& uri)
      : fps_(uri.fps(30, "as fast as taken")),
        renderer_(config(uri, fps_)),
        calibration_(renderer_.calibration()),
        frames_(static_cast<std::uint64_t>(uri.integer("frames", 0, 0, 1 << 30))) {
    set_stall_after(static_cast<std::uint64_t>(uri.integer("stall_after", 0, 0, 1 << 30)));
    uri.finish();
    const auto& c = renderer_.config();
    info_.uri = uri.text();
    info_.width = c.width;
    info_.height = c.height;
    info_.channels = c.color ? 3 : 1;
    info_.fps = fps_;
    info_.max_disparity = synthetic::covering_max_disparity(c);
    info_.description = fmt::format("synthetic {} {}x{} @ {} fps", uri.path(), c.width, c.height,
                                    fps_ > 0 ? fmt::format("{}", fps_) : std::string("max"));
  }
  ~SyntheticSource() override { stop(); }

  const SourceInfo& info() const override { return info_; }
  const StereoCalibration& calibration() const override { return calibration_; }

 private:
  // The scene moves in real time at the rate it is delivered: a 90 Hz source sees a third of a
  // 30 Hz one's motion per frame. Delivered as fast as taken, it keeps the preset's rate.
  static synthetic::SceneConfig config(SourceUri& uri, double fps) {
    const int width = uri.integer("width", 640, 32, 8192);
    const int height = uri.integer("height", 360, 32, 8192);
    synthetic::SceneConfig c = synthetic::preset(uri.path(), width, height);
    c.color = uri.flag("color", false);
    c.right_gain = uri.number("right_gain", 1.0, 0.25, 4.0);
    c.right_offset = uri.number("right_offset", 0.0, -128.0, 128.0);
    c.right_rows = uri.number("right_rows", 0.0, -8.0, 8.0);
    c.right_roll_deg = uri.number("right_roll_deg", 0.0, -1.0, 1.0);
    c.lens_falloff = uri.number("lens_falloff", 0.0, 0.0, 0.75);
    if (fps > 0) c.fps = fps;
    return c;
  }

  bool produce(std::uint64_t seq, ImageView<const std::uint8_t>& left,
               ImageView<const std::uint8_t>& right) override {
    if (frames_ > 0 && seq >= frames_) return false;
    renderer_.render(static_cast<std::int64_t>(seq), sample_);
    left = sample_.left.cview();
    right = sample_.right.cview();
    return true;
  }

  double fps_;  // 0: as fast as taken
  synthetic::SceneRenderer renderer_;
  StereoCalibration calibration_;
  std::uint64_t frames_;
  synthetic::StereoSample sample_;
  SourceInfo info_;
};

}  // namespace

std::unique_ptr<FrameSource> open_synthetic(SourceUri& uri) {
  return std::make_unique<SyntheticSource>(uri);
}

}  // namespace dco::drivers
