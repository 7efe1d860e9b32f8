// Middlebury calib.txt and the "key: numbers" files of KITTI raw and Karlsruhe, with the
// key/value text helpers they share.
#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "calibration_internal.hpp"

namespace dco::detail {

// ---------------------------------------------------------------------------------------------
// Helpers shared by the text formats.

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r\n");
  return s.substr(first, last - first + 1);
}

std::vector<std::string_view> split_lines(std::string_view text) {
  std::vector<std::string_view> lines;
  std::size_t start = 0;
  while (start <= text.size()) {
    const auto end = text.find('\n', start);
    if (end == std::string_view::npos) {
      lines.push_back(text.substr(start));
      break;
    }
    lines.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return lines;
}

bool is_identifier(std::string_view s) {
  if (s.empty() || std::isdigit(static_cast<unsigned char>(s.front()))) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
  });
}

namespace {

std::optional<double> to_double(std::string_view s) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || s.empty()) return std::nullopt;
  return v;
}

// A "key: values" or "key=values" line, remembered with its line number for messages.
struct Entry {
  long line = 0;
  std::string value;
};

class KeyValues {
 public:
  KeyValues(std::string file, std::map<std::string, Entry> entries)
      : file_(std::move(file)), entries_(std::move(entries)) {}

  bool has(const std::string& key) const { return entries_.count(key) != 0; }
  long line(const std::string& key) const { return has(key) ? entries_.at(key).line : 0; }
  const std::string& file() const { return file_; }

  // The numbers of `key`; brackets and semicolons (Middlebury matrices) count as spaces.
  std::vector<double> numbers(const std::string& key) const {
    const auto it = entries_.find(key);
    if (it == entries_.end()) fail_at(file_, 0, fmt::format("missing '{}'", key));
    std::string text = it->second.value;
    std::replace_if(
        text.begin(), text.end(), [](char c) { return c == '[' || c == ']' || c == ';'; }, ' ');
    std::vector<double> out;
    std::istringstream in(text);
    std::string token;
    while (in >> token) {
      const auto v = to_double(token);
      if (!v)
        fail_at(file_, it->second.line, fmt::format("'{}' in {} is not a number", token, key));
      out.push_back(*v);
    }
    return out;
  }

  std::vector<double> numbers(const std::string& key, std::size_t count) const {
    auto v = numbers(key);
    if (v.size() != count)
      fail_at(file_, line(key),
              fmt::format("{} has {} numbers, expected {}", key, v.size(), count));
    return v;
  }

  double number(const std::string& key) const { return numbers(key, 1)[0]; }

  int integer(const std::string& key, double value) const {
    if (value != std::round(value) || std::abs(value) > 1e9)
      fail_at(file_, line(key), fmt::format("{} must be a whole number, got {}", key, value));
    return static_cast<int>(value);
  }

 private:
  std::string file_;
  std::map<std::string, Entry> entries_;
};

KeyValues parse_key_values(std::string_view text, const std::string& file, char separator) {
  std::map<std::string, Entry> entries;
  const auto lines = split_lines(text);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto line = trim(lines[i]);
    if (line.empty() || line.front() == '#') continue;
    const auto sep = line.find(separator);
    const auto key = sep == std::string_view::npos ? line : trim(line.substr(0, sep));
    if (sep == std::string_view::npos || !is_identifier(key))
      fail_at(file, static_cast<long>(i + 1),
              fmt::format("expected 'key{} values', got '{}'", separator, line.substr(0, 40)));
    const auto [at, added] = entries.emplace(
        std::string(key), Entry{static_cast<long>(i + 1), std::string(line.substr(sep + 1))});
    // Which of two values was meant is unknown: the last one winning would hide the mistake.
    if (!added)
      fail_at(file, static_cast<long>(i + 1),
              fmt::format("{} is given twice (first on line {})", key, at->second.line));
  }
  return KeyValues(file, std::move(entries));
}

// Extrinsics implied by rectifying rotations: both rectified frames share orientation and the
// right one sits at +B on x, so x_right = Rr^T * (Rl * x_left - (B, 0, 0)).
void extrinsics_from_rectification(StereoCalibration& c) {
  const Mat3 rr_t = transpose(c.rect_rotation_right);
  c.rotation = mul(rr_t, c.rect_rotation_left);
  const Vec3 t = mul(rr_t, Vec3{-c.rectified.baseline_m, 0, 0});
  c.translation = t;
}

bool nearly_equal(double a, double b) {
  return std::abs(a - b) <= 1e-6 * std::max({1.0, std::abs(a), std::abs(b)});
}

