#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dco/compositor/scene.hpp"

namespace dco::compositor {

std::string printable(std::string_view text) {
  std::string out(text);
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return out;
}

namespace {

// What a message quotes of a file's or an option's text: printable, and no more than a line.
std::string shown(std::string_view text) {
  constexpr std::size_t kMax = 60;
  return text.size() <= kMax ? printable(text) : printable(text.substr(0, kMax)) + "...";
}

std::vector<float> numbers(std::string_view text, char separator, const std::string& where) {
  std::vector<float> out;
  std::string s(text);
  std::size_t pos = 0;
  while (pos <= s.size()) {
    while (pos < s.size() && separator == ' ' && (s[pos] == ' ' || s[pos] == '\t')) ++pos;
    // Spaces may trail; a comma must be followed by a number.
    if (pos == s.size() && separator == ' ') break;
    std::size_t end =
        s.find_first_of(separator == ' ' ? std::string(" \t") : std::string(1, separator), pos);
    if (end == std::string::npos) end = s.size();
    const std::string token = s.substr(pos, end - pos);
    char* stop = nullptr;
    errno = 0;
    const float v = std::strtof(token.c_str(), &stop);
    // The whole token (a NUL inside it is not its end); a value too small for a float (1e-40)
    // is that tiny value, one too large is inf and refused.
    if (token.empty() || stop != token.c_str() + token.size() || (errno != 0 && errno != ERANGE) ||
        !std::isfinite(v))
      throw Error(where + ": '" + shown(token) + "' is not a number");
    out.push_back(v);
    pos = end + 1;
  }
  return out;
}

void check_object(const std::vector<float>& v, const std::string& what, const std::string& where) {
  if (v.size() != 4 && v.size() != 7)
    throw Error(where + ": a " + what + " takes X Y Z SIZE and optionally R G B, got " +
                std::to_string(v.size()) + " numbers");
  if (v[3] <= 0) throw Error(where + ": the " + what + "'s size must be positive");
  // A cube's SIZE is its edge, a sphere's its radius.
  const float nearest = v[2] - (what == "cube" ? v[3] / 2 : v[3]);
  if (!(nearest > kNearPlaneM)) {
    char text[160];
    std::snprintf(text, sizeof text,
                  ": the %s reaches to Z = %g m; objects are drawn beyond %g m in front of the "
                  "camera",
                  what.c_str(), static_cast<double>(nearest), static_cast<double>(kNearPlaneM));
    throw Error(where + text);
  }
  for (std::size_t i = 4; i < v.size(); ++i)
    if (v[i] < 0 || v[i] > 1) throw Error(where + ": colours are in 0..1");
}

template <typename T>
T make(const std::vector<float>& v) {
  T o;
  o.center = {v[0], v[1], v[2]};
  if constexpr (std::is_same_v<T, Cube>)
    o.size = v[3];
  else
    o.radius = v[3];
  if (v.size() == 7) o.color = {v[4], v[5], v[6]};
  return o;
}

}  // namespace

Cube parse_cube(std::string_view text) {
  const std::string where = "--cube '" + shown(text) + "'";
  const auto v = numbers(text, ',', where);
  check_object(v, "cube", where);
  return make<Cube>(v);
}

Sphere parse_sphere(std::string_view text) {
  const std::string where = "--sphere '" + shown(text) + "'";
  const auto v = numbers(text, ',', where);
  check_object(v, "sphere", where);
  return make<Sphere>(v);
}

Scene parse_scene(std::string_view text, const std::string& name) {
  Scene scene;
  std::istringstream in{std::string(text)};
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();  // a file written on Windows
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos) continue;
    const auto word_end = line.find_first_of(" \t", first);
    const std::string word = line.substr(first, word_end - first);
    const std::string where = name + ":" + std::to_string(number);
    const std::string rest = word_end == std::string::npos ? "" : line.substr(word_end);
    if (word == "cube") {
      const auto v = numbers(rest, ' ', where);
      check_object(v, "cube", where);
      scene.cubes.push_back(make<Cube>(v));
    } else if (word == "sphere") {
      const auto v = numbers(rest, ' ', where);
      check_object(v, "sphere", where);
      scene.spheres.push_back(make<Sphere>(v));
    } else {
      throw Error(where + ": unknown object '" + shown(word) + "' (cube or sphere)");
    }
    if (scene.size() > kMaxObjects)
      throw Error(where + ": more than " + std::to_string(kMaxObjects) + " objects");
  }
  return scene;
}

Scene load_scene(const std::string& path) {
  // A directory opens as a stream that reads nothing: refused by name, as a read error is.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error("scene '" + printable(path) + "': not a readable file");
  // kMaxObjects lines take well under a MiB: a larger file is not a scene.
  if (std::filesystem::file_size(path, ec) > kMaxSceneBytes)
    throw Error("scene '" + printable(path) + "': larger than " +
                std::to_string(kMaxSceneBytes >> 20) + " MiB");
  std::ifstream in(path);
  if (!in) throw Error("scene '" + printable(path) + "': cannot open: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error("scene '" + printable(path) + "': read failed");
  Scene scene = parse_scene(text.str(), path);
  // A scene file given on purpose and holding nothing is a mistake, not a wish for the default.
  if (scene.empty()) throw Error("scene '" + printable(path) + "': no cube or sphere in it");
  return scene;
}

}  // namespace dco::compositor
