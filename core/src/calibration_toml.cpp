// dco's own TOML calibration format (docs/calibration.md): reader and writer.
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <iterator>
#include <limits>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <toml++/toml.h>
#include <opencv2/calib3d.hpp>

#include "calibration_internal.hpp"

namespace dco::detail {
namespace {

// ---------------------------------------------------------------------------------------------
// Reading.

Mat3 rodrigues(const Vec3& r) {
  cv::Mat rvec(3, 1, CV_64F, const_cast<double*>(r.data()));
  cv::Mat rm;
  cv::Rodrigues(rvec, rm);
  Mat3 out{};
  for (int i = 0; i < 9; ++i) out[i] = rm.at<double>(i / 3, i % 3);
  return out;
}

long line_of(const toml::node& n) {
  return static_cast<long>(n.source().begin.line);
}

// One TOML table; remembers the keys read so that anything else is reported as unknown.
class TomlSection {
 public:
  TomlSection(const toml::table* table, std::string name, const std::string& file)
      : table_(table), name_(std::move(name)), file_(file) {}

  bool present() const { return table_ != nullptr; }
  bool has(std::string_view key) const { return table_ && table_->contains(key); }

  const toml::node& require(std::string_view key) {
    if (table_ == nullptr) fail_at(file_, 0, fmt::format("missing section [{}]", name_));
    const toml::node* n = table_->get(key);
    if (n == nullptr)
      fail_at(file_, line_of(*table_), fmt::format("[{}] is missing '{}'", name_, key));
    used_.emplace(key);
    return *n;
  }

  double number(std::string_view key) { return as_number(require(key), key); }

  int integer(std::string_view key) {
    const toml::node& n = require(key);
    const auto* v = n.as_integer();
    if (v == nullptr || v->get() < std::numeric_limits<int>::min() ||
        v->get() > std::numeric_limits<int>::max())
      fail_at(file_, line_of(n), fmt::format("[{}] {} must be an integer", name_, key));
    return static_cast<int>(v->get());
  }

  std::string text(std::string_view key) {
    const toml::node& n = require(key);
    const auto* v = n.as_string();
    if (v == nullptr)
      fail_at(file_, line_of(n), fmt::format("[{}] {} must be a string", name_, key));
    return v->get();
  }

  std::vector<double> numbers(std::string_view key) {
    const toml::node& n = require(key);
    const auto* arr = n.as_array();
    if (arr == nullptr)
      fail_at(file_, line_of(n), fmt::format("[{}] {} must be an array of numbers", name_, key));
    std::vector<double> out;
    for (const toml::node& e : *arr) out.push_back(as_number(e, key));
    return out;
  }

  Mat3 rotation(std::string_view key) {
    const auto v = numbers(key);
    if (v.size() == 9) {
      Mat3 m{};
      std::copy(v.begin(), v.end(), m.begin());
      return m;
    }
    if (v.size() == 3) return rodrigues({v[0], v[1], v[2]});
    fail_at(
        file_, line_of(require(key)),
        fmt::format("[{}] {} needs 9 numbers (row-major matrix) or 3 (Rodrigues vector), got {}",
                    name_, key, v.size()));
  }

  void reject_unknown() const {
    if (!table_) return;
    for (auto&& [k, v] : *table_)
      if (!used_.count(std::string(k.str())))
        fail_at(file_, line_of(v), fmt::format("unknown key '{}' in [{}]", k.str(), name_));
  }

 private:
  double as_number(const toml::node& n, std::string_view key) const {
    if (const auto* f = n.as_floating_point()) return f->get();
    if (const auto* i = n.as_integer()) return static_cast<double>(i->get());
    fail_at(file_, line_of(n), fmt::format("[{}] {} must be a number", name_, key));
  }

