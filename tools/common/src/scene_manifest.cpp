#include "dco/tools/scene_manifest.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <string_view>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dco/core/disparity_io.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image_io.hpp"

namespace dco::tools {
namespace {

enum Column {
  kScene,
  kLeft,
  kRight,
  kGt,
  kGtFormat,
  kGtDivisor,
  kNoccMask,
  kMaxDisp,
  kColumnCount
};
constexpr std::array<std::string_view, kColumnCount> kColumnNames = {
    "scene", "left", "right", "gt", "gt_format", "gt_divisor", "nocc_mask", "max_disp"};

constexpr float kUnknown = std::numeric_limits<float>::infinity();

std::vector<std::string_view> split_tabs(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t tab = line.find('\t', start);
    fields.push_back(line.substr(start, tab == std::string_view::npos ? tab : tab - start));
    if (tab == std::string_view::npos) return fields;
    start = tab + 1;
  }
}

// Where each known column sits in a row; extra columns are ignored so the manifest can grow.
std::array<std::size_t, kColumnCount> parse_header(const std::vector<std::string_view>& fields,
                                                   const std::string& where) {
  std::array<std::size_t, kColumnCount> index{};
  for (int c = 0; c < kColumnCount; ++c) {
    const auto found = std::find(fields.begin(), fields.end(), kColumnNames[c]);
    if (found == fields.end())
      throw Error(fmt::format("{}: header has no column '{}'", where, kColumnNames[c]));
    if (std::find(found + 1, fields.end(), kColumnNames[c]) != fields.end())
      throw Error(fmt::format("{}: header names column '{}' twice", where, kColumnNames[c]));
    index[c] = static_cast<std::size_t>(found - fields.begin());
  }
  return index;
}

template <typename T>
T parse_number(std::string_view text, std::string_view column, const std::string& where) {
  T value{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size())
    throw Error(fmt::format("{}: {} '{}' is not a number", where, column, text));
  return value;
}

Scene parse_row(const std::vector<std::string_view>& fields,
                const std::array<std::size_t, kColumnCount>& index,
                const std::filesystem::path& data_root, const std::string& where) {
  const auto field = [&](Column c) -> std::string_view {
    const std::string_view value = fields[index[c]];
    if (value.empty()) throw Error(fmt::format("{}: column '{}' is empty", where, kColumnNames[c]));
    return value;
  };
  const auto path = [&](Column c) { return data_root / std::filesystem::path(field(c)); };

  Scene scene;
  scene.name = std::string(field(kScene));
  scene.left = path(kLeft);
  scene.right = path(kRight);
  scene.gt = path(kGt);

  const std::string_view format = field(kGtFormat);
  if (format == "pfm")
    scene.gt_format = GroundTruthFormat::kPfm;
  else if (format == "png")
    scene.gt_format = GroundTruthFormat::kPng;
  else
    throw Error(fmt::format("{}: unknown gt_format '{}' (expected pfm or png)", where, format));

  scene.gt_divisor = parse_number<double>(field(kGtDivisor), "gt_divisor", where);
  // As a float (the PNG decoder divides in float) it must stay a positive finite number.
  if (!(scene.gt_divisor >= 1e-6 && scene.gt_divisor <= 1e6))
    throw Error(fmt::format("{}: gt_divisor must be within 1e-6..1e6", where));
  // PFM holds pixels already; a divisor there would be silently ignored, so refuse it.
  if (scene.gt_format == GroundTruthFormat::kPfm && scene.gt_divisor != 1)
    throw Error(fmt::format("{}: gt_divisor must be 1 for pfm ground truth", where));

  if (field(kNoccMask) != "-") scene.nocc_mask = path(kNoccMask);

  scene.max_disp = parse_number<int>(field(kMaxDisp), "max_disp", where);
  // No disparity exceeds an image's width.
  if (scene.max_disp <= 0 || scene.max_disp > kMaxImageSide)
    throw Error(fmt::format("{}: max_disp must be within 1..{}", where, kMaxImageSide));
  return scene;
}

// PNG ground truth stores disparity * divisor in its first channel. OpenCV hands colour files over
// as BGR(A), so the file's first channel (R) is the Mat's channel 2.
Image<float> decode_png_disparity(const Scene& scene) {
  const cv::Mat raw = read_image_file(scene.gt, cv::IMREAD_UNCHANGED, "ground truth");
  if (raw.depth() != CV_8U && raw.depth() != CV_16U)
    throw Error(fmt::format("ground truth '{}' is neither 8 nor 16 bit", scene.gt.string()));
  cv::Mat channel;
  cv::extractChannel(raw, channel, raw.channels() >= 3 ? 2 : 0);
  cv::Mat values;
  channel.convertTo(values, CV_32F);

  Image<float> disparity(values.cols, values.rows);
  const float divisor = static_cast<float>(scene.gt_divisor);
  for (int y = 0; y < values.rows; ++y) {
    const float* in = values.ptr<float>(y);
    float* out = disparity.row(y);
    for (int x = 0; x < values.cols; ++x) out[x] = in[x] > 0 ? in[x] / divisor : kUnknown;
  }
  return disparity;
}

Image<float> decode_pfm_disparity(const Scene& scene) {
  Image<float> disparity = read_pfm(scene.gt);
  if (disparity.channels() != 1)
    throw Error(fmt::format("ground truth '{}' has {} channels, expected 1", scene.gt.string(),
                            disparity.channels()));
  // One convention for "unknown" downstream, whatever the file used (+inf, NaN, 0).
  for (int y = 0; y < disparity.height(); ++y) {
    float* row = disparity.row(y);
    for (int x = 0; x < disparity.width(); ++x)
      if (!(std::isfinite(row[x]) && row[x] > 0)) row[x] = kUnknown;
  }
  return disparity;
}

}  // namespace

