#include "dco/drivers/source_uri.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "dco/core/error.hpp"

namespace dco::drivers {
namespace {

template <typename T>
bool parse_whole(const std::string& s, T& out) {
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && end == s.data() + s.size() && !s.empty();
}

}  // namespace

SourceUri::SourceUri(std::string_view uri) : text_(uri) {
  const auto sep = uri.find("://");
  if (sep == std::string_view::npos || sep == 0)
    throw Error(fmt::format("source '{}': expected scheme://..., e.g. synthetic://hand", uri));
  scheme_ = uri.substr(0, sep);
  std::string_view rest = uri.substr(sep + 3);
  const auto q = rest.find('?');
  path_ = rest.substr(0, q);
  if (q == std::string_view::npos) return;
  std::string_view query = rest.substr(q + 1);
  while (!query.empty()) {
    const auto amp = query.find('&');
    const std::string_view item = query.substr(0, amp);
    const auto eq = item.find('=');
    if (eq == std::string_view::npos || eq == 0)
      throw Error(fmt::format("source '{}': parameter '{}' is not key=value", uri, item));
    const std::string key(item.substr(0, eq));
    if (!params_.emplace(key, std::string(item.substr(eq + 1))).second)
      throw Error(fmt::format("source '{}': parameter '{}' given twice", uri, key));
    if (amp == std::string_view::npos) break;
    query.remove_prefix(amp + 1);
  }
}

std::optional<std::string> SourceUri::take(const std::string& key) {
  read_.push_back(key);
  const auto it = params_.find(key);
  if (it == params_.end()) return std::nullopt;
  return it->second;
}

int SourceUri::integer(const std::string& key, int fallback, int min, int max) {
  const auto v = take(key);
  if (!v) return fallback;
  int out = 0;
  if (!parse_whole(*v, out) || out < min || out > max)
    throw Error(
        fmt::format("source '{}': {}={} must be an integer in [{}, {}]", text_, key, *v, min, max));
  return out;
}

double SourceUri::number(const std::string& key, double fallback, double min, double max) {
  const auto v = take(key);
  if (!v) return fallback;
  double out = 0;
  if (!parse_whole(*v, out) || !std::isfinite(out) || out < min || out > max)
    throw Error(
        fmt::format("source '{}': {}={} must be a number in [{}, {}]", text_, key, *v, min, max));
  return out;
}

double SourceUri::fps(double fallback, const char* zero_means) {
  const auto v = take("fps");
  if (!v) return fallback;
  double out = 0;
  if (!parse_whole(*v, out) || !(out == 0 || (out >= kMinFps && out <= kMaxFps)))
    throw Error(fmt::format("source '{}': fps={} must be a number in [{:g}, {:g}], or 0 ({})",
                            text_, *v, kMinFps, kMaxFps, zero_means));
  return out;
}

bool SourceUri::flag(const std::string& key, bool fallback) {
  const auto v = take(key);
  if (!v) return fallback;
  if (*v == "1" || *v == "true") return true;
  if (*v == "0" || *v == "false") return false;
  throw Error(fmt::format("source '{}': {}={} must be 0 or 1", text_, key, *v));
}

void SourceUri::finish() const {
  for (const auto& [key, value] : params_)
    if (std::find(read_.begin(), read_.end(), key) == read_.end())
      throw Error(fmt::format("source '{}': unknown parameter '{}'", text_, key));
}

}  // namespace dco::drivers