  const toml::table* table_;
  std::string name_;
  const std::string& file_;
  std::set<std::string, std::less<>> used_;
};

CameraIntrinsics read_camera(TomlSection& s, const std::string& file, std::string_view name) {
  CameraIntrinsics c;
  const std::string model = s.text("model");
  if (model == "pinhole")
    c.model = CameraModel::kPinhole;
  else if (model == "kannala_brandt")
    c.model = CameraModel::kKannalaBrandt;
  else
    fail_at(file, line_of(s.require("model")),
            fmt::format("[{}] model must be \"pinhole\" or \"kannala_brandt\", got \"{}\"", name,
                        model));
  c.width = s.integer("width");
  c.height = s.integer("height");
  c.fx = s.number("fx");
  c.fy = s.number("fy");
  c.cx = s.number("cx");
  c.cy = s.number("cy");
  if (s.has("distortion")) c.distortion = s.numbers("distortion");
  s.reject_unknown();
  return c;
}

}  // namespace

StereoCalibration parse_toml(std::string_view text, const std::string& file) {
  toml::table root;
  try {
    root = toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    fail_at(file, static_cast<long>(e.source().begin.line), e.description());
  }
  static const std::set<std::string, std::less<>> kSections{"left", "right", "extrinsics",
                                                            "rectified", "rectification"};
  for (auto&& [k, v] : root) {
    if (!kSections.count(k.str()))
      fail_at(file, line_of(v), fmt::format("unknown section or key '{}'", k.str()));
    if (!v.is_table()) fail_at(file, line_of(v), fmt::format("'{}' must be a [section]", k.str()));
  }
  auto section = [&](const char* name) { return TomlSection(root[name].as_table(), name, file); };
  TomlSection left = section("left"), right = section("right"), ext = section("extrinsics"),
              rectified = section("rectified"), rectification = section("rectification");

  StereoCalibration c;
  c.source = file;
  if (rectified.present()) {
    RectifiedGeometry& g = c.rectified;
    g.width = rectified.integer("width");
    g.height = rectified.integer("height");
    g.f = rectified.number("f");
    g.cx_left = rectified.number("cx_left");
    g.cx_right = rectified.number("cx_right");
    g.cy = rectified.number("cy");
    g.baseline_m = rectified.number("baseline_m");
    rectified.reject_unknown();
  }
  if (rectification.present()) {
    if (!rectified.present())
      fail_at(file, line_of(*root["rectification"].node()),
              "[rectification] needs a [rectified] section for the target geometry");
    c.has_rectification = true;
    c.rect_rotation_left = rectification.rotation("rotation_left");
    c.rect_rotation_right = rectification.rotation("rotation_right");
    rectification.reject_unknown();
  }
  c.is_rectified = rectified.present() && !rectification.present();
  if (c.is_rectified) cameras_from_rectified(c);  // defaults for whatever sections are absent
  if (left.present() || !c.is_rectified) c.left = read_camera(left, file, "left");
  if (right.present() || !c.is_rectified) c.right = read_camera(right, file, "right");
  if (ext.present() || !c.is_rectified) {
    c.rotation = ext.rotation("rotation");
    const auto t = ext.numbers("translation");
    if (t.size() != 3)
      fail_at(file, line_of(ext.require("translation")),
              fmt::format("[extrinsics] translation needs 3 numbers, got {}", t.size()));
    c.translation = {t[0], t[1], t[2]};
    ext.reject_unknown();
  }
  return c;
}

// ---------------------------------------------------------------------------------------------
// Writing.

namespace {

std::string toml_number(double v) {
  // toml++ reads subnormal numbers back only approximately; such a coefficient is 0 in effect,
  // and 0 keeps the file's promise that it reads back as written.
  if (std::fpclassify(v) == FP_SUBNORMAL) v = std::signbit(v) ? -0.0 : 0.0;
  std::string s = fmt::format("{}", v);
  if (s.find_first_of(".en") == std::string::npos) s += ".0";  // keep floats floats ("n": inf/nan)
  return s;
}

template <typename Range>
std::string toml_array(const Range& values) {
  std::string s = "[";
  for (auto it = std::begin(values); it != std::end(values); ++it) {
    if (it != std::begin(values)) s += ", ";
    s += toml_number(*it);
  }
  return s + "]";
}

void write_camera(std::string& out, std::string_view name, const CameraIntrinsics& c) {
  fmt::format_to(std::back_inserter(out),
                 "[{}]\nmodel = \"{}\"\nwidth = {}\nheight = {}\nfx = {}\nfy = {}\ncx = {}\n"
                 "cy = {}\ndistortion = {}\n\n",
                 name, c.model == CameraModel::kPinhole ? "pinhole" : "kannala_brandt", c.width,
                 c.height, toml_number(c.fx), toml_number(c.fy), toml_number(c.cx),
                 toml_number(c.cy), toml_array(c.distortion));
}

}  // namespace

std::string format_toml(const StereoCalibration& calib) {
  std::string out = "# dco stereo calibration; keys are described in docs/calibration.md\n\n";
  write_camera(out, "left", calib.left);
  write_camera(out, "right", calib.right);
  fmt::format_to(std::back_inserter(out),
                 "[extrinsics]\n# x_right = rotation * x_left + translation (metres)\n"
                 "rotation = {}\ntranslation = {}\n",
                 toml_array(calib.rotation), toml_array(calib.translation));
  if (calib.is_rectified || calib.has_rectification) {
    const RectifiedGeometry& g = calib.rectified;
    fmt::format_to(std::back_inserter(out),
                   "\n[rectified]\nwidth = {}\nheight = {}\nf = {}\ncx_left = {}\ncx_right = {}\n"
                   "cy = {}\nbaseline_m = {}\n",
                   g.width, g.height, toml_number(g.f), toml_number(g.cx_left),
                   toml_number(g.cx_right), toml_number(g.cy), toml_number(g.baseline_m));
  }
  if (calib.has_rectification && !calib.is_rectified)
    fmt::format_to(std::back_inserter(out),
                   "\n[rectification]\nrotation_left = {}\nrotation_right = {}\n",
                   toml_array(calib.rect_rotation_left), toml_array(calib.rect_rotation_right));
  return out;
}

}  // namespace dco::detail