std::string Scene::file_stem() const {
  std::string stem = name;
  std::replace(stem.begin(), stem.end(), '/', '_');
  return stem;
}

std::vector<Scene> load_scene_manifest(const std::filesystem::path& tsv,
                                       const std::filesystem::path& data_root) {
  std::error_code ec;
  if (std::filesystem::is_directory(tsv, ec))
    throw Error(fmt::format("scene manifest '{}' is a directory", tsv.string()));
  std::ifstream in(tsv);
  if (!in) throw Error(fmt::format("cannot open scene manifest '{}'", tsv.string()));

  std::vector<Scene> scenes;
  std::optional<std::array<std::size_t, kColumnCount>> index;
  std::size_t header_fields = 0;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    if (!line.empty() && line.back() == '\r') line.pop_back();  // files edited on Windows
    if (line.empty() || line.front() == '#') continue;
    const std::string where = fmt::format("{}:{}", tsv.string(), line_no);
    const std::vector<std::string_view> fields = split_tabs(line);
    if (!index) {
      index = parse_header(fields, where);
      header_fields = fields.size();
      continue;
    }
    if (fields.size() != header_fields)
      throw Error(fmt::format("{}: {} tab-separated fields, the header has {}", where,
                              fields.size(), header_fields));
    scenes.push_back(parse_row(fields, *index, data_root, where));
    scenes.back().position = static_cast<int>(scenes.size()) - 1;
    const std::string& name = scenes.back().name;
    const std::string stem = scenes.back().file_stem();
    for (std::size_t i = 0; i + 1 < scenes.size(); ++i) {
      if (scenes[i].name == name)
        throw Error(fmt::format("{}: scene '{}' listed twice", where, name));
      // Predictions are files named by the stem: two scenes must not share one.
      if (scenes[i].file_stem() == stem)
        throw Error(fmt::format("{}: scenes '{}' and '{}' both have the file name '{}'", where,
                                scenes[i].name, name, stem));
    }
  }
  if (!index) throw Error(fmt::format("{}: no header row", tsv.string()));
  return scenes;
}

GroundTruth load_ground_truth(const Scene& scene) {
  GroundTruth gt;
  gt.disparity = scene.gt_format == GroundTruthFormat::kPfm ? decode_pfm_disparity(scene)
                                                            : decode_png_disparity(scene);
  if (scene.nocc_mask) {
    gt.nocc = load_image(*scene.nocc_mask, ImageColor::kGray);
    if (gt.nocc.width() != gt.disparity.width() || gt.nocc.height() != gt.disparity.height())
      throw Error(fmt::format("nocc mask '{}' is {}x{}, the ground truth is {}x{}",
                              scene.nocc_mask->string(), gt.nocc.width(), gt.nocc.height(),
                              gt.disparity.width(), gt.disparity.height()));
  }
  return gt;
}

}  // namespace dco::tools
