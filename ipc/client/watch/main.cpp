// dco-watch: follows the depth ring like a renderer would and prints, once per interval, the
// frame rate, the latency from capture and from publish to the moment the frame was read, and
// the newest frame's metadata.

#include <dco/client.hpp>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <string_view>
#include <vector>

#include "dco/default_ring_path.hpp"
#include "overlay.hpp"

namespace {

void usage(std::FILE* out) {
  std::fprintf(
      out,
      "usage: dco-watch [--path FILE] [--uid UID] [--frames N] [--interval-ms MS]\n"
      "                 [--timeout-ms MS] [--poll-us US] [--copy] [--overlay FILE.ppm]\n"
      "                 [--virtual-depth M]\n"
      "  --path FILE       depth ring (default %s, or the one dcod run by hand by this user\n"
      "                    writes: $XDG_RUNTIME_DIR/dcod or the temp dir's dcod-UID)\n"
      "  --uid UID         owner the ring must have (default: own uid)\n"
      "  --frames N        stop after N frames (default: run until stopped)\n"
      "  --interval-ms MS  report period (default 1000)\n"
      "  --timeout-ms MS   give up when no frame arrives for MS (default 2000)\n"
      "  --poll-us US      wake when the daemon starts writing a frame and poll up to US\n"
      "                    for it, for the lowest latency (default 0: sleep until published)\n"
      "  --copy            copy every frame (read_latest path) instead of a view\n"
      "  --overlay FILE    at every report, write the newest frame as a PPM picture: the\n"
      "                    camera image with a virtual box that real surfaces occlude\n"
      "  --virtual-depth M distance of that box (default 1.0 m)\n",
      dco::client_tools::kServiceRingPath);
}

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

bool parse_int(std::string_view text, long long lo, long long hi, long long* out) {
  char* end = nullptr;
  const std::string s(text);
  errno = 0;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (s.empty() || errno != 0 || *end != '\0' || v < lo || v > hi) return false;
  *out = v;
  return true;
}

bool parse_double(std::string_view text, double* out) {
  char* end = nullptr;
  const std::string s(text);
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || errno != 0 || *end != '\0' || !(v > 0) || v > 1e6) return false;
  *out = v;
  return true;
}

double percentile(std::vector<double>& v, double p) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace

int main(int argc, char** argv) {
  // A write past a file size limit is then an error the overlay writer reports.
  std::signal(SIGXFSZ, SIG_IGN);
  dco::client::Options options;
  options.path = dco::client_tools::default_ring_path();
  long long frames = 0;
  long long interval_ms = 1000;
  long long timeout_ms = 2000;
  bool copy = false;
  std::string overlay;
  double virtual_depth_m = 1.0;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const bool has_value = i + 1 < argc;
    long long v = 0;
    if (arg == "--help" || arg == "-h") {
      usage(stdout);
      return 0;
    } else if (arg == "--copy") {
      copy = true;
    } else if (arg == "--overlay" && has_value) {
      overlay = argv[++i];
    } else if (arg == "--virtual-depth" && has_value &&
               parse_double(argv[i + 1], &virtual_depth_m)) {
      ++i;
    } else if (arg == "--path" && has_value) {
      options.path = argv[++i];
    } else if (arg == "--uid" && has_value && parse_int(argv[i + 1], 0, 0xffffffffLL, &v)) {
      options.expected_uid = static_cast<std::uint32_t>(v);
      ++i;
    } else if (arg == "--frames" && has_value && parse_int(argv[i + 1], 1, 1LL << 40, &v)) {
      frames = v;
      ++i;
    } else if (arg == "--interval-ms" && has_value && parse_int(argv[i + 1], 1, 3600000, &v)) {
      interval_ms = v;
      ++i;
    } else if (arg == "--timeout-ms" && has_value && parse_int(argv[i + 1], 1, 3600000, &v)) {
      timeout_ms = v;
      ++i;
    } else if (arg == "--poll-us" && has_value && parse_int(argv[i + 1], 0, 100000, &v)) {
      options.poll_us = static_cast<std::uint32_t>(v);
      ++i;
    } else {
      // One line that says what the option takes (the usage is --help's).
      const char* wants = arg == "--uid"             ? "a uid"
                          : arg == "--frames"        ? "a whole number of frames, 1 or more"
                          : arg == "--interval-ms"   ? "milliseconds in 1..3600000"
                          : arg == "--timeout-ms"    ? "milliseconds in 1..3600000"
                          : arg == "--poll-us"       ? "microseconds in 0..100000"
                          : arg == "--virtual-depth" ? "a depth in metres above 0"
                          : arg == "--overlay"       ? "a file name"
                          : arg == "--path"          ? "a file name"
                                                     : nullptr;
      if (wants != nullptr)
        std::fprintf(stderr, "dco-watch: error: %s needs %s, not %s%s%s (see --help)\n", argv[i],
                     wants, has_value ? "'" : "", has_value ? argv[i + 1] : "nothing",
                     has_value ? "'" : "");
      else
        std::fprintf(stderr, "dco-watch: error: unknown argument '%s' (see --help)\n", argv[i]);
      return 2;
    }
  }

  try {
    dco::client::Client client(options);
    std::vector<float> depth;
    std::vector<std::uint8_t> image;
    dco_frame_buffer buffer;
    dco_frame_buffer_init(&buffer);
    std::vector<double> from_capture_ms;
    std::vector<double> from_publish_ms;
    long long received = 0;
    long long torn = 0;
    // A window starts at a frame and counts the frames after it: the first frame, already
    // published when the watch starts, says nothing of the rate.
    long long window_frames = 0;
    std::int64_t window_start = 0;
    std::uint64_t last_index = 0, last_session = 0;
    long long skipped = 0;
    dco_frame_info newest;
    dco_frame_info_init(&newest);
    std::int64_t gone_since = 0;  // when the writer was seen gone, 0 while it runs
    std::vector<std::uint8_t> overlay_rgb;
    while (frames == 0 || received < frames) {
      dco::client::FrameView view;
      dco_frame_view_init(&view.raw);
      const dco_status status =
          dco_client_wait_next(client.handle(), static_cast<std::int32_t>(timeout_ms), &view.raw);
      if (status == DCO_E_OVERTAKEN) {
        ++torn;
        continue;
      }
      // A stopped daemon is waited for, as a renderer does, until --timeout-ms has passed
      // without a frame: a restarted one (another session, maybe another size) is followed.
      if (status == DCO_E_WRITER_GONE) {
        const std::int64_t t = now_ns();
        if (gone_since == 0) {
          gone_since = t;
          std::fprintf(stderr, "dco-watch: the writer stopped; waiting up to %lld ms for it\n",
                       timeout_ms);
        }
        if (t - gone_since < timeout_ms * 1'000'000) continue;
      }
      if (status != DCO_OK) throw dco::client::Error(status);
      gone_since = 0;
      const dco_frame_info info = view.info();
      if (copy) {
        const std::size_t depth_bytes = std::size_t{info.width} * info.height * sizeof(float);
        const std::size_t image_bytes = std::size_t{info.width} * info.height * info.image_channels;
        depth.resize(depth_bytes / sizeof(float));
        image.resize(image_bytes);
        buffer.depth = depth.data();
        buffer.depth_stride = std::size_t{info.width} * sizeof(float);
        buffer.depth_capacity = depth_bytes;
        buffer.image = image_bytes ? image.data() : nullptr;
        buffer.image_stride = std::size_t{info.width} * info.image_channels;
        buffer.image_capacity = image_bytes;
        if (!client.copy(view, buffer)) {
          ++torn;
          continue;
        }
      }
      const std::int64_t t = now_ns();
      // Publish indices count per ring session: a restarted daemon's first frame skips nothing.
      if (last_index != 0 && info.session_id == last_session && info.publish_index > last_index + 1)
        skipped += static_cast<long long>(info.publish_index - last_index - 1);
      last_index = info.publish_index;
      last_session = info.session_id;
      from_capture_ms.push_back(static_cast<double>(t - info.capture_ns) / 1e6);
      from_publish_ms.push_back(static_cast<double>(t - info.publish_ns) / 1e6);
      newest = info;
      if (received++ == 0)
        window_start = t;
      else
        ++window_frames;
      const std::int64_t elapsed = t - window_start;
      if (elapsed >= interval_ms * 1'000'000 || (frames != 0 && received == frames)) {
        if (!overlay.empty()) {
          render_occlusion_overlay(view, virtual_depth_m, overlay_rgb);
          std::string error;
          // A frame overwritten while it was drawn is skipped, never written torn.
          if (client.still_valid(view) &&
              !write_ppm(overlay, overlay_rgb, info.width, info.height, error)) {
            std::fprintf(stderr, "dco-watch: error: %s\n", error.c_str());
            return 1;
          }
        }
        std::printf(
            "fps %.1f  latency capture p50 %.2f ms max %.2f ms  publish p50 %.3f ms max %.3f ms  "
            "skipped %lld  overtaken %lld\n"
            "  session %016llx  seq %llu  index %llu  slot %u  %ux%u  image %u ch  "
            "fx %.2f fy %.2f cx %.2f cy %.2f baseline %.4f m\n",
            elapsed > 0 ? static_cast<double>(window_frames) * 1e9 / static_cast<double>(elapsed)
                        : 0.0,
            percentile(from_capture_ms, 0.5), percentile(from_capture_ms, 1.0),
            percentile(from_publish_ms, 0.5), percentile(from_publish_ms, 1.0), skipped, torn,
            static_cast<unsigned long long>(newest.session_id),
            static_cast<unsigned long long>(newest.frame_seq),
            static_cast<unsigned long long>(newest.publish_index), newest.slot, newest.width,
            newest.height, newest.image_channels, newest.fx, newest.fy, newest.cx, newest.cy,
            newest.baseline_m);
        std::fflush(stdout);
        from_capture_ms.clear();
        from_publish_ms.clear();
        window_frames = 0;
        window_start = t;
      }
    }
  } catch (const std::exception& e) {  // the client's errors, and out of memory with --copy
    std::fprintf(stderr, "dco-watch: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
