// replay://DIR: a recorded stereo sequence from image files, paced like the camera it came from.
//
// DIR holds either images/I1_*.png + images/I2_*.png (the Karlsruhe sequences' layout) or
// left/* + right/* (any image files: paired and ordered by the numbers in their names, all of them
// in order, where every name has one, else in name order), and one calibration file: calib.toml
// (dco's format), calib.txt (Middlebury or Karlsruhe) or calib_cam_to_cam.txt (KITTI). The whole
// recording is decoded up front, so replay never touches the disk while it streams and a looped
// replay allocates nothing per frame.

#include <algorithm>
#include <cctype>
#include <charconv>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "../src/paced_source.hpp"
#include "../src/sources.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image_io.hpp"

namespace dco::drivers {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kMaxRecordingBytes = std::size_t{2} << 30;

bool is_image(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext == ".png" || ext == ".pgm" || ext == ".ppm" || ext == ".jpg" || ext == ".jpeg" ||
         ext == ".bmp";
}

// Image files in `dir` whose name starts with `prefix`, in name order.
std::vector<fs::path> list_images(const fs::path& dir, const std::string& prefix) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const fs::path& p = entry.path();
    if (entry.is_regular_file() && is_image(p) && p.filename().string().rfind(prefix, 0) == 0)
      out.push_back(p);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Calls number(digits, fraction) for each run of digits in a file's stem after its side's
// prefix, in order; `fraction`: the run follows a number and a '.' ("1305031102.175304").
template <class Number>
void for_each_number(const fs::path& p, const std::string& prefix, Number&& number) {
  const std::string stem = p.stem().string().substr(prefix.size());
  const auto digit = [&](std::size_t i) {
    return i < stem.size() && std::isdigit(static_cast<unsigned char>(stem[i]));
  };
  for (std::size_t first = 0; first < stem.size(); ++first) {
    if (!digit(first)) continue;
    std::size_t last = first;
    while (digit(last + 1)) ++last;
    number(std::string_view(stem).substr(first, last - first + 1),
           first >= 2 && stem[first - 1] == '.' && digit(first - 2));
    first = last;
  }
}

// The numbers in a file's stem, in order: "I1_000012" -> 12, "1305031102.175304" (a capture
// time) -> 1305031102, 0.175304, "000046_10" (KITTI) -> 46, 10. A fraction is held as 18
// decimal places: "100.15" comes after "100.1" and before "100.2" (times written without their
// trailing zeros). Compared in that order, so files play in time and frame order. nullopt when
// there is none; a number past 64 bits (a nanosecond time has 19 digits and fits) or a fraction
// past 18 places is an error: the files cannot be put in order by it, nor paired by position.
using FrameKey = std::vector<std::uint64_t>;

std::optional<FrameKey> frame_key(const fs::path& p, const std::string& prefix,
                                  const std::string& where) {
  FrameKey key;
  for_each_number(p, prefix, [&](std::string_view digits, bool fraction) {
    std::uint64_t value = 0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
    if (ec != std::errc() || end != digits.data() + digits.size() ||
        (fraction && digits.size() > 18))
      throw Error(fmt::format("{}: {} has a number of {} digits, too long to order frames by",
                              where, p.filename().string(), digits.size()));
    if (fraction)
      for (std::size_t place = digits.size(); place < 18; ++place) value *= 10;
    key.push_back(value);
  });
  if (key.empty()) return std::nullopt;
  return key;
}

// The numbers frame_key reads, for messages: "000046_10" -> "46_10", "1305031102.175304" as it is.
std::string frame_name(const fs::path& p, const std::string& prefix) {
  std::string text;
  for_each_number(p, prefix, [&](std::string_view digits, bool fraction) {
    if (fraction)
      text += "." + std::string(digits);
    else
      text += (text.empty() ? "" : "_") + std::to_string(std::stoull(std::string(digits)));
  });
  return text;
}

// Left and right images as pairs, their names' side prefixes given. Where every name carries a
// number the pairs are made by the numbers, in their order (a file missing on one side is named,
// "9" comes before "10"); else by name order.
std::vector<std::pair<fs::path, fs::path>> pair_images(const std::vector<fs::path>& left,
                                                       const std::vector<fs::path>& right,
                                                       const std::string (&prefix)[2],
                                                       const std::string& where) {
  std::map<FrameKey, fs::path> by_number[2];
  bool numbered = true;
  for (int side = 0; side < 2 && numbered; ++side)
    for (const fs::path& p : side == 0 ? left : right) {
      const auto key = frame_key(p, prefix[side], where);
      if (!key) {
        numbered = false;
        break;
      }
      const auto [at, added] = by_number[side].emplace(*key, p);
      if (!added)
        throw Error(fmt::format("{}: {} and {} are both frame {}", where,
                                at->second.filename().string(), p.filename().string(),
                                frame_name(p, prefix[side])));
    }
  std::vector<std::pair<fs::path, fs::path>> pairs;
  if (!numbered) {
    if (left.size() != right.size())
      throw Error(fmt::format("{}: {} left but {} right images", where, left.size(), right.size()));
    for (std::size_t i = 0; i < left.size(); ++i) pairs.emplace_back(left[i], right[i]);
    return pairs;
  }
  for (int side = 0; side < 2; ++side)
    for (const auto& [key, p] : by_number[side])
      if (!by_number[1 - side].contains(key))
        throw Error(fmt::format("{}: {} has no {} image of frame {}", where, p.filename().string(),
                                side == 0 ? "right" : "left", frame_name(p, prefix[side])));
  for (const auto& [key, p] : by_number[0]) pairs.emplace_back(p, by_number[1].at(key));
  return pairs;
}

class ReplaySource final : public PacedSource {
 public:
  explicit ReplaySource(SourceUri& uri) : dir_(uri.path()) {
    info_.uri = uri.text();
    info_.fps = uri.fps(30, "as fast as taken");
    loop_ = uri.flag("loop", false);
    uri.finish();
    const std::string where = "replay://" + dir_.string();
    if (!fs::is_directory(dir_)) throw Error(where + ": no such directory");

    std::vector<fs::path> left, right;
    std::string prefix[2];
    if (fs::is_directory(dir_ / "images")) {
      prefix[0] = "I1_";
      prefix[1] = "I2_";
      left = list_images(dir_ / "images", prefix[0]);
      right = list_images(dir_ / "images", prefix[1]);
    } else {
      left = list_images(dir_ / "left", "");
      right = list_images(dir_ / "right", "");
    }
    if (left.empty())
      throw Error(where +
                  ": no frames (expected images/I1_*.png + images/I2_*.png, or left/ + right/)");
    const auto pairs = pair_images(left, right, prefix, where);

    calibration_ = load_calibration(find_calibration(where));
    const CameraIntrinsics& cam = calibration_.left;
    std::size_t bytes = 0;
    frames_.reserve(pairs.size());
    for (const auto& [left_path, right_path] : pairs) {
      Frame f{load_image(left_path), load_image(right_path)};
      if (frames_.empty()) calibration_.take_size_if_unknown(f.left.width(), f.left.height());
      const int channels = frames_.empty() ? f.left.channels() : frames_.front().left.channels();
      for (const auto* img : {&f.left, &f.right}) {
        if (img->width() != cam.width || img->height() != cam.height || img->channels() != channels)
          throw Error(fmt::format(
              "{}: {} is {}x{}x{}, the calibration and the first frame say "
              "{}x{}x{}",
              where, (img == &f.left ? left_path : right_path).filename().string(), img->width(),
              img->height(), img->channels(), cam.width, cam.height, channels));
      }
      bytes +=
          2 * static_cast<std::size_t>(f.left.stride()) * static_cast<std::size_t>(f.left.height());
      if (bytes > kMaxRecordingBytes)
        throw Error(fmt::format("{}: the recording is larger than {} MiB", where,
                                kMaxRecordingBytes >> 20));
      frames_.push_back(std::move(f));
    }
    info_.width = cam.width;
    info_.height = cam.height;
    info_.channels = frames_.front().left.channels();
    info_.description =
        fmt::format("replay {} ({} frames{}) {}x{} @ {} fps", dir_.string(), frames_.size(),
                    loop_ ? ", looped" : "", cam.width, cam.height,
                    info_.fps > 0 ? fmt::format("{}", info_.fps) : std::string("max"));
  }
  ~ReplaySource() override { stop(); }

  const SourceInfo& info() const override { return info_; }
  const StereoCalibration& calibration() const override { return calibration_; }

 private:
  struct Frame {
    Image<std::uint8_t> left, right;
  };

  fs::path find_calibration(const std::string& where) const {
    for (const char* name : {"calib.toml", "calib.txt", "calib_cam_to_cam.txt"})
      if (fs::is_regular_file(dir_ / name)) return dir_ / name;
    throw Error(where + ": no calibration (calib.toml, calib.txt or calib_cam_to_cam.txt)");
  }

  bool produce(std::uint64_t seq, ImageView<const std::uint8_t>& left,
               ImageView<const std::uint8_t>& right) override {
    if (!loop_ && seq >= frames_.size()) return false;
    const Frame& f = frames_[seq % frames_.size()];
    left = f.left.cview();
    right = f.right.cview();
    return true;
  }

  fs::path dir_;
  bool loop_ = false;
  StereoCalibration calibration_;
  std::vector<Frame> frames_;
  SourceInfo info_;
};

}  // namespace

std::unique_ptr<FrameSource> open_replay(SourceUri& uri) {
  return std::make_unique<ReplaySource>(uri);
}

}  // namespace dco::drivers
