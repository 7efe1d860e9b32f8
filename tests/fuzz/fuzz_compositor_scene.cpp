// Entry point: arbitrary bytes as a dco-compositor scene file and as its --cube/--sphere argument.
// Bad input must be refused with one line; what is accepted must be drawable: finite, of positive
// size, wholly beyond the near plane, colours in 0..1, at most kMaxObjects objects.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "dco/compositor/scene.hpp"
#include "fuzz_target.hpp"

namespace {

using namespace dco::compositor;

void check_object(const Vec3& center, float size, float nearest, const Vec3& color) {
  for (const float v : center)
    if (!std::isfinite(v)) std::abort();
  if (!(size > 0) || !std::isfinite(size) || !(nearest > kNearPlaneM)) std::abort();
  for (const float c : color)
    if (!(c >= 0 && c <= 1)) std::abort();
}

void check(const Cube& c) {
  check_object(c.center, c.size, c.center[2] - c.size / 2, c.color);
}

void check(const Sphere& s) {
  check_object(s.center, s.radius, s.center[2] - s.radius, s.color);
}

template <typename Parse>
void one_line(Parse parse, std::string_view text) {
  try {
    check(parse(text));
  } catch (const Error& e) {
    const std::string message = e.what();
    if (message.empty() || message.find('\n') != std::string::npos) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const Scene scene = parse_scene(text, "scene.txt");
    if (scene.size() > kMaxObjects) std::abort();
    for (const Cube& c : scene.cubes) check(c);
    for (const Sphere& s : scene.spheres) check(s);
  } catch (const Error& e) {
    if (std::string_view(e.what()).rfind("scene.txt:", 0) != 0) std::abort();
  }
  one_line(parse_cube, text);
  one_line(parse_sphere, text);
  return 0;
}
