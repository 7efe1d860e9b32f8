// dco-compositor: what a renderer on the headset does with dco. It follows the depth ring, puts
// the camera image and the real depth into an offscreen GLES framebuffer, draws virtual objects
// depth-tested against the real depth, shows them in a window or writes PNG frames, and prints
// the GPU time of each.

#include <dco/client.hpp>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "dco/compositor/renderer.hpp"
#include "dco/compositor/scene.hpp"
#include "dco/default_ring_path.hpp"

namespace {

using namespace dco::compositor;
using Clock = std::chrono::steady_clock;

std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) {
  g_stop = true;
}

void usage(std::FILE* out) {
  std::fprintf(
      out,
      "usage: dco-compositor [--ring FILE] [--uid UID] [--out FILE.png] [--mask FILE.png]\n"
      "                      [--frames N]\n"
      "                      [--cube X,Y,Z,SIZE[,R,G,B]]... [--sphere X,Y,Z,R[,R,G,B]]...\n"
      "                      [--scene FILE] [--soft N] [--wait S] [--width W --height H]\n"
      "                      [--egl auto|surfaceless|device] [--window [--display NAME]]\n"
      "  --ring FILE     depth ring of dcod (default %s, or the one dcod run by hand by this\n"
      "                  user writes: $XDG_RUNTIME_DIR/dcod or the temp dir's dcod-UID)\n"
      "  --uid UID       owner the ring must have (default: own uid; the packaged dcod runs as\n"
      "                  the user dcod)\n"
      "  --out FILE      composited frames as PNG; a printf pattern (frame_%%04d.png) keeps\n"
      "                  every frame, a plain name the last one\n"
      "  --mask FILE     where virtual objects are visible, as a grey PNG (same naming)\n"
      "  --frames N      frames to composite, then exit 0 (default 1; with --window 0: until\n"
      "                  the window is closed); 0 = until stopped (SIGINT, SIGTERM)\n"
      "  --cube, --sphere  a virtual object in camera coordinates (x right, y down, z ahead,\n"
      "                  metres); without any, a cube at 0,0,1,0.3 and a sphere at\n"
      "                  0.25,0,1.5,0.2\n"
      "  --scene FILE    objects from a file: 'cube X Y Z SIZE [R G B]', 'sphere X Y Z R ...'\n"
      "  --soft N        soft occlusion blending over N px around depth contours (0..8; 0 =\n"
      "                  hard, the default)\n"
      "  --wait S        how long to wait for the daemon, at start and after it stops (default 5)\n"
      "  --width, --height  refuse a ring of another size\n"
      "  --egl WHICH     headless EGL display: surfaceless, device (a GPU enumerated by EGL),\n"
      "                  or auto (default: the first that works)\n"
      "  --window        also show the frames in an X11 window, scaled to fit\n"
      "  --display NAME  the X display of the window (default $DISPLAY); implies --window\n",
      dco::client_tools::kServiceRingPath);
}

bool parse_int(const char* text, long lo, long hi, long* out) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text, &end, 10);
  if (!*text || errno != 0 || *end != '\0' || v < lo || v > hi) return false;
  *out = v;
  return true;
}

// A file name, or a pattern with one %d (%0Nd) for the frame number; anything else is refused,
// since the pattern never reaches printf as a format.
void check_pattern(const std::string& pattern, const char* option) {
  if (pattern.empty()) throw Error(std::string(option) + ": an empty file name");
  const auto p = pattern.find('%');
  if (p == std::string::npos) return;
  std::size_t i = p + 1;
  while (i < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[i]))) ++i;
  // N of %0Nd: two digits at most (a frame number has no more than 20).
  if (i >= pattern.size() || pattern[i] != 'd' || pattern.find('%', i) != std::string::npos ||
      i - p - 1 > 2 || (i - p - 1 == 2 && std::atoi(pattern.c_str() + p + 1) > 20))
    throw Error(std::string(option) + " '" + pattern +
                "': a name with at most one %d or %0Nd (N up to 20)");
}

std::string frame_name(const std::string& pattern, long index) {
  const auto p = pattern.find('%');
  if (p == std::string::npos) return pattern;
  const auto d = pattern.find('d', p);
  const std::string spec = pattern.substr(p + 1, d - p - 1);
  const int width = spec.empty() ? 0 : std::atoi(spec.c_str());
  std::string number = std::to_string(index);
  if (static_cast<int>(number.size()) < width)
    number.insert(0, static_cast<std::size_t>(width) - number.size(), '0');
  return pattern.substr(0, p) + number + pattern.substr(d + 1);
}

struct Args {
  std::string ring = dco::client_tools::default_ring_path(), out, mask, scene_file;
  long frames = -1, soft = 0, wait_s = 5, width = 0, height = 0;  // frames -1: the default
  long uid = -1;                                                  // -1: own uid
  bool window = false;
  std::string display;
  HeadlessDisplay egl = HeadlessDisplay::kAuto;
  Scene scene;
};

