#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace dco::compositor {

// A failure the compositor reports in one line (bad arguments, EGL/GL errors, unreadable files).
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Text as errors quote it: on one line, control characters shown as '?'.
std::string printable(std::string_view text);

using Vec3 = std::array<float, 3>;

// The near plane objects are drawn from (metres); every object lies wholly beyond it, since a
// face cut by it would open the object up.
inline constexpr float kNearPlaneM = 0.01f;
// Objects per scene: each is a draw call per frame.
inline constexpr std::size_t kMaxObjects = 4096;
inline constexpr std::uintmax_t kMaxSceneBytes = 1 << 20;

// Virtual objects in camera coordinates of the rectified left camera: x right, y down, z forward,
// metres. Cubes are axis-aligned in that frame.
struct Cube {
  Vec3 center{};
  float size = 0;
  Vec3 color{0.9f, 0.3f, 0.2f};
};
struct Sphere {
  Vec3 center{};
  float radius = 0;
  Vec3 color{0.2f, 0.5f, 0.9f};
};
struct Scene {
  std::vector<Cube> cubes;
  std::vector<Sphere> spheres;
  bool empty() const { return cubes.empty() && spheres.empty(); }
  std::size_t size() const { return cubes.size() + spheres.size(); }
};

// "X,Y,Z,SIZE[,R,G,B]" (command line) into a cube or a sphere of radius SIZE.
Cube parse_cube(std::string_view text);
Sphere parse_sphere(std::string_view text);

// A scene file: one object per line, "cube X Y Z SIZE [R G B]" or "sphere X Y Z RADIUS [R G B]",
// colours in 0..1, '#' starts a comment, at most kMaxObjects. Errors name the file and line.
Scene parse_scene(std::string_view text, const std::string& name);
Scene load_scene(const std::string& path);

}  // namespace dco::compositor
