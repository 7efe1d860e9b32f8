#include "dco/tools/flow_eval.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/error.hpp"
#include "dco/core/file_replace.hpp"
#include "dco/core/image_io.hpp"

namespace dco::tools {
namespace {

static_assert(std::endian::native == std::endian::little, ".flo files are little-endian");

constexpr float kFloTag = 202021.25f;
constexpr int kMaxFloSide = 1 << 15;  // larger sides mean a corrupt header, not a real image
constexpr float kUnknownFlow = 1e9f;  // Middlebury: |u| or |v| above this = no ground truth
constexpr std::size_t kFloHeaderBytes = 12;

int dis_preset(std::string_view name) {
  if (name == "ultrafast") return cv::DISOpticalFlow::PRESET_ULTRAFAST;
  if (name == "fast") return cv::DISOpticalFlow::PRESET_FAST;
  if (name == "medium") return cv::DISOpticalFlow::PRESET_MEDIUM;
  throw Error(fmt::format("flow: unknown DIS preset '{}' (ultrafast, fast or medium)", name));
}

// DIS works on grey 8-bit frames with continuous rows.
cv::Mat to_gray(ImageView<const std::uint8_t> frame, const char* name) {
  if (frame.empty()) throw Error(fmt::format("flow: {} is empty", name));
  if (frame.channels == 1) return as_mat(frame).clone();
  if (frame.channels != 3)
    throw Error(fmt::format("flow: {} has {} channels, expected 1 or 3", name, frame.channels));
  cv::Mat gray;
  cv::cvtColor(as_mat(frame), gray, cv::COLOR_BGR2GRAY);
  return gray;
}

bool known(float u, float v) {
  return std::isfinite(u) && std::isfinite(v) && std::fabs(u) < kUnknownFlow &&
         std::fabs(v) < kUnknownFlow;
}

}  // namespace

Image<float> read_flo(const std::filesystem::path& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw Error(fmt::format("{}: cannot open flow file", path.string()));
  const std::vector<char> bytes((std::istreambuf_iterator<char>(file)),
                                std::istreambuf_iterator<char>());
  if (bytes.size() < kFloHeaderBytes)
    throw Error(
        fmt::format("{}: too short for a .flo header ({} bytes)", path.string(), bytes.size()));
  float tag = 0;
  std::int32_t width = 0, height = 0;
  std::memcpy(&tag, bytes.data(), 4);
  std::memcpy(&width, bytes.data() + 4, 4);
  std::memcpy(&height, bytes.data() + 8, 4);
  if (tag != kFloTag)
    throw Error(fmt::format("{}: not a Middlebury .flo file (tag {} instead of 202021.25)",
                            path.string(), tag));
  if (width <= 0 || height <= 0 || width > kMaxFloSide || height > kMaxFloSide)
    throw Error(fmt::format("{}: implausible flow size {}x{}", path.string(), width, height));
  const std::size_t expected =
      kFloHeaderBytes + static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 8;
  if (bytes.size() != expected)
    throw Error(fmt::format("{}: {}x{} flow needs {} bytes, the file has {}", path.string(), width,
                            height, expected, bytes.size()));
  Image<float> flow(width, height, 2);
  const std::size_t row_bytes = static_cast<std::size_t>(width) * 8;
  for (int y = 0; y < height; ++y)
    std::memcpy(flow.row(y), bytes.data() + kFloHeaderBytes + y * row_bytes, row_bytes);
  return flow;
}

void write_flo(const std::filesystem::path& path, ImageView<const float> flow) {
  if (flow.empty() || flow.channels != 2)
    throw Error(fmt::format("{}: a .flo file holds a non-empty 2-channel flow", path.string()));
  replace_file(path, [&](const std::filesystem::path& tmp) {
    std::ofstream file(tmp, std::ios::binary);
    const std::int32_t size[2] = {flow.width, flow.height};
    file.write(reinterpret_cast<const char*>(&kFloTag), 4);
    file.write(reinterpret_cast<const char*>(size), 8);
    for (int y = 0; y < flow.height; ++y)
      file.write(reinterpret_cast<const char*>(flow.row(y)),
                 static_cast<std::streamsize>(flow.width) * 8);
    file.close();
    if (!file) throw Error(fmt::format("{}: cannot write flow file", path.string()));
  });
}

namespace {

void check_same_size(ImageView<const std::uint8_t> frame_a, ImageView<const std::uint8_t> frame_b,
                     ImageView<const float> gt_flow) {
  if (gt_flow.channels != 2) throw Error("flow: the ground truth needs 2 channels (u, v)");
  if (!frame_a.same_size(frame_b) || !frame_a.same_size(gt_flow))
    throw Error(fmt::format("flow: frames {}x{} and {}x{} and ground truth {}x{} differ in size",
                            frame_a.width, frame_a.height, frame_b.width, frame_b.height,
                            gt_flow.width, gt_flow.height));
}

// DIS flow a -> b (CV_32FC2).
cv::Mat dis_flow(ImageView<const std::uint8_t> frame_a, ImageView<const std::uint8_t> frame_b,
                 std::string_view preset) {
  const cv::Ptr<cv::DISOpticalFlow> dis = cv::DISOpticalFlow::create(dis_preset(preset));
  const cv::Mat a = to_gray(frame_a, "frame_a");
  const cv::Mat b = to_gray(frame_b, "frame_b");
  // Below this DIS has no pyramid level to work on (OpenCV's dis_flow.cpp, patch size 8).
  const double patch = dis->getPatchSize();
  const int levels =
      std::min(static_cast<int>(std::log2(std::max(a.cols, a.rows) / (4.0 * patch)) + 0.5),
               static_cast<int>(std::log2(std::min(a.cols, a.rows) / patch)));
  if (levels < dis->getFinestScale())
    throw Error(fmt::format("flow: {}x{} frames are too small for DIS with the '{}' preset", a.cols,
                            a.rows, preset));
  cv::Mat flow;
  dis->calc(a, b, flow);
  return flow;
}

double mean_endpoint_error(const cv::Mat& flow, ImageView<const float> gt_flow,
                           ImageView<const std::uint8_t> valid_mask) {
  double sum = 0;
  long long count = 0;
  for (int y = 0; y < gt_flow.height; ++y) {
    const float* gt = gt_flow.row(y);
    const auto* est = flow.ptr<float>(y);
    const std::uint8_t* mask = valid_mask.empty() ? nullptr : valid_mask.row(y);
    for (int x = 0; x < gt_flow.width; ++x) {
      if ((mask && mask[x] == 0) || !known(gt[2 * x], gt[2 * x + 1])) continue;
      sum += std::hypot(est[2 * x] - gt[2 * x], est[2 * x + 1] - gt[2 * x + 1]);
      ++count;
    }
  }
  if (count == 0) throw Error("flow: no pixel with a known ground truth inside the valid mask");
  return sum / static_cast<double>(count);
}

}  // namespace

double dis_endpoint_error(ImageView<const std::uint8_t> frame_a,
                          ImageView<const std::uint8_t> frame_b, ImageView<const float> gt_flow,
                          ImageView<const std::uint8_t> valid_mask, std::string_view preset) {
  check_same_size(frame_a, frame_b, gt_flow);
  if (!valid_mask.empty() && (!valid_mask.same_size(gt_flow) || valid_mask.channels != 1))
    throw Error(fmt::format("flow: the valid mask must be {}x{}x1", gt_flow.width, gt_flow.height));
  return mean_endpoint_error(dis_flow(frame_a, frame_b, preset), gt_flow, valid_mask);
}

SintelFlowResult evaluate_sintel_flow(const std::filesystem::path& sequence_dir,
                                      std::string_view preset) {
  const Image<std::uint8_t> a = load_image(sequence_dir / "frame_0002.png", ImageColor::kGray);
  const Image<std::uint8_t> b = load_image(sequence_dir / "frame_0003.png", ImageColor::kGray);
  const Image<float> gt = read_flo(sequence_dir / "gt" / "frame_0002.flo");
  const Image<std::uint8_t> invalid =
      load_image(sequence_dir / "gt" / "invalid" / "frame_0002.png", ImageColor::kGray);
  const Image<std::uint8_t> occluded =
      load_image(sequence_dir / "gt" / "occlusions" / "frame_0002.png", ImageColor::kGray);
  if (!invalid.view().same_size(gt.view()) || !occluded.view().same_size(gt.view()))
    throw Error(fmt::format("{}: masks and ground truth differ in size", sequence_dir.string()));

  Image<std::uint8_t> valid(gt.width(), gt.height());
  Image<std::uint8_t> visible(gt.width(), gt.height());
  for (int y = 0; y < gt.height(); ++y)
    for (int x = 0; x < gt.width(); ++x) {
      valid.at(x, y) = invalid.at(x, y) == 0 ? 255 : 0;
      visible.at(x, y) = invalid.at(x, y) == 0 && occluded.at(x, y) == 0 ? 255 : 0;
    }
  check_same_size(a.view(), b.view(), gt.view());
  const cv::Mat flow = dis_flow(a.view(), b.view(), preset);
  return {mean_endpoint_error(flow, gt.view(), valid.view()),
          mean_endpoint_error(flow, gt.view(), visible.view())};
}

}  // namespace dco::tools