int run(const Args& args) {
  Scene scene = args.scene;
  if (!args.scene_file.empty()) {
    Scene more = load_scene(args.scene_file);
    scene.cubes.insert(scene.cubes.end(), more.cubes.begin(), more.cubes.end());
    scene.spheres.insert(scene.spheres.end(), more.spheres.begin(), more.spheres.end());
  }
  if (scene.empty()) {
    scene.cubes.push_back(parse_cube("0,0,1,0.3"));
    scene.spheres.push_back(parse_sphere("0.25,0,1.5,0.2"));
  }
  if (scene.size() > kMaxObjects)
    throw Error("more than " + std::to_string(kMaxObjects) + " objects in the scene");

  dco::client::Options options;
  options.path = args.ring;
  if (args.uid >= 0) options.expected_uid = static_cast<std::uint32_t>(args.uid);
  options.expected_width = static_cast<std::uint32_t>(args.width);
  options.expected_height = static_cast<std::uint32_t>(args.height);
  const auto patience = std::chrono::seconds(args.wait_s);

  // The daemon may still be starting: wait for its ring, but not for ever.
  std::optional<dco::client::Client> client;
  for (const auto until = Clock::now() + patience;;) {
    if (g_stop) {
      std::fprintf(stderr, "dco-compositor: stopped while waiting for %s\n", args.ring.c_str());
      return 0;
    }
    try {
      client.emplace(options);
      break;
    } catch (const dco::client::Error& e) {
      if (e.status() != DCO_E_NO_SEGMENT || Clock::now() >= until) {
        if (e.status() == DCO_E_NO_SEGMENT)
          std::fprintf(stderr,
                       "dco-compositor: no depth ring at %s after %ld s: is dcod running?\n",
                       args.ring.c_str(), args.wait_s);
        else
          std::fprintf(stderr, "dco-compositor: %s: %s\n", args.ring.c_str(), e.what());
        return 1;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }

  std::optional<Renderer> renderer_storage;
  if (args.window) {
    WindowOptions window;
    window.display = args.display;
    if (args.width > 0 && args.height > 0) {
      window.width = static_cast<int>(args.width);
      window.height = static_cast<int>(args.height);
    }
    renderer_storage.emplace(window);
  } else {
    renderer_storage.emplace(args.egl);
  }
  Renderer& renderer = *renderer_storage;
  std::fprintf(stderr, "dco-compositor: %s on %s, %zu cubes, %zu spheres, %s occlusion%s\n",
               renderer.gl_renderer(), renderer.egl_display().c_str(), scene.cubes.size(),
               scene.spheres.size(), args.soft ? "soft" : "hard",
               args.window ? ", in a window" : "");
  const long frames = args.frames >= 0 ? args.frames : (args.window ? 0 : 1);
  RenderOptions render_options;
  render_options.soft_radius_px = static_cast<int>(args.soft);

  std::vector<std::uint8_t> mask, picture;
  auto last_frame = Clock::now();
  bool announced_gone = false;
  for (long done = 0; frames == 0 || done < frames;) {
    if (g_stop) {
      std::fprintf(stderr, "dco-compositor: stopped after %ld frames\n", done);
      return 0;
    }
    std::optional<dco::client::FrameView> view;
    try {
      view = client->wait_next(std::chrono::milliseconds(200));
    } catch (const dco::client::Error& e) {
      if (e.status() != DCO_E_WRITER_GONE) throw;
      if (!announced_gone)
        std::fprintf(stderr, "dco-compositor: dcod stopped; waiting %ld s for it to come back\n",
                     args.wait_s);
      announced_gone = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    const auto no_frame_for_too_long = [&] {
      if (Clock::now() - last_frame <= patience) return false;
      std::fprintf(stderr, "dco-compositor: no frame from %s for %ld s%s\n", args.ring.c_str(),
                   args.wait_s,
                   view ? " (each was rewritten by dcod before its upload ended)" : "");
      return true;
    };
    if (!view) {
      // A window stays responsive (and repainted) while the daemon is quiet.
      if (renderer.windowed() && !renderer.present()) {
        std::fprintf(stderr, "dco-compositor: window closed after %ld frames\n", done);
        return 0;
      }
      if (no_frame_for_too_long()) return 1;
      continue;
    }
    if (announced_gone) std::fprintf(stderr, "dco-compositor: dcod is back\n");
    announced_gone = false;
    const dco_frame_info& info = view->info();
    RealFrame frame;
    frame.camera = {static_cast<int>(info.width),
                    static_cast<int>(info.height),
                    info.fx,
                    info.fy,
                    info.cx,
                    info.cy};
    // Straight from the ring, no copy: once the upload has taken the pixels the slot is checked,
    // and a frame the daemon rewrote meanwhile is given up before it is drawn.
    frame.depth = view->raw.depth;
    frame.depth_stride = info.depth_stride;
    // The compositor shows grey; a colour ring is drawn without its image.
    if (info.image_channels == 1) {
      frame.image = view->raw.image;
      frame.image_stride = info.image_stride;
    }
    const RenderTimes times =
        renderer.render(frame, scene, render_options, [&] { return client->still_valid(*view); });
    if (!times.drawn) {
      if (no_frame_for_too_long()) return 1;
      continue;
    }
    last_frame = Clock::now();
    char gpu[32] = "n/a";
    if (times.gpu_ms >= 0) std::snprintf(gpu, sizeof gpu, "%.2f ms", times.gpu_ms);
    std::printf("frame %ld seq %llu %ux%u: GPU %s, upload to glFinish %.2f ms\n", done,
                static_cast<unsigned long long>(info.frame_seq), info.width, info.height, gpu,
                times.wall_ms);
    std::fflush(stdout);
    if (renderer.windowed() && !renderer.present()) {
      std::fprintf(stderr, "dco-compositor: window closed after %ld frames\n", done + 1);
      return 0;
    }
    if (args.out.empty() && args.mask.empty()) {
      ++done;
      continue;
    }
    const std::vector<std::uint8_t>& rgba = renderer.read_rgba();
    if (!args.out.empty()) {
      // The picture a user sees is opaque; coverage goes to --mask.
      picture.resize(rgba.size() / 4 * 3);
      for (std::size_t i = 0, n = rgba.size() / 4; i < n; ++i)
        std::copy_n(&rgba[4 * i], 3, &picture[3 * i]);
      write_png(frame_name(args.out, done), picture.data(), frame.camera.width, frame.camera.height,
                3);
    }
    if (!args.mask.empty()) {
      mask.resize(rgba.size() / 4);
      for (std::size_t i = 0; i < mask.size(); ++i) mask[i] = rgba[4 * i + 3];
      write_png(frame_name(args.mask, done), mask.data(), frame.camera.width, frame.camera.height,
                1);
    }
    ++done;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string_view a = argv[i];
      if (a == "--help" || a == "-h") {
        usage(stdout);
        return 0;
      }
      if (a == "--window") {
        args.window = true;
        continue;
      }
      static constexpr std::string_view kTakesValue[] = {
          "--ring",   "--uid",  "--out",  "--mask",  "--scene",  "--cube", "--sphere",
          "--frames", "--soft", "--wait", "--width", "--height", "--egl",  "--display"};
      if (std::find(std::begin(kTakesValue), std::end(kTakesValue), a) == std::end(kTakesValue))
        throw Error("unknown option " + printable(a));
      if (i + 1 >= argc) throw Error(std::string(a) + " needs a value");
      const char* value = argv[++i];
      auto number = [&](long lo, long hi, long* out) {
        if (!parse_int(value, lo, hi, out))
          throw Error(std::string(a) + " takes a whole number in " + std::to_string(lo) + ".." +
                      std::to_string(hi) + ", not '" + printable(value) + "'");
      };
      if (a == "--ring") {
        args.ring = value;
      } else if (a == "--uid") {
        number(0, 0xfffffffeL, &args.uid);
      } else if (a == "--out") {
        check_pattern(value, "--out");
        args.out = value;
      } else if (a == "--mask") {
        check_pattern(value, "--mask");
        args.mask = value;
      } else if (a == "--scene") {
        if (!args.scene_file.empty()) throw Error("--scene given twice (one file holds them all)");
        args.scene_file = value;
      } else if (a == "--cube")
        args.scene.cubes.push_back(parse_cube(value));
      else if (a == "--sphere")
        args.scene.spheres.push_back(parse_sphere(value));
      else if (a == "--frames")
        number(0, 1'000'000'000, &args.frames);
      else if (a == "--soft")
        number(0, 8, &args.soft);
      else if (a == "--wait")
        number(0, 3600, &args.wait_s);
      else if (a == "--width")
        number(1, 16384, &args.width);
      else if (a == "--height")
        number(1, 16384, &args.height);
      else if (a == "--egl")
        args.egl = parse_headless_display(value);
      else if (a == "--display") {
        args.display = value;
        args.window = true;
      }
    }
    // One without the other would be compared with a ring of height or width 0.
    if ((args.width == 0) != (args.height == 0)) throw Error("--width and --height go together");
  } catch (const Error& e) {
    std::fprintf(stderr, "dco-compositor: %s\n", e.what());
    usage(stderr);
    return 2;
  }
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
  // A write past a file size limit is then an error the PNG writer reports.
  std::signal(SIGXFSZ, SIG_IGN);
  try {
    return run(args);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dco-compositor: %s\n", e.what());
    return 1;
  }
}