// Rectified geometry from 3x4 projection matrices P = K [I | t] with K = [f 0 cx; 0 f cy; 0 0 1]:
// the last column is (f tx + cx tz, f ty + cy tz, tz), the camera's offset t in the rectified
// frame. KITTI's colour pair sits a few millimetres off the line between its centres (0.5-0.8 %
// of the baseline across and along the view), which its users ignore; a pair further off than
// kMaxOffAxisShare of its baseline is not side by side.
RectifiedGeometry geometry_from_projections(const KeyValues& kv, const std::string& left_key,
                                            const std::string& right_key) {
  constexpr double kMaxOffAxisShare = 0.02;
  const auto pl = kv.numbers(left_key, 12);
  const auto pr = kv.numbers(right_key, 12);
  if (!nearly_equal(pl[0], pr[0]) || !nearly_equal(pl[0], pl[5]) || !nearly_equal(pr[0], pr[5]) ||
      !nearly_equal(pl[6], pr[6]) || pl[10] != 1.0 || pr[10] != 1.0)
    fail_at(kv.file(), kv.line(right_key),
            fmt::format("{} and {} do not describe a rectified pair (f or cy differ)", left_key,
                        right_key));
  // The entries a rectified projection holds at 0 (skew, and the rows' other terms); any other
  // value would be dropped without a word.
  for (const auto* p : {&pl, &pr})
    if ((*p)[1] != 0 || (*p)[4] != 0 || (*p)[8] != 0 || (*p)[9] != 0)
      fail_at(kv.file(), kv.line(p == &pl ? left_key : right_key),
              fmt::format("{} is not a rectified projection [f 0 cx tx; 0 f cy ty; 0 0 1 tz]",
                          p == &pl ? left_key : right_key));
  const double f = pl[0];
  const auto offset = [f](const std::vector<double>& p) {
    return std::array<double, 3>{(p[3] - p[2] * p[11]) / f, (p[7] - p[6] * p[11]) / f, p[11]};
  };
  const auto tl = offset(pl), tr = offset(pr);
  const double across = std::abs(tl[0] - tr[0]);
  if (std::abs(tl[1] - tr[1]) > kMaxOffAxisShare * across ||
      std::abs(tl[2] - tr[2]) > kMaxOffAxisShare * across)
    fail_at(kv.file(), kv.line(right_key),
            fmt::format("{} and {} place the cameras apart vertically or in depth by more than "
                        "{} % of their baseline: dco needs a side-by-side pair",
                        left_key, right_key, 100 * kMaxOffAxisShare));
  RectifiedGeometry g;
  g.f = f;
  g.cx_left = pl[2];
  g.cx_right = pr[2];
  g.cy = pl[6];
  g.baseline_m = tl[0] - tr[0];
  return g;
}

CameraIntrinsics intrinsics_from(const KeyValues& kv, const std::string& k_key,
                                 const std::string& d_key) {
  const auto k = kv.numbers(k_key, 9);
  // The camera models here have no skew: a non-zero one would be dropped without a word.
  if (k[1] != 0 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1)
    fail_at(kv.file(), kv.line(k_key),
            fmt::format("{} is not a camera matrix [fx 0 cx; 0 fy cy; 0 0 1]", k_key));
  CameraIntrinsics c;
  c.fx = k[0];
  c.fy = k[4];
  c.cx = k[2];
  c.cy = k[5];
  c.distortion = kv.has(d_key) ? kv.numbers(d_key) : std::vector<double>{};
  return c;
}

Mat3 mat3_from(const KeyValues& kv, const std::string& key) {
  const auto v = kv.numbers(key, 9);
  Mat3 m{};
  std::copy(v.begin(), v.end(), m.begin());
  return m;
}

Vec3 vec3_from(const KeyValues& kv, const std::string& key) {
  const auto v = kv.numbers(key, 3);
  return {v[0], v[1], v[2]};
}

