#include "dco/tools/command_line.hpp"

#include <charconv>
#include <stdexcept>
#include <string>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "dco/core/config.hpp"
#include "dco/core/error.hpp"
#include "dco/core/printable.hpp"
#include "dco/core/synthetic_scene.hpp"

namespace dco::tools {

bool ArgCursor::next() {
  if (++index_ >= argc_) return false;
  name_ = argv_[index_];
  inline_value_.reset();
  if (const auto eq = name_.find('='); name_.starts_with("--") && eq != std::string_view::npos) {
    inline_value_ = std::string(name_.substr(eq + 1));
    name_ = name_.substr(0, eq);
  }
  return true;
}

std::string ArgCursor::value() {
  if (inline_value_) return *std::exchange(inline_value_, std::nullopt);
  if (index_ + 1 >= argc_) throw UsageError(fmt::format("option {} needs a value", name_));
  return argv_[++index_];
}

bool ArgCursor::flag() const {
  if (inline_value_) throw UsageError(fmt::format("option {} takes no value", name_));
  return true;
}

int ArgCursor::int_value() {
  const std::string_view option = name_;
  const std::string text = value();
  int v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size())
    throw UsageError(fmt::format("option {} needs an integer, not '{}'", option, text));
  return v;
}

double ArgCursor::number_value(double min, double max) {
  const std::string_view option = name_;
  const std::string text = value();
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || !(v >= min && v <= max))
    throw UsageError(
        fmt::format("option {} needs a number in [{}, {}], not '{}'", option, min, max, text));
  return v;
}

ImageSize parse_image_size(std::string_view option, const std::string& text, int minimum,
                           int maximum) {
  ImageSize size;
  const auto x = text.find('x');
  try {
    if (x == std::string::npos) throw std::invalid_argument("no x");
    std::size_t used = 0;
    size.width = std::stoi(text.substr(0, x), &used);
    if (used != x) throw std::invalid_argument("width");
    size.height = std::stoi(text.substr(x + 1), &used);
    if (used != text.size() - x - 1) throw std::invalid_argument("height");
  } catch (const std::exception&) {
    throw UsageError(fmt::format("{} needs WIDTHxHEIGHT, not '{}'", option, text));
  }
  if (size.width < minimum || size.height < minimum)
    throw UsageError(
        fmt::format("{} must be at least {}x{}, not {}", option, minimum, minimum, text));
  if (size.width > maximum || size.height > maximum)
    throw UsageError(
        fmt::format("{} must be at most {}x{}, not {}", option, maximum, maximum, text));
  return size;
}

std::string one_line(std::string text) {
  for (char& c : text)
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return printable(text);
}

int run_tool(std::string_view tool, const std::function<int()>& body) {
  try {
    return body();
  } catch (const UsageError& e) {
    fmt::print(stderr, "{}: error: {} (see --help)\n", tool, one_line(e.what()));
    return 2;
  } catch (const cv::Exception& e) {
    fmt::print(stderr, "{}: error: OpenCV: {}\n", tool, one_line(e.err));
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "{}: error: {}\n", tool, one_line(e.what()));
    return 1;
  }
}

void apply_sets(ConfigSchema& schema, const std::vector<std::string>& assignments) {
  for (const std::string& assignment : assignments) {
    try {
      schema.set(assignment);
    } catch (const Error& e) {
      throw UsageError(e.what());  // it names the --set
    }
  }
}

void validate_given(bool from_file, const std::function<void()>& validate) {
  try {
    validate();
  } catch (const Error& e) {
    if (from_file) throw;
    throw UsageError(std::string("--set: ") + e.what());
  }
}

bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  std::error_code ec;
  return a.lexically_normal() == b.lexically_normal() ||
         (std::filesystem::equivalent(a, b, ec) && !ec);
}

void check_synthetic_name(const std::string& name) {
  try {
    synthetic::preset(name, 64, 64);
  } catch (const Error& e) {
    throw UsageError(e.what());
  }
}

}  // namespace dco::tools
