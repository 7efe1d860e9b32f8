#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace dco::drivers {

// "scheme://path?key=value&key=value" with strict, typed access: every parameter must be read by
// the source (finish() rejects the rest), so a misspelt option is an error, not a silent default.
class SourceUri {
 public:
  // Throws dco::Error when there is no "scheme://" or a parameter lacks "=" or repeats.
  explicit SourceUri(std::string_view uri);

  const std::string& text() const { return text_; }
  const std::string& scheme() const { return scheme_; }
  const std::string& path() const { return path_; }

  // Each throws dco::Error naming the URI and the key when the value does not parse or is out of
  // [min, max]; absent keys give the fallback.
  int integer(const std::string& key, int fallback, int min, int max);
  double number(const std::string& key, double fallback, double min, double max);
  bool flag(const std::string& key, bool fallback);
  // The frame rate "fps": kMinFps..kMaxFps, or 0, which means `zero_means` (said in errors).
  // Below kMinFps the frame period would not fit the clock.
  static constexpr double kMinFps = 0.01, kMaxFps = 1000;
  double fps(double fallback, const char* zero_means);
  // The raw text of a parameter (a file name, a layout name); nullopt when absent.
  std::optional<std::string> value(const std::string& key) { return take(key); }
  // Throws dco::Error for any parameter no getter asked for.
  void finish() const;

 private:
  std::optional<std::string> take(const std::string& key);

  std::string text_, scheme_, path_;
  std::map<std::string, std::string> params_;
  std::vector<std::string> read_;
};

}  // namespace dco::drivers