void size_from(const KeyValues& kv, const std::string& key, int& width, int& height) {
  const auto s = kv.numbers(key, 2);
  width = kv.integer(key, s[0]);
  height = kv.integer(key, s[1]);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Middlebury calib.txt.

StereoCalibration parse_middlebury(std::string_view text, const std::string& file) {
  const KeyValues kv = parse_key_values(text, file, '=');
  StereoCalibration c;
  c.source = file;
  std::array<std::vector<double>, 2> cams{kv.numbers("cam0", 9), kv.numbers("cam1", 9)};
  for (int i = 0; i < 2; ++i) {
    const auto& m = cams[i];
    if (m[1] != 0 || m[3] != 0 || m[6] != 0 || m[7] != 0 || m[8] != 1 || !nearly_equal(m[0], m[4]))
      fail_at(file, kv.line(i == 0 ? "cam0" : "cam1"),
              fmt::format("cam{} is not a matrix [f 0 cx; 0 f cy; 0 0 1]", i));
  }
  if (!nearly_equal(cams[0][0], cams[1][0]) || !nearly_equal(cams[0][5], cams[1][5]))
    fail_at(file, kv.line("cam1"), "cam1 has a different f or cy than cam0: not a rectified pair");
  RectifiedGeometry& g = c.rectified;
  g.f = cams[0][0];
  g.cx_left = cams[0][2];
  g.cx_right = cams[1][2];
  g.cy = cams[0][5];
  g.baseline_m = kv.number("baseline") / 1000.0;  // the file gives millimetres
  g.width = kv.integer("width", kv.number("width"));
  g.height = kv.integer("height", kv.number("height"));
  if (kv.has("doffs")) {
    const double doffs = kv.number("doffs");
    // Files print cx and doffs with 3 decimals, so they agree to about 1e-3.
    if (!(std::abs(doffs - g.doffs()) <= 0.01))
      fail_at(file, kv.line("doffs"),
              fmt::format("doffs {} disagrees with cam1 cx - cam0 cx = {}", doffs, g.doffs()));
  }
  c.is_rectified = true;
  cameras_from_rectified(c);
  return c;
}

// ---------------------------------------------------------------------------------------------
// Karlsruhe (K1/P1_roi ...) and KITTI raw (K_02/R_rect_02/P_rect_02 ...) "key: numbers" files.

namespace {

StereoCalibration parse_karlsruhe(const KeyValues& kv) {
  StereoCalibration c;
  c.source = kv.file();
  if (!kv.has("P1_roi") || !kv.has("P2_roi"))
    fail_at(kv.file(), 0,
            "has no P1_roi/P2_roi: only Karlsruhe files of rectified images are supported (the "
            "format gives no raw image size)");
  c.rectified = geometry_from_projections(kv, "P1_roi", "P2_roi");
  if (kv.has("roi")) {
    // roi = x0 x1 y0 y1, inclusive pixel bounds of the crop in the rectified image.
    const auto r = kv.numbers("roi", 4);
    c.rectified.width = kv.integer("roi", r[1] - r[0] + 1);
    c.rectified.height = kv.integer("roi", r[3] - r[2] + 1);
  }
  c.is_rectified = true;
  cameras_from_rectified(c);
  return c;
}

StereoCalibration parse_kitti(const KeyValues& kv) {
  StereoCalibration c;
  c.source = kv.file();
  // The colour pair (02, 03) when present, else the grey pair (00, 01).
  const std::string l = kv.has("K_02") ? "_02" : "_00";
  const std::string r = kv.has("K_02") ? "_03" : "_01";
  c.left = intrinsics_from(kv, "K" + l, "D" + l);
  c.right = intrinsics_from(kv, "K" + r, "D" + r);
  size_from(kv, "S" + l, c.left.width, c.left.height);
  size_from(kv, "S" + r, c.right.width, c.right.height);
  c.has_rectification = true;
  c.rect_rotation_left = mat3_from(kv, "R_rect" + l);
  c.rect_rotation_right = mat3_from(kv, "R_rect" + r);
  c.rectified = geometry_from_projections(kv, "P_rect" + l, "P_rect" + r);
  if (kv.has("S_rect" + l)) {
    size_from(kv, "S_rect" + l, c.rectified.width, c.rectified.height);
    // One rectified size serves both images.
    if (kv.has("S_rect" + r)) {
      int width = 0, height = 0;
      size_from(kv, "S_rect" + r, width, height);
      if (width != c.rectified.width || height != c.rectified.height)
        fail_at(kv.file(), kv.line("S_rect" + r),
                fmt::format("S_rect{} is {}x{} but S_rect{} is {}x{}", r, width, height, l,
                            c.rectified.width, c.rectified.height));
    }
  } else {
    c.rectified.width = c.left.width;
    c.rectified.height = c.left.height;
  }
  if (kv.has("R" + l) && kv.has("T" + l) && kv.has("R" + r) && kv.has("T" + r)) {
    // R_0x/T_0x map the reference camera 00 into camera 0x.
    const Mat3 rl = mat3_from(kv, "R" + l), rr = mat3_from(kv, "R" + r);
    const Vec3 tl = vec3_from(kv, "T" + l), tr = vec3_from(kv, "T" + r);
    c.rotation = mul(rr, transpose(rl));
    const Vec3 rt = mul(c.rotation, tl);
    c.translation = {tr[0] - rt[0], tr[1] - rt[1], tr[2] - rt[2]};
  } else {
    extrinsics_from_rectification(c);
  }
  return c;
}
}  // namespace

StereoCalibration parse_key_colon(std::string_view text, const std::string& file) {
  const KeyValues kv = parse_key_values(text, file, ':');
  if (kv.has("K_02") || kv.has("K_00")) return parse_kitti(kv);
  if (kv.has("K1") || kv.has("P1_roi")) return parse_karlsruhe(kv);
  fail_at(file, 0,
          "unrecognised 'key: numbers' calibration (expected KITTI K_02/K_03 or Karlsruhe "
          "K1/P1_roi keys)");
}

}  // namespace dco::detail
