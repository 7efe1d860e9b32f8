// dco-bench: the full depth pipeline in its real-time runtime on a synthetic sequence and on the
// real Karlsruhe clip — throughput, per-stage times, latency and drops at a camera's frame rate —
// next to OpenCV StereoSGBM (3-way) + WLS on the same frames in the same run. `dco-bench ipc`
// measures depth delivery through the shared-memory ring instead (ipc_bench.cpp).

#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/calib3d.hpp>

#include "dco/core/calibration.hpp"
#include "dco/core/config.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/core/memory_policy.hpp"
#include "dco/core/rectifier.hpp"
#include "dco/core/stopwatch.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/core/usable_cpus.hpp"
#include "dco/gpu/backend.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"
#include "dco/pipeline/densify/densifier.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "dco/pipeline/row_team.hpp"
#include "dco/pipeline/runtime/depth_runtime.hpp"
#include "dco/pipeline/runtime/histogram.hpp"
#include "dco/tools/command_line.hpp"
#include "dco/tools/frame_sequence.hpp"
#include "dco/tools/json.hpp"
#include "dco/tools/sgbm_wls.hpp"
#include "ipc_bench.hpp"
#include "median.hpp"

namespace {

namespace fs = std::filesystem;
namespace rt = dco::pipeline::runtime;
using dco::tools::UsageError;

constexpr std::string_view kUsage =
    R"(usage: dco-bench [--sequence synthetic|karlsruhe|all] [--synthetic NAME] [--size WxH]
                 [--frames N] [--warmup N] [--rounds N] [--karlsruhe DIR] [--fps F]
                 [--paced-frames N] [--json] [--backend auto|cpu|cuda] [--config FILE]
                 [--set KEY=VALUE]

Runs the depth pipeline in the real-time runtime and, on the same frames in the same run,
OpenCV StereoSGBM (3-way) + WLS. Per sequence:
  throughput  runtime.deterministic on, frames pushed as fast as it takes them: ms per frame
              (first push to last result / frames), frames per second and the mean time of
              each stage; the steady interval (first result to last result / (frames - 1):
              the pipeline's period once it is full); how long a new runtime took to its first
              result;
  latency     frames pushed at --fps (capture time = the frame's due time), newest wins at the
              entry and a frame that waited past its entry deadline is late (no depth):
              capture-to-result latency p50 / p99, the frames dropped (late ones included),
              the mean time between results and the mean age of the newest depth over the
              run (what a renderer holds: its latency plus how long it is held);
              with runtime.release_latency_ms also the capture-to-ready latency and the
              results that were overdue or handed on early;
  peer        SGBM 3-way + WLS ms per frame; ratio = peer / dco.
The throughput run and the peer take turns, --rounds times, so that both meet the machine in
the same state; each round's figures are printed, and the headline figures are the medians over
the rounds (the ratio: the median of the rounds' ratios).
Each run (and the peer) first takes the sequence's first --warmup frames, untimed, so that what
starting up costs once (buffers touched for the first time, the flow's set-up) is not counted as
the frames' work. The timed pass is a new sequence: its ms per frame still pays for filling the
pipeline and for a first solve with no previous frame; the latency run leaves that sequence's
first --warmup frames out of its figures as well (a camera's first frames, once per start).
With the CUDA backend it also runs the sparse stereo stage, the contour stage and the densify
solver on the CPU and on the GPU over the same frames: the stage times and how many output
pixels differ (the tolerance is zero: the GPU computes the same integer costs, float operations
and decisions).

  --sequence S        synthetic, karlsruhe or all (default all)
  --synthetic NAME    hand | boxes | static (default hand)
  --size WxH          synthetic resolution (default 1280x720)
  --frames N          frames of each sequence (default 20; the Karlsruhe clip has 10)
  --warmup N          frames of the untimed pass before each run (default 8, at most the
                      frames: the runtime takes its frame pool's entries in turn, so its
                      buffers are all touched after 8 frames)
  --rounds N          turns of the throughput run and the peer (default 3)
  --karlsruhe DIR     the clip (default: the shared data's 2010_03_09_drive_0023), max-disp 96
  --fps F             input rate of the latency run (default 30)
  --paced-frames N    frames pushed in the latency run, the sequence played back and forth
                      (default 90)
  --json              print one JSON object instead of text: the first sequence's ms_per_frame,
                      peer_ms_per_frame, ratio, latency_p50_ms, latency_p99_ms, ... at the top
                      level and every sequence under "sequences"
  --backend B         runtime.backend: auto (CUDA when a device works), cpu or cuda
  --config FILE       TOML with [stereo], [contour], [densify] and [runtime] tables
  --set KEY=VALUE     override one parameter, e.g. --set runtime.threads=3
  -h, --help          print this help

`dco-bench ipc [...]` measures depth delivery to client processes instead: see
`dco-bench ipc --help`.

Exit status: 0 success, 1 bad data (missing frames, bad parameter), 2 bad command line.
)";

struct Options {
  std::string sequence = "all";
  std::string synthetic = "hand";
  int width = 1280, height = 720, frames = 20;
  int warmup = 8;
  int rounds = 3;
  fs::path karlsruhe = fs::path(DCO_DATA_DIR) / "karlsruhe_sequences" / "2010_03_09_drive_0023";
  double fps = 30;
  int paced_frames = 90;
  bool json = false;
  std::optional<fs::path> config;
  std::vector<std::string> overrides;
  bool help = false;
};

double parse_fps(const std::string& text) {
  try {
    std::size_t used = 0;
    const double fps = std::stod(text, &used);
    // Below 0.01 fps a run of frames would take days, and 1/fps in nanoseconds soon leaves int64.
    if (used == text.size() && fps >= 0.01 && fps <= 1000) return fps;
  } catch (const std::exception&) {
  }
  throw UsageError(fmt::format("--fps needs a rate in [0.01, 1000], not '{}'", text));
}

Options parse_args(int argc, char** argv) {
  Options opt;
  dco::tools::ArgCursor args(argc, argv);
  while (args.next()) {
    const std::string_view arg = args.name();
    if (arg == "-h" || arg == "--help")
      opt.help = args.flag();
    else if (arg == "--sequence")
      opt.sequence = args.value();
    else if (arg == "--synthetic")
      opt.synthetic = args.value();
    else if (arg == "--size") {
      const dco::tools::ImageSize size =
          dco::tools::parse_image_size("--size", args.value(), 64, dco::synthetic::kMaxSide);
      opt.width = size.width;
      opt.height = size.height;
    } else if (arg == "--frames")
      opt.frames = args.int_value();
    else if (arg == "--warmup")
      opt.warmup = args.int_value();
    else if (arg == "--rounds")
      opt.rounds = args.int_value();
    else if (arg == "--karlsruhe")
      opt.karlsruhe = args.value();
    else if (arg == "--fps")
      opt.fps = parse_fps(args.value());
    else if (arg == "--paced-frames")
      opt.paced_frames = args.int_value();
    else if (arg == "--json")
      opt.json = args.flag();
    else if (arg == "--config")
      opt.config = args.value();
    else if (arg == "--set")
      opt.overrides.push_back(args.value());
    else if (arg == "--backend") {
      const std::string backend = args.value();
      if (backend != "auto" && backend != "cpu" && backend != "cuda")
        throw UsageError("--backend " + backend + ": not one of auto, cpu, cuda");
      opt.overrides.push_back("runtime.backend=" + backend);
    } else if (arg.starts_with("-"))
      throw UsageError(fmt::format("unknown option {}", arg));
    else
      throw UsageError(fmt::format("unexpected argument '{}'", arg));
  }
  if (opt.help) return opt;
  dco::tools::check_synthetic_name(opt.synthetic);
  if (opt.sequence != "synthetic" && opt.sequence != "karlsruhe" && opt.sequence != "all")
    throw UsageError(
        fmt::format("--sequence must be synthetic, karlsruhe or all, not '{}'", opt.sequence));
  // Frames are held in memory and counted in int: a bound keeps both sane.
  constexpr int kMaxFrames = 100000;
  if (opt.frames < 1 || opt.frames > kMaxFrames)
    throw UsageError(fmt::format("--frames must be within 1..{}", kMaxFrames));
  if (opt.paced_frames < 1 || opt.paced_frames > kMaxFrames)
    throw UsageError(fmt::format("--paced-frames must be within 1..{}", kMaxFrames));
  if (opt.warmup < 0 || opt.warmup > kMaxFrames)
    throw UsageError(fmt::format("--warmup must be within 0..{}", kMaxFrames));
  if (opt.rounds < 1) throw UsageError("--rounds must be >= 1");

  return opt;
}

struct Params {
  dco::pipeline::PipelineParams pipeline;
  rt::RuntimeParams runtime;
  bool max_disparity_given = false;  // by --config or --set; else each sequence's own range
};

Params load_params(const Options& opt) {
  Params p;
  dco::ConfigSchema schema;
  dco::pipeline::register_params(schema, p.pipeline);
  rt::register_params(schema, p.runtime);
  if (opt.config) schema.load_file(*opt.config);
  dco::tools::apply_sets(schema, opt.overrides);
  p.max_disparity_given = schema.was_set("stereo.max_disparity");
  dco::tools::validate_given(opt.config.has_value(), [&] {
    dco::pipeline::validate(p.pipeline);
    rt::validate(p.runtime);
  });
  return p;
}

struct Frames {
  std::string name;
  std::vector<dco::tools::StereoInput> pairs;
  int max_disparity = 0;
};

// Every frame is held in memory (the timed loop reads none from disk): `frames` pairs like
// `first` must fit in half the machine's memory, else a clear error rather than bad_alloc or the
// kernel's OOM killer.
void check_frames_fit(int frames, const dco::tools::StereoInput& first) {
  const auto bytes = [](const auto& image) {
    return static_cast<double>(image.width()) * image.height() * image.channels() *
           sizeof(*image.cview().row(0));
  };
  const double per_frame = bytes(first.left) + bytes(first.right) + bytes(first.gt_disparity);
  const double memory =
      static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGE_SIZE));
  if (memory > 0 && frames * per_frame > memory / 2)
    throw UsageError(fmt::format(
        "--frames {}: {} frames of {}x{} take {:.1f} GB in memory, more than half of this "
        "machine's {:.1f} GB",
        frames, frames, first.left.width(), first.left.height(), frames * per_frame / 1e9,
        memory / 1e9));
}

Frames load_frames(const Options& opt, bool synthetic, int default_max_disparity) {
  Frames f;
  std::unique_ptr<dco::tools::FrameSequence> source;
  if (synthetic) {
    f.name = fmt::format("synthetic {} {}x{}", opt.synthetic, opt.width, opt.height);
    source = dco::tools::make_synthetic_sequence(opt.synthetic, opt.width, opt.height, opt.frames,
                                                 false);
  } else {
    f.name = "karlsruhe " + opt.karlsruhe.filename().string();
    const fs::path images = opt.karlsruhe / "images";
    if (!fs::is_directory(images))
      throw dco::Error(fmt::format("no Karlsruhe images in '{}'", images.string()));
    source = dco::tools::make_pattern_sequence(
        (images / "I1_%06d.png").string(), (images / "I2_%06d.png").string(), 0, -1, std::nullopt);
  }
  f.max_disparity = source->max_disparity().value_or(default_max_disparity);
  dco::tools::StereoInput input;
  while (static_cast<int>(f.pairs.size()) < opt.frames && source->next(input)) {
    if (f.pairs.empty()) check_frames_fit(opt.frames, input);
    f.pairs.push_back(input);
  }
  if (f.pairs.empty()) throw dco::Error(fmt::format("{}: no frames", f.name));
  return f;
}

// The CUDA stages against the CPU stages on the same frames.
struct BackendCheck {
  double cpu_stereo_ms = 0, cuda_stereo_ms = 0;  // mean after the first (warm-up) frame
  long differing_pixels = 0;                     // of the sparse maps at input size
  double max_abs_diff = 0;                       // over pixels finite in both
  double cpu_contour_ms = 0, cuda_contour_ms = 0;
  long differing_contour_pixels = 0;           // of the contour maps, M_fuse and M_I together
  double cpu_solve_ms = 0, cuda_solve_ms = 0;  // the densify solver on the CPU's contour results
  bool refined = false;  // whether the frames went through the photometric refinement
  double cpu_refine_ms = 0, cuda_refine_ms = 0;  // its time, after the solve
  long differing_dense_pixels = 0;
  double cpu_rectify_ms = 0, cuda_rectify_ms = 0;  // per pair, the frames taken as raw images
  long differing_rectified_bytes = 0;
};

// Bytes that differ, every channel.
long differing(dco::ImageView<const std::uint8_t> a, dco::ImageView<const std::uint8_t> b) {
  long n = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width * a.channels; ++x) n += a.row(y)[x] != b.row(y)[x];
  return n;
}

// A raw rig of the frames' size (lens distortion, cameras slightly rotated against each other),
// so both backends have real maps to rectify the frames through.
dco::StereoCalibration bench_rig(int width, int height) {
  dco::StereoCalibration c;
  const double f = 0.8 * width;
  c.left = {dco::CameraModel::kPinhole,   width, height, f, f, width / 2.0, height / 2.0,
            {-0.05, 0.01, 5e-4, -3e-4, 0}};
  c.right = {dco::CameraModel::kPinhole,
             width,
             height,
             f * 1.01,
             f * 1.01,
             width / 2.0 + 2,
             height / 2.0 - 2,
             {-0.04, 0.008, -2e-4, 4e-4, 0}};
  cv::Mat rotation;
  cv::Rodrigues(cv::Vec3d(0.01, -0.02, 0.005), rotation);  // about 1.3 degrees
  for (int i = 0; i < 9; ++i) c.rotation[i] = rotation.at<double>(i / 3, i % 3);
  c.translation = {-0.1, 0.002, 0.001};
  c.source = "bench rig";
  return c;
}

// The CPU rectifier (cv::remap) against the GPU remapper on every frame pair.
void compare_rectification(const Frames& frames, const dco::gpu::BackendChoice& backend,
                           BackendCheck& c) {
  const auto& first = frames.pairs.front();
  const dco::Rectifier rectifier(bench_rig(first.left.width(), first.left.height()));
  const auto remapper = backend.remapper(rectifier);
  dco::Image<std::uint8_t> cpu_l, cpu_r, cuda_l, cuda_r;
  int timed = 0;
  for (std::size_t i = 0; i < frames.pairs.size(); ++i) {
    const auto& f = frames.pairs[i];
    dco::Stopwatch t;
    rectifier.rectify(f.left.cview(), f.right.cview(), cpu_l, cpu_r);
    const double cpu_ms = t.lap_ms();
    rectifier.rectify(f.left.cview(), f.right.cview(), cuda_l, cuda_r, remapper.get());
    const double cuda_ms = t.lap_ms();
    if (i > 0 || frames.pairs.size() == 1) {
      c.cpu_rectify_ms += cpu_ms;
      c.cuda_rectify_ms += cuda_ms;
      ++timed;
    }
    c.differing_rectified_bytes +=
        differing(cpu_l.cview(), cuda_l.cview()) + differing(cpu_r.cview(), cuda_r.cview());
  }
  c.cpu_rectify_ms /= timed;
  c.cuda_rectify_ms /= timed;
}

long differing(dco::ImageView<const float> a, dco::ImageView<const float> b, double* max_abs) {
  long n = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const float u = a.row(y)[x], v = b.row(y)[x];
      if (std::memcmp(&u, &v, sizeof u) == 0) continue;
      ++n;
      if (max_abs != nullptr && std::isfinite(u) && std::isfinite(v))
        *max_abs = std::max(*max_abs, static_cast<double>(std::abs(u - v)));
    }
  return n;
}

BackendCheck compare_with_cpu(const dco::pipeline::PipelineParams& params, const Frames& frames,
                              const dco::pipeline::StageFactories& cuda) {
  namespace pl = dco::pipeline;
  BackendCheck c;
  // The CUDA stage searches every disparity ("auto" is "full" there); so does the CPU one here.
  dco::stereo::StereoParams full_search = params.stereo;
  full_search.search_range = "full";
  const auto cpu_stage = dco::stereo::make_cpu_stereo_matcher(full_search);
  const auto cuda_stage = cuda.stereo(params.stereo);
  const auto cpu_contour = dco::contour::make_cpu_contour_extractor(params.contour);
  const auto cuda_contour = cuda.contour(params.contour);
  dco::densify::Densifier cuda_densifier(params.densify, cuda.densify_solver,
                                         cuda.photometric_refinement);
  // The GPU refines frames that the CPU's pixel budget skips: here the CPU refines them too, so
  // the two compare like with like.
  dco::densify::DensifyParams cpu_densify = params.densify;
  const int width = frames.pairs.front().left.width(), height = frames.pairs.front().left.height();
  c.refined = cuda_densifier.refines(width, height);
  if (c.refined)
    cpu_densify.photometric.max_pixels =
        std::max(cpu_densify.photometric.max_pixels, width * height);
  dco::densify::Densifier cpu_densifier(cpu_densify);
  dco::Image<float> cuda_dense;
  // The CPU stage's slots of frames i - 2, i - 1 and i: the contours of i - 1 use all three.
  std::array<pl::StereoSlot, 3> slots;
  dco::Image<float> cuda_sparse;
  pl::DepthResult a, b;
  int timed = 0, contour_timed = 0;
  for (std::size_t i = 0; i < frames.pairs.size(); ++i) {
    const auto& f = frames.pairs[i];
    pl::StereoSlot& slot = slots[i % 3];
    pl::prepare_frame(params.stereo, f.left.cview(), static_cast<int>(i), slot);
    pl::stereo_frame(*cpu_stage, f.left.cview(), f.right.cview(), slot, c.refined);
    cuda_stage->compute(f.left.cview(), f.right.cview(), cuda_sparse);
    if (i > 0 || frames.pairs.size() == 1) {
      c.cpu_stereo_ms += cpu_stage->last_timings().total_ms;
      c.cuda_stereo_ms += cuda_stage->last_timings().total_ms;
      ++timed;
    }
    c.differing_pixels += differing(slot.sparse.cview(), cuda_sparse.cview(), &c.max_abs_diff);
    if (i < 2) continue;
    const pl::StereoSlot& centre = slots[(i - 1) % 3];
    pl::contour_frame(*cpu_contour, centre, &slots[(i - 2) % 3], &slot, a);
    pl::contour_frame(*cuda_contour, centre, &slots[(i - 2) % 3], &slot, b);
    if (i > 2 || frames.pairs.size() == 3) {
      c.cpu_contour_ms += a.contour_timings.total_ms;
      c.cuda_contour_ms += b.contour_timings.total_ms;
      ++contour_timed;
    }
    c.differing_contour_pixels += differing(a.contours.cview(), b.contours.cview()) +
                                  differing(a.m_fuse.cview(), b.m_fuse.cview(), nullptr) +
                                  differing(a.m_intensity.cview(), b.m_intensity.cview(), nullptr);
    // Both densifiers on the CPU's contour result `a`, each with its own previous frame.
    pl::densify_frame(cuda_densifier, a);
    std::swap(a.dense, cuda_dense);
    const double cuda_solve_ms = a.densify_timings.solve_ms;
    const double cuda_refine_ms = a.densify_timings.refine_ms;
    pl::densify_frame(cpu_densifier, a);
    if (i > 2 || frames.pairs.size() == 3) {
      c.cpu_solve_ms += a.densify_timings.solve_ms;
      c.cuda_solve_ms += cuda_solve_ms;
      c.cpu_refine_ms += a.densify_timings.refine_ms;
      c.cuda_refine_ms += cuda_refine_ms;
    }
    c.differing_dense_pixels += differing(a.dense.cview(), cuda_dense.cview(), nullptr);
  }
  c.cpu_stereo_ms /= timed;
  c.cuda_stereo_ms /= timed;
  if (contour_timed > 0) {
    c.cpu_contour_ms /= contour_timed;
    c.cuda_contour_ms /= contour_timed;
    c.cpu_solve_ms /= contour_timed;
    c.cuda_solve_ms /= contour_timed;
    c.cpu_refine_ms /= contour_timed;
    c.cuda_refine_ms /= contour_timed;
  }
  return c;
}

// Every result's times, in the order the runtime hands them on (on its own thread). Room for
// `capacity` results is made up front and kept by take(), so recording never allocates on the
// runtime's thread while it is being timed.
class ResultTimes {
 public:
  explicit ResultTimes(std::size_t capacity) { times_.reserve(capacity); }
  rt::DepthRuntime::ResultCallback callback() {
    return [this](const dco::pipeline::DepthResult&, const rt::FrameTimes& t) {
      const std::lock_guard lock(mutex_);
      times_.push_back(t);
    };
  }
  std::vector<rt::FrameTimes> take() {
    const std::lock_guard lock(mutex_);
    std::vector<rt::FrameTimes> taken(times_.begin(), times_.end());
    times_.clear();
    return taken;
  }

 private:
  std::mutex mutex_;
  std::vector<rt::FrameTimes> times_;
};

double ms_between(rt::Clock::time_point from, rt::Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

// The runtime's figures (RuntimeStats) over the results of the timed pass, measured the way the
// runtime measures them.
struct PassFigures {
  rt::DurationSummary latency, ready, stereo, contour, densify;
  // The age of the newest depth a renderer holds (now - its capture time), averaged over the
  // time from the first result to the last, and the mean time between results: fewer results
  // can still mean younger depth, when each one starts sooner.
  double depth_age_ms = 0, result_interval_ms = 0;
};

rt::DurationSummary summary_of(const rt::Histogram& h) {
  return {h.count(), h.percentile(50), h.percentile(99), h.mean_ms(), h.max_ms()};
}

PassFigures figures_of(const std::vector<rt::FrameTimes>& times) {
  rt::Histogram latency, ready, stereo, contour, densify;
  for (const rt::FrameTimes& t : times) {
    latency.record(ms_between(t.capture, t.release));
    ready.record(ms_between(t.capture, t.densify_end));
    stereo.record(rt::stereo_stage_ms(t));
    contour.record(rt::contour_stage_ms(t));
    densify.record(ms_between(t.densify_start, t.densify_end));
  }
  PassFigures f{summary_of(latency), summary_of(ready), summary_of(stereo), summary_of(contour),
                summary_of(densify)};
  // Between two results the held depth ages linearly from the earlier one's latency: the area
  // under that sawtooth over the time it spans.
  double area = 0;
  for (std::size_t k = 1; k < times.size(); ++k) {
    const rt::FrameTimes& held = times[k - 1];
    const double from = ms_between(held.capture, held.release);
    const double to = ms_between(held.capture, times[k].release);
    area += (to - from) * (from + to) / 2;
  }
  if (times.size() >= 2) {
    const double span = ms_between(times.front().release, times.back().release);
    if (span > 0) {
      f.depth_age_ms = area / span;
      f.result_interval_ms = span / static_cast<double>(times.size() - 1);
    }
  }
  return f;
}

// The counts of `after` less those of `before`: what one pass of a runtime added.
rt::RuntimeStats counts_since(const rt::RuntimeStats& before, const rt::RuntimeStats& after) {
  rt::RuntimeStats d = after;
  d.pushed -= before.pushed;
  d.dropped -= before.dropped;
  d.late -= before.late;
  d.published -= before.published;
  d.overdue -= before.overdue;
  d.early -= before.early;
  return d;
}

// One turn of the throughput run and the peer.
struct Round {
  double ms_per_frame = 0, peer_ms_per_frame = 0;
  double steady_ms = 0;  // first result to last / (frames - 1): no filling, no draining
  double ratio() const { return peer_ms_per_frame / ms_per_frame; }
};

struct Result {
  std::string name;
  std::string backend, backend_message;
  std::optional<BackendCheck> check;
  int width = 0, height = 0, frames = 0, max_disparity = 0, threads = 0, warmup = 0;
  bool parallel_flow = false;  // the flow cue's two fields on two threads
  int opencv_threads = 0;      // runtime.opencv_threads resolved (0: OpenCV's own choice)
  // Threads sharing each stage's row-wise steps (stereo.row_threads, ... resolved).
  int stereo_row_threads = 1, contour_row_threads = 1, densify_row_threads = 1;
  bool shares_rows() const {
    return stereo_row_threads > 1 || contour_row_threads > 1 || densify_row_threads > 1;
  }
  std::vector<Round> rounds;
  double ms_per_frame = 0;  // the medians over the rounds
  double steady_ms = 0;
  double peer_ms_per_frame = 0;
  double ratio = 0;            // the median of the rounds' ratios
  double first_result_ms = 0;  // a new runtime: first push to first result (the warm-up pass)
  PassFigures throughput;      // every round's frames
  // Of every round's frames (warm-up included), those whose match planes, those whose early
  // contour work (intensity gradients, stereo cue) and those whose share of the next frame's
  // contour step (the reused flow field turned round) the stereo thread did.
  long planes_on_stereo = 0, early_contour_on_stereo = 0, next_contour_on_stereo = 0,
       planes_frames = 0;
  double planes_share() const {
    return planes_frames > 0 ? static_cast<double>(planes_on_stereo) / planes_frames : 0.0;
  }
  double early_contour_share() const {
    return planes_frames > 0 ? static_cast<double>(early_contour_on_stereo) / planes_frames : 0.0;
  }
  double next_contour_share() const {
    return planes_frames > 0 ? static_cast<double>(next_contour_on_stereo) / planes_frames : 0.0;
  }
  double fps = 0;
  int paced_frames = 0;
  double release_latency_ms = 0;  // runtime.release_latency_ms of the latency run
  int release_priority = 0;       // runtime.release_priority of the latency run
  rt::RuntimeStats paced;         // the counts of its timed pass: pushed, dropped, late, ...
  PassFigures paced_figures;
};

Result run(const Options& opt, const Params& base, const Frames& frames) {
  Params p = base;
  // dco and the peer search the same range: the one asked for, else the sequence's own.
  const int max_disparity =
      base.max_disparity_given ? base.pipeline.stereo.max_disparity : frames.max_disparity;
  p.pipeline.stereo.max_disparity = max_disparity;
  Result r;
  r.name = frames.name;
  r.width = frames.pairs[0].left.width();
  r.height = frames.pairs[0].left.height();
  r.frames = static_cast<int>(frames.pairs.size());
  r.warmup = std::min(opt.warmup, r.frames);
  r.max_disparity = max_disparity;
  const dco::gpu::BackendChoice backend =
      dco::gpu::choose_backend(p.runtime.backend, p.pipeline.stereo);
  r.threads = rt::stage_threads(p.runtime);
  r.parallel_flow = dco::contour::parallel_flow_fields(p.pipeline.contour);
  r.opencv_threads =
      rt::opencv_threads_for(p.runtime.opencv_threads, r.threads, dco::usable_cpus());
  r.stereo_row_threads = dco::pipeline::RowTeam::threads_for(p.pipeline.stereo.row_threads);
  r.contour_row_threads = dco::pipeline::RowTeam::threads_for(p.pipeline.contour.row_threads);
  r.densify_row_threads = dco::pipeline::RowTeam::threads_for(p.pipeline.densify.row_threads);
  r.backend = backend.backend;
  r.backend_message = backend.message;

  // Each run first passes the sequence's first --warmup frames through the same runtime
  // untimed, and the peer likewise, so that starting up is not counted as a frame's work.
  const auto warmup_frames = std::span(frames.pairs).first(static_cast<std::size_t>(r.warmup));
  // Throughput: every frame, as fast as the runtime takes them; then the peer on the same frames.
  // The two take turns so that a drift of the machine's speed meets both alike.
  std::vector<rt::FrameTimes> all_times;
  std::vector<double> first_results;
  for (int round = 0; round < opt.rounds; ++round) {
    Round turn;
    {
      rt::RuntimeParams runtime = p.runtime;
      runtime.deterministic = true;
      ResultTimes results(frames.pairs.size());
      rt::DepthRuntime pipeline(p.pipeline, runtime, results.callback(), {}, backend.stages);
      pipeline.start();
      auto start = rt::Clock::now();
      if (!warmup_frames.empty()) {
        for (const auto& f : warmup_frames) pipeline.push(f.left.cview(), f.right.cview());
        pipeline.drain();
        first_results.push_back(ms_between(start, results.take().front().release));
        start = rt::Clock::now();
      }
      for (const auto& f : frames.pairs) pipeline.push(f.left.cview(), f.right.cview());
      pipeline.drain();
      const std::vector<rt::FrameTimes> times = results.take();
      if (static_cast<int>(times.size()) != r.frames)
        throw dco::Error(fmt::format("{}: the deterministic run published {} of {} frames",
                                     frames.name, times.size(), r.frames));
      if (warmup_frames.empty()) first_results.push_back(ms_between(start, times.front().release));
      turn.ms_per_frame = ms_between(start, times.back().release) / r.frames;
      turn.steady_ms =
          r.frames > 1 ? ms_between(times.front().release, times.back().release) / (r.frames - 1)
                       : turn.ms_per_frame;
      const rt::RuntimeStats st = pipeline.stats();
      r.planes_on_stereo += st.planes_on_stereo_thread;
      r.early_contour_on_stereo += st.early_contour_on_stereo_thread;
      r.next_contour_on_stereo += st.next_contour_on_stereo_thread;
      r.planes_frames += st.published;
      all_times.insert(all_times.end(), times.begin(), times.end());
    }
    for (const auto& f : warmup_frames)
      dco::tools::run_sgbm_wls(f.left.cview(), f.right.cview(), max_disparity);
    double peer_ms = 0;
    for (const auto& f : frames.pairs)
      peer_ms += dco::tools::run_sgbm_wls(f.left.cview(), f.right.cview(), max_disparity).time_ms;
    turn.peer_ms_per_frame = peer_ms / r.frames;
    r.rounds.push_back(turn);
  }
  const auto median_of = [&](auto figure) {
    std::vector<double> v;
    for (const Round& turn : r.rounds) v.push_back(figure(turn));
    return dco::bench::median(std::move(v));
  };
  r.ms_per_frame = median_of([](const Round& t) { return t.ms_per_frame; });
  r.steady_ms = median_of([](const Round& t) { return t.steady_ms; });
  r.peer_ms_per_frame = median_of([](const Round& t) { return t.peer_ms_per_frame; });
  r.ratio = median_of([](const Round& t) { return t.ratio(); });
  r.first_result_ms = dco::bench::median(first_results);
  r.throughput = figures_of(all_times);
  {  // Latency: a camera's pace; the sequence is played back and forth so motion stays smooth.
    ResultTimes results(static_cast<std::size_t>(r.warmup + opt.paced_frames));
    rt::DepthRuntime pipeline(p.pipeline, p.runtime, results.callback(), {}, backend.stages);
    pipeline.start();
    const auto period = std::chrono::duration_cast<rt::Clock::duration>(
        std::chrono::duration<double>(1.0 / opt.fps));
    const int n = r.frames;
    const auto play = [&](int count, int timed_after, rt::RuntimeStats& before) {
      const auto start = rt::Clock::now();
      for (int i = 0; i < count; ++i) {
        const int cycle = std::max(1, 2 * n - 2);
        const int k = n == 1 ? 0 : (i % cycle < n ? i % cycle : cycle - i % cycle);
        const auto due = start + i * period;
        std::this_thread::sleep_until(due);
        if (i == timed_after) before = pipeline.stats();
        const auto& f = frames.pairs[static_cast<std::size_t>(k)];
        pipeline.push(f.left.cview(), f.right.cview(), due);
      }
      pipeline.drain();
      return start + timed_after * period;
    };
    // The warm-up frames, then a new sequence whose first --warmup frames are not counted either:
    // they wait for their lookahead and solve with no previous frame, as a camera's first frames
    // do once, and would otherwise stand in the timed frames' tail.
    rt::RuntimeStats before;
    play(r.warmup, 0, before);
    results.take();
    const auto timed_from = play(r.warmup + opt.paced_frames, r.warmup, before);
    std::vector<rt::FrameTimes> timed = results.take();
    std::erase_if(timed, [&](const rt::FrameTimes& t) { return t.capture < timed_from; });
    r.fps = opt.fps;
    r.release_latency_ms = p.runtime.release_latency_ms;
    r.release_priority = p.runtime.release_priority;
    r.paced_frames = opt.paced_frames;
    // Late, overdue and early count from the first timed push (a warm-up frame still in flight
    // then may fall on either side); every timed frame is either published or dropped.
    r.paced = counts_since(before, pipeline.stats());
    r.paced.pushed = opt.paced_frames;
    r.paced.published = static_cast<long>(timed.size());
    r.paced.dropped = r.paced.pushed - r.paced.published;
    r.paced_figures = figures_of(timed);
  }
  if (backend.stages.stereo) {
    r.check = compare_with_cpu(p.pipeline, frames, backend.stages);
    compare_rectification(frames, backend, *r.check);
  }
  return r;
}

void print_text(const Result& r) {
  const PassFigures& t = r.throughput;
  const rt::RuntimeStats& l = r.paced;
  const PassFigures& ls = r.paced_figures;
  fmt::print(
      "{}: {} frames of {}x{}, max-disp {}, {} stage thread(s){}{}{}, each run after an untimed "
      "pass over the first {}\n",
      r.name, r.frames, r.width, r.height, r.max_disparity, r.threads,
      r.parallel_flow ? " (+ a flow worker)" : "",
      r.shares_rows()
          ? fmt::format(" (rows on {} / {} / {} threads in stereo / contour / densify)",
                        r.stereo_row_threads, r.contour_row_threads, r.densify_row_threads)
          : "",
      r.opencv_threads > 0 ? fmt::format(", OpenCV's loops on {} thread(s)", r.opencv_threads) : "",
      r.warmup);
  fmt::print(
      "  dco      {:8.1f} ms/frame  ({:.2f} fps, median of {} rounds); a new runtime's first "
      "result "
      "after {:.0f} ms\n",
      r.ms_per_frame, 1000.0 / r.ms_per_frame, r.rounds.size(), r.first_result_ms);
  fmt::print("  steady   {:8.1f} ms between results once the pipeline is full ({:.2f} fps)\n",
             r.steady_ms, 1000.0 / r.steady_ms);
  fmt::print(
      "  stages   stereo {:.1f}  contour {:.1f}  densify {:.1f} ms  (mean; p99 {:.1f} / {:.1f} / "
      "{:.1f})\n",
      t.stereo.mean_ms, t.contour.mean_ms, t.densify.mean_ms, t.stereo.p99_ms, t.contour.p99_ms,
      t.densify.p99_ms);
  fmt::print(
      "  planes   the densify stage's match planes ran on the stereo thread for {} of {} frames, "
      "the contour stage's early work (gradients, stereo cue) for {}, the next frame's reused "
      "flow field for {}\n",
      r.planes_on_stereo, r.planes_frames, r.early_contour_on_stereo, r.next_contour_on_stereo);
  fmt::print(
      "  latency  p50 {:.1f} ms  p99 {:.1f} ms  (p99 - p50 {:.1f} ms) at {:g} fps input; "
      "{} of {} frames dropped ({} late), {} published\n",
      ls.latency.p50_ms, ls.latency.p99_ms, ls.latency.p99_ms - ls.latency.p50_ms, r.fps, l.dropped,
      l.pushed, l.late, l.published);
  fmt::print("  age      the newest depth {:.1f} ms old on average; a result every {:.1f} ms\n",
             ls.depth_age_ms, ls.result_interval_ms);
  if (r.release_latency_ms > 0)
    fmt::print(
        "  release  at capture + {:g} ms (the latest {:.2f} ms after); ready p50 {:.1f} ms  p99 "
        "{:.1f} ms; {} overdue, {} early; {}\n",
        r.release_latency_ms, ls.latency.max_ms - r.release_latency_ms, ls.ready.p50_ms,
        ls.ready.p99_ms, l.overdue, l.early,
        l.release_realtime ? fmt::format("release thread at SCHED_FIFO {}", r.release_priority)
        : r.release_priority > 0
            ? std::string("release thread a normal one (SCHED_FIFO not allowed here)")
            : std::string("release thread a normal one"));
  fmt::print(
      "  peer     {:8.1f} ms/frame  OpenCV StereoSGBM 3-way + WLS; ratio peer / dco {:.3f} (the "
      "median of the rounds' ratios)\n",
      r.peer_ms_per_frame, r.ratio);
  for (std::size_t i = 0; i < r.rounds.size(); ++i)
    fmt::print("  round {}  dco {:.1f} (steady {:.1f}), peer {:.1f} ms/frame, ratio {:.3f}\n",
               i + 1, r.rounds[i].ms_per_frame, r.rounds[i].steady_ms,
               r.rounds[i].peer_ms_per_frame, r.rounds[i].ratio());
  fmt::print("  {}\n", r.backend_message);
  if (r.check)
    fmt::print(
        "  stereo   CPU {:.2f} ms, CUDA {:.2f} ms per frame (ratio {:.1f}); {} output pixels "
        "differ (max {:g} px)\n",
        r.check->cpu_stereo_ms, r.check->cuda_stereo_ms,
        r.check->cpu_stereo_ms / r.check->cuda_stereo_ms, r.check->differing_pixels,
        r.check->max_abs_diff);
  if (r.check && r.check->cpu_contour_ms > 0)
    fmt::print(
        "  contour  CPU {:.2f} ms, CUDA {:.2f} ms per frame (ratio {:.1f}, DIS flow on the CPU in "
        "both); {} output pixels differ\n",
        r.check->cpu_contour_ms, r.check->cuda_contour_ms,
        r.check->cpu_contour_ms / r.check->cuda_contour_ms, r.check->differing_contour_pixels);
  if (r.check && r.check->cpu_solve_ms > 0)
    fmt::print(
        "  densify  solve CPU {:.2f} ms, CUDA {:.2f} ms per frame (ratio {:.1f}, the system built "
        "on the CPU in both); {} output pixels differ\n",
        r.check->cpu_solve_ms, r.check->cuda_solve_ms,
        r.check->cpu_solve_ms / r.check->cuda_solve_ms, r.check->differing_dense_pixels);
  if (r.check && r.check->refined)
    fmt::print(
        "  densify  photometric refinement CPU {:.2f} ms, CUDA {:.2f} ms per frame (ratio {:.1f}, "
        "with transfers; the CPU refines every frame size here)\n",
        r.check->cpu_refine_ms, r.check->cuda_refine_ms,
        r.check->cpu_refine_ms / r.check->cuda_refine_ms);
  if (r.check)
    fmt::print(
        "  rectify  CPU {:.2f} ms, CUDA {:.2f} ms per pair with transfers (ratio {:.1f}, the "
        "frames through a distorted rig); {} output bytes differ\n",
        r.check->cpu_rectify_ms, r.check->cuda_rectify_ms,
        r.check->cpu_rectify_ms / r.check->cuda_rectify_ms, r.check->differing_rectified_bytes);
}

// {"ms_per_frame": ..., "peer_ms_per_frame": ..., "ratio": ..., "steady_ms": ...} of each round.
std::vector<std::string> round_objects(const Result& r) {
  using dco::tools::json_number;
  std::vector<std::string> out;
  for (const Round& turn : r.rounds)
    out.push_back(fmt::format(
        "{{\"ms_per_frame\": {}, \"peer_ms_per_frame\": {}, \"ratio\": {}, \"steady_ms\": {}}}",
        json_number(turn.ms_per_frame), json_number(turn.peer_ms_per_frame),
        json_number(turn.ratio()), json_number(turn.steady_ms)));
  return out;
}

// The fields of one sequence, without braces.
std::string json_fields(const Result& r) {
  using dco::tools::json_number;
  const PassFigures& t = r.throughput;
  const rt::RuntimeStats& l = r.paced;
  const PassFigures& ls = r.paced_figures;
  return fmt::format(
             "\"name\": {}, \"width\": {}, \"height\": {}, \"frames\": {}, \"max_disparity\": {}, "
             "\"threads\": {}, \"parallel_flow\": {}, \"opencv_threads\": {}, "
             "\"stereo_row_threads\": {}, "
             "\"contour_row_threads\": {}, \"densify_row_threads\": {}, "
             "\"warmup_frames\": {}, "
             "\"first_result_ms\": {}, "
             "\"ms_per_frame\": {}, \"fps\": {}, \"steady_ms\": {}, \"stereo_ms\": {}, "
             "\"contour_ms\": {}, \"densify_ms\": {}, \"input_fps\": {}, \"latency_p50_ms\": {}, "
             "\"latency_p99_ms\": {}, \"latency_max_ms\": {}, \"ready_p50_ms\": {}, "
             "\"ready_p99_ms\": {}, \"depth_age_ms\": {}, \"result_interval_ms\": {}, "
             "\"release_latency_ms\": {}, \"release_realtime\": {}, \"overdue\": {}, "
             "\"early\": {}, "
             "\"paced_frames\": {}, \"dropped\": {}, \"late\": {}, "
             "\"published\": {}, \"planes_on_stereo_thread\": {}, "
             "\"early_contour_on_stereo_thread\": {}, \"next_contour_on_stereo_thread\": {}, "
             "\"peer_ms_per_frame\": {}, \"ratio\": {}",
             dco::tools::json_string(r.name), r.width, r.height, r.frames, r.max_disparity,
             r.threads, r.parallel_flow ? "true" : "false", r.opencv_threads, r.stereo_row_threads,
             r.contour_row_threads, r.densify_row_threads, r.warmup, json_number(r.first_result_ms),
             json_number(r.ms_per_frame), json_number(1000.0 / r.ms_per_frame),
             json_number(r.steady_ms), json_number(t.stereo.mean_ms),
             json_number(t.contour.mean_ms), json_number(t.densify.mean_ms), json_number(r.fps),
             json_number(ls.latency.p50_ms), json_number(ls.latency.p99_ms),
             json_number(ls.latency.max_ms), json_number(ls.ready.p50_ms),
             json_number(ls.ready.p99_ms), json_number(ls.depth_age_ms),
             json_number(ls.result_interval_ms), json_number(r.release_latency_ms),
             l.release_realtime ? "true" : "false", l.overdue, l.early, l.pushed, l.dropped, l.late,
             l.published, json_number(r.planes_share()), json_number(r.early_contour_share()),
             json_number(r.next_contour_share()), json_number(r.peer_ms_per_frame),
             json_number(r.ratio)) +
         fmt::format(", \"rounds\": [{}]", fmt::join(round_objects(r), ", ")) +
         fmt::format(", \"backend\": {}", dco::tools::json_string(r.backend)) +
         (r.check ? fmt::format(
                        ", \"cpu_stereo_ms\": {}, \"cuda_stereo_ms\": {}, "
                        "\"cuda_differing_pixels\": {}, \"cuda_max_abs_diff\": {}, "
                        "\"cpu_contour_ms\": {}, \"cuda_contour_ms\": {}, "
                        "\"cuda_contour_differing_pixels\": {}, \"cpu_solve_ms\": {}, "
                        "\"cuda_solve_ms\": {}, \"refined\": {}, \"cpu_refine_ms\": {}, "
                        "\"cuda_refine_ms\": {}, "
                        "\"cuda_dense_differing_pixels\": {}, "
                        "\"cpu_rectify_ms\": {}, \"cuda_rectify_ms\": {}, "
                        "\"cuda_rectify_differing_bytes\": {}",
                        json_number(r.check->cpu_stereo_ms), json_number(r.check->cuda_stereo_ms),
                        r.check->differing_pixels, json_number(r.check->max_abs_diff),
                        json_number(r.check->cpu_contour_ms), json_number(r.check->cuda_contour_ms),
                        r.check->differing_contour_pixels, json_number(r.check->cpu_solve_ms),
                        json_number(r.check->cuda_solve_ms), r.check->refined ? "true" : "false",
                        json_number(r.check->cpu_refine_ms), json_number(r.check->cuda_refine_ms),
                        r.check->differing_dense_pixels, json_number(r.check->cpu_rectify_ms),
                        json_number(r.check->cuda_rectify_ms), r.check->differing_rectified_bytes)
                  : std::string());
}

}  // namespace

int main(int argc, char** argv) {
  dco::retain_freed_memory();  // before any thread starts: see memory_policy.hpp
  if (argc > 1 && std::string_view(argv[1]) == "ipc")
    return dco::bench::run_ipc_bench(argc - 1, argv + 1);
  return dco::tools::run_tool("dco-bench", [&] {
    const Options opt = parse_args(argc, argv);
    if (opt.help) {
      fmt::print("{}", kUsage);
      return 0;
    }
    const Params params = load_params(opt);
    std::vector<Frames> sequences;
    if (opt.sequence != "karlsruhe") sequences.push_back(load_frames(opt, true, 0));
    if (opt.sequence != "synthetic") sequences.push_back(load_frames(opt, false, 96));
    std::vector<Result> results;
    for (const Frames& frames : sequences) {
      results.push_back(run(opt, params, frames));
      if (!opt.json) print_text(results.back());
    }
    if (opt.json) {
      std::string all;
      for (const Result& r : results) all += (all.empty() ? "{" : ", {") + json_fields(r) + "}";
      fmt::print("{{{}, \"sequences\": [{}]}}\n", json_fields(results.front()), all);
    }
    return 0;
  });
}
