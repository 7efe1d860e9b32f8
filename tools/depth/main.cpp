// dco-depth: runs the depth pipeline offline on files — one stereo pair, every scene of a
// manifest, or a sequence (numbered image files or a synthetic scene) — and writes disparity
// as PFM, plus pictures a person can judge it by.

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <regex>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "dco/core/calibration.hpp"
#include "dco/core/config.hpp"
#include "dco/core/depth_conversion.hpp"
#include "dco/core/disparity_io.hpp"
#include "dco/core/error.hpp"
#include "dco/core/file_replace.hpp"
#include "dco/core/image_io.hpp"
#include "dco/core/memory_policy.hpp"
#include "dco/core/rectifier.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "dco/tools/command_line.hpp"
#include "dco/tools/frame_sequence.hpp"
#include "dco/tools/scene_manifest.hpp"
#include "overlays.hpp"

namespace {

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

namespace fs = std::filesystem;
using dco::tools::UsageError;

constexpr std::string_view kUsage =
    R"(usage: dco-depth --left L --right R [--calib FILE] [--max-disp N] --out D.pfm
                 [--depth-out Z.pfm|Z.png] [--overlay-dir DIR] [--sparse] [options]
       dco-depth --scenes TSV [--data-root DIR] --out-dir DIR [--max-disp N] [--sparse] [options]
       dco-depth --left-pattern P --right-pattern P [--first N] [--count N] [--calib FILE]
                 [--max-disp N] --out-dir DIR [--overlays] [--sparse] [options]
       dco-depth --synthetic NAME [--size WxH] [--frames N] [--color] [--right-gain G]
                 [--right-offset O] [--right-rows R] [--right-roll DEG] [--lens-falloff K]
                 [--max-disp N] --out-dir DIR [--overlays] [--sparse] [options]
       dco-depth --list-params

Computes disparity with the depth pipeline (stereo -> contours -> densify) and writes it in
pixels of the input image as PFM: dense, every pixel set; with --sparse the stereo stage's
sparse map, +inf where it has no value.

One pair:
  --left, --right L R  rectified (or, with --calib, raw) 8-bit images of one size
  --calib FILE         calibration (dco TOML, Middlebury calib.txt, KITTI/Karlsruhe)
  --out D.pfm          disparity output
  --depth-out Z        metric depth: .pfm in metres (+inf unknown) or .png in millimetres
  --overlay-dir DIR    also write disparity colours, contours and an occlusion composite
Every scene of a manifest:
  --scenes TSV         writes DIR/<scene with '/' replaced by '_'>.pfm and .time_ms, and for
                       the dense map also .sparse.pfm (the stereo stage's map it was filled in
                       from, which dco-eval uses to split the error)
  --data-root DIR      what the manifest's paths are relative to (default: the TSV's folder)
A sequence (frame_000000.pfm, ... in --out-dir; synthetic scenes add gt_000000.pfm, ...; such
maps of an earlier run in that folder that this one does not write are removed):
  --left-pattern P     numbered left images, e.g. 'images/I1_%06d.png'
  --right-pattern P    numbered right images
  --first N --count N  frame range (default: from 0 until the first missing file)
  --synthetic NAME     hand | boxes | static, rendered with exact ground truth
  --size WxH           synthetic resolution (default 1280x720)
  --frames N           synthetic frames (default 30)
  --color              synthetic colour images (default grey, like the headset camera)
  --right-gain G       the right camera's levels times G (0.25..4, default 1) and plus O
  --right-offset O     (-128..128, default 0): two sensors that differ, as a cheap pair's do
  --right-rows R       the right camera's scene R rows lower (-8..8, default 0): a drifted
                       rectification
  --right-roll DEG     the right camera turned DEG degrees about the image centre (-1..1,
                       default 0; positive: its scene lower towards the right edge)
  --lens-falloff K     both lenses darker towards the corners by 1 - K r^2 (0..0.75, default
                       0; r = 1 at the half-diagonal)
  --overlays           also write overlay/depth_*.png, contours_*.png, occlusion_*.png
Common:
  --max-disp N         largest disparity searched, input pixels (so does stereo.max_disparity
                       from --set or --config); without either, each scene's own: the
                       manifest's max_disp, a synthetic scene's nearest object
  --out-dir DIR        output folder (created if missing)
  --sparse             write the sparse stereo map instead of the dense one
  --config FILE        TOML with [stereo], [contour] and [densify] tables (see --list-params)
  --set KEY=VALUE      override one parameter, e.g. --set densify.lambda_s=2
  --list-params        print every parameter with its value and range
  -h, --help           print this help

Exit status: 0 success, 1 bad data (missing or unreadable files, size mismatch, bad calibration),
2 bad command line.
)";

struct Options {
  std::optional<fs::path> left, right, calib, out, depth_out, overlay_dir;
  std::optional<fs::path> scenes, data_root, out_dir;
  std::optional<std::string> left_pattern, right_pattern, synthetic;
  int first = 0, count = -1, frames = 30, width = 1280, height = 720;
  bool color = false, overlays = false;
  dco::tools::SyntheticRightCamera right_camera;
  std::optional<int> max_disp;
  std::optional<fs::path> config;
  std::vector<std::string> overrides;
  bool sparse = false;
  bool list_params = false;
  bool help = false;
};

Options parse_args(int argc, char** argv) {
  Options opt;
  dco::tools::ArgCursor args(argc, argv);
  while (args.next()) {
    const std::string_view arg = args.name();
    if (arg == "-h" || arg == "--help")
      opt.help = args.flag();
    else if (arg == "--left")
      opt.left = args.value();
    else if (arg == "--right")
      opt.right = args.value();
    else if (arg == "--calib")
      opt.calib = args.value();
    else if (arg == "--out")
      opt.out = args.value();
    else if (arg == "--depth-out")
      opt.depth_out = args.value();
    else if (arg == "--overlay-dir")
      opt.overlay_dir = args.value();
    else if (arg == "--scenes")
      opt.scenes = args.value();
    else if (arg == "--data-root")
      opt.data_root = args.value();
    else if (arg == "--out-dir")
      opt.out_dir = args.value();
    else if (arg == "--left-pattern")
      opt.left_pattern = args.value();
    else if (arg == "--right-pattern")
      opt.right_pattern = args.value();
    else if (arg == "--first")
      opt.first = args.int_value();
    else if (arg == "--count")
      opt.count = args.int_value();
    else if (arg == "--synthetic")
      opt.synthetic = args.value();
    else if (arg == "--size") {
      const dco::tools::ImageSize size = dco::tools::parse_image_size(
          "--size", args.value(), dco::synthetic::kMinSide, dco::synthetic::kMaxSide);
      opt.width = size.width;
      opt.height = size.height;
    } else if (arg == "--frames")
      opt.frames = args.int_value();
    else if (arg == "--color")
      opt.color = args.flag();
    else if (arg == "--right-gain")
      opt.right_camera.gain = args.number_value(0.25, 4.0);
    else if (arg == "--right-offset")
      opt.right_camera.offset = args.number_value(-128.0, 128.0);
    else if (arg == "--right-rows")
      opt.right_camera.rows = args.number_value(-8.0, 8.0);
    else if (arg == "--right-roll")
      opt.right_camera.roll_deg = args.number_value(-1.0, 1.0);
    else if (arg == "--lens-falloff")
      opt.right_camera.lens_falloff = args.number_value(0.0, 0.75);
    else if (arg == "--overlays")
      opt.overlays = args.flag();
    else if (arg == "--max-disp")
      opt.max_disp = args.int_value();
    else if (arg == "--config")
      opt.config = args.value();
    else if (arg == "--set")
      opt.overrides.push_back(args.value());
    else if (arg == "--sparse")
      opt.sparse = args.flag();
    else if (arg == "--list-params")
      opt.list_params = args.flag();
    else if (arg.starts_with("-"))
      throw UsageError(fmt::format("unknown option {}", arg));
    else
      throw UsageError(fmt::format("unexpected argument '{}'", arg));
  }
  if (opt.help || opt.list_params) return opt;
  if (opt.max_disp && *opt.max_disp <= 0)
    throw UsageError(fmt::format("--max-disp must be positive, not {}", *opt.max_disp));
  const int modes = (opt.left || opt.right ? 1 : 0) + (opt.scenes ? 1 : 0) +
                    (opt.left_pattern || opt.right_pattern ? 1 : 0) + (opt.synthetic ? 1 : 0);
  if (modes == 0)
    throw UsageError("give --left and --right, --scenes, --left-pattern or --synthetic");
  if (modes > 1)
    throw UsageError("--left/--right, --scenes, --*-pattern and --synthetic exclude each other");
  if (opt.left || opt.right) {
    if (!opt.left || !opt.right) throw UsageError("give both --left and --right");
    if (!opt.out) throw UsageError("--out is required");
    if (lower(opt.out->extension().string()) != ".pfm")
      throw UsageError(
          fmt::format("--out writes PFM: give a name ending in .pfm, not '{}'", opt.out->string()));
    if (opt.depth_out && lower(opt.depth_out->extension().string()) != ".pfm" &&
        lower(opt.depth_out->extension().string()) != ".png")
      throw UsageError(
          fmt::format("--depth-out writes .pfm or .png, not '{}'", opt.depth_out->string()));
    // An output over an input would destroy the input (the write replaces the file, whatever
    // its permissions).
    for (const std::optional<fs::path>& output : {opt.out, opt.depth_out})
      for (const std::optional<fs::path>& input : {opt.left, opt.right, opt.calib, opt.config})
        if (output && input && dco::tools::same_file(*output, *input))
          throw UsageError(
              fmt::format("'{}' is an input; the output would replace it", output->string()));
    if (opt.depth_out && dco::tools::same_file(*opt.out, *opt.depth_out))
      throw UsageError("--out and --depth-out name one file");
    if (opt.depth_out && !opt.calib) throw UsageError("--depth-out needs --calib");
    if (opt.out_dir || opt.data_root) throw UsageError("--out-dir and --data-root need --scenes");
    if (opt.overlays) throw UsageError("--overlays is for --out-dir; one pair takes --overlay-dir");
    return opt;
  }
  if (!opt.out_dir) throw UsageError("this mode needs --out-dir");
  if (opt.out || opt.depth_out || opt.overlay_dir)
    throw UsageError("--out, --depth-out and --overlay-dir are for one pair; use --out-dir");
  if (opt.scenes && opt.calib) throw UsageError("--scenes does not take --calib");
  if (opt.left_pattern && !opt.right_pattern)
    throw UsageError("--left-pattern needs --right-pattern");
  if (opt.right_pattern && !opt.left_pattern)
    throw UsageError("--right-pattern needs --left-pattern");
  if (opt.synthetic && (opt.frames < 1 || opt.width < 16 || opt.height < 16))
    throw UsageError("--frames must be >= 1 and --size at least 16x16");
  if (opt.synthetic) dco::tools::check_synthetic_name(*opt.synthetic);
  if (opt.left_pattern && opt.first < 0) throw UsageError("--first must be >= 0");
  for (const std::optional<std::string>& pattern : {opt.left_pattern, opt.right_pattern}) {
    try {
      if (pattern) dco::tools::expand_pattern(*pattern, 0);
    } catch (const dco::Error& e) {
      throw UsageError(e.what());
    }
  }
  if (opt.left_pattern && opt.count != -1 && opt.count < 1)
    throw UsageError("--count must be >= 1 (without it: up to the first missing file)");
  if (!opt.left_pattern && (opt.first != 0 || opt.count != -1))
    throw UsageError("--first and --count are for --left-pattern/--right-pattern");
  if (opt.synthetic && opt.calib) throw UsageError("--synthetic does not take --calib");
  if (!opt.scenes && opt.data_root) throw UsageError("--data-root needs --scenes");
  return opt;
}

// The parameters, and whether the disparity range was given (--max-disp, a --set or the config
// file): then it holds for every scene instead of the manifest's or the synthetic scene's own.
dco::pipeline::PipelineParams load_params(const Options& opt, bool& max_disparity_given) {
  dco::pipeline::PipelineParams params;
  dco::ConfigSchema schema;
  dco::pipeline::register_params(schema, params);
  if (opt.config) schema.load_file(*opt.config);
  dco::tools::apply_sets(schema, opt.overrides);
  max_disparity_given = opt.max_disp || schema.was_set("stereo.max_disparity");
  // --max-disp has the range of stereo.max_disparity (its lower end is checked with the options).
  if (opt.max_disp && *opt.max_disp > dco::stereo::kMaxDisparityLimit)
    throw UsageError(fmt::format("--max-disp {}: value {} is outside [1, {}]", *opt.max_disp,
                                 *opt.max_disp, dco::stereo::kMaxDisparityLimit));
  if (opt.max_disp) params.stereo.max_disparity = *opt.max_disp;
  dco::tools::validate_given(opt.config.has_value(), [&] { dco::pipeline::validate(params); });
  return params;
}

// A single frame through the whole pipeline (its contour window holds only that frame).
void run_single(dco::pipeline::DepthPipeline& pipeline, const dco::Image<std::uint8_t>& left,
                const dco::Image<std::uint8_t>& right, dco::pipeline::DepthResult& result) {
  pipeline.reset();
  if (!pipeline.push(left.cview(), right.cview(), result)) pipeline.finish(result);
}

// The stereo stage's correction of the right camera, for a frame's line: empty while it has none.
std::string correction_text(const dco::pipeline::DepthResult& r) {
  return r.camera_correction.identity() ? std::string()
                                        : "; " + dco::stereo::describe(r.camera_correction);
}

double total_ms(const dco::pipeline::DepthResult& r, bool sparse) {
  return r.stereo_timings.total_ms +
         (sparse ? 0.0 : r.contour_timings.total_ms + r.densify_timings.total_ms);
}

std::string timing_text(const dco::pipeline::DepthResult& r, bool sparse) {
  if (sparse) return fmt::format("stereo {:.1f} ms", r.stereo_timings.total_ms);
  const std::string full_size = r.solver.fine_iterations > 0
                                    ? fmt::format(" + {} at full size", r.solver.fine_iterations)
                                    : std::string();
  // The output's residual on the full system when measured (densify.output_residual), else the
  // half-size solve's.
  const std::string residual = std::isnan(r.solver.output_residual)
                                   ? fmt::format("half-size res {:.1e}", r.solver.final_residual)
                                   : fmt::format("res {:.1e}", r.solver.output_residual);
  return fmt::format("stereo {:.1f} + contour {:.1f} + densify {:.1f} ms ({} it{}, {})",
                     r.stereo_timings.total_ms, r.contour_timings.total_ms,
                     r.densify_timings.total_ms, r.solver.iterations, full_size, residual);
}

float median_disparity(const dco::Image<float>& d) {
  std::vector<float> v;
  v.reserve(static_cast<std::size_t>(d.width()) * d.height());
  for (int y = 0; y < d.height(); ++y)
    for (int x = 0; x < d.width(); ++x)
      if (std::isfinite(d.at(x, y)) && d.at(x, y) > 0) v.push_back(d.at(x, y));
  if (v.empty()) return 0.0f;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

void write_overlays(const fs::path& dir, const std::string& suffix,
                    const dco::pipeline::DepthResult& r, bool sparse, float max_disparity,
                    float plane) {
  fs::create_directories(dir);
  const dco::Image<float>& map = sparse ? r.sparse : r.dense;
  dco::tools::write_disparity_colour(dir / ("depth" + suffix + ".png"), map.cview(), max_disparity);
  dco::tools::write_contour_overlay(dir / ("contours" + suffix + ".png"), r.image.cview(),
                                    r.contours.cview());
  dco::tools::write_occlusion_composite(dir / ("occlusion" + suffix + ".png"), r.image.cview(),
                                        map.cview(), plane);
}

int run_pair(const Options& opt, const dco::pipeline::PipelineParams& params) {
  dco::Image<std::uint8_t> left = dco::load_image(*opt.left);
  dco::Image<std::uint8_t> right = dco::load_image(*opt.right);
  if (left.channels() != right.channels())
    throw dco::Error(fmt::format("'{}' has {} channel(s) but '{}' has {}", opt.left->string(),
                                 left.channels(), opt.right->string(), right.channels()));
  std::optional<dco::Rectifier> rectifier;
  if (opt.calib) {
    dco::StereoCalibration calib = dco::load_calibration(*opt.calib);
    // A rectified calibration without a size (Karlsruhe without roi) takes the images': only
    // then is its geometry checked against a width.
    calib.take_size_if_unknown(left.width(), left.height());
    rectifier.emplace(calib);
    // Already rectified images go through as they are, but must be of the calibrated size.
    rectifier->check_inputs(left.cview(), right.cview());
    if (rectifier->needs_remap()) {
      dco::Image<std::uint8_t> left_rect, right_rect;
      rectifier->rectify(left.cview(), right.cview(), left_rect, right_rect);
      left = std::move(left_rect);
      right = std::move(right_rect);
    }
  }
  dco::pipeline::DepthPipeline pipeline(params);
  dco::pipeline::DepthResult result;
  run_single(pipeline, left, right, result);
  const dco::Image<float>& map = opt.sparse ? result.sparse : result.dense;
  dco::write_pfm(*opt.out, map.view());
  if (opt.depth_out) {
    dco::Image<float> depth(map.width(), map.height());
    dco::disparity_to_depth(map.view(), rectifier->geometry(), depth.view());
    if (lower(opt.depth_out->extension().string()) == ".png")
      dco::write_depth_png16(*opt.depth_out, depth.view());
    else
      dco::write_pfm(*opt.depth_out, depth.view());
  }
  if (opt.overlay_dir)
    write_overlays(*opt.overlay_dir, "", result, opt.sparse,
                   static_cast<float>(params.stereo.max_disparity), median_disparity(map));
  fmt::print("{}: {}x{}, {}{}\n", opt.out->string(), map.width(), map.height(),
             timing_text(result, opt.sparse), correction_text(result));
  return 0;
}

int run_batch(const Options& opt, dco::pipeline::PipelineParams params, bool max_disparity_given) {
  const fs::path data_root = opt.data_root.value_or(opt.scenes->parent_path());
  const auto scenes = dco::tools::load_scene_manifest(*opt.scenes, data_root);
  if (scenes.empty()) throw dco::Error(fmt::format("'{}' lists no scene", opt.scenes->string()));
  fs::create_directories(*opt.out_dir);
  dco::pipeline::DepthResult result;
  for (const dco::tools::Scene& scene : scenes) {
    if (!max_disparity_given) params.stereo.max_disparity = scene.max_disp;
    dco::pipeline::validate(params);
    dco::pipeline::DepthPipeline pipeline(params);
    const dco::Image<std::uint8_t> left = dco::load_image(scene.left);
    const dco::Image<std::uint8_t> right = dco::load_image(scene.right);
    run_single(pipeline, left, right, result);
    const std::string stem = scene.file_stem();
    dco::write_pfm(*opt.out_dir / (stem + ".pfm"),
                   (opt.sparse ? result.sparse : result.dense).view());
    const fs::path sparse = *opt.out_dir / (stem + ".sparse.pfm");
    if (opt.sparse)
      fs::remove(sparse);  // a dense run's, which no longer matches the .pfm
    else
      dco::write_pfm(sparse, result.sparse.view());
    const fs::path time_file = *opt.out_dir / (stem + ".time_ms");
    dco::replace_file(time_file, [&](const fs::path& tmp) {
      std::ofstream time_out(tmp);
      time_out << total_ms(result, opt.sparse) << '\n';
      time_out.close();
      if (!time_out) throw dco::Error("cannot write " + time_file.string());
    });
    fmt::print("{:<40} {}x{} max-disp {:3}  {}{}\n", scene.name, left.width(), left.height(),
               params.stereo.max_disparity, timing_text(result, opt.sparse),
               correction_text(result));
  }
  return 0;
}

// Removes frame_NNNNNN.pfm and gt_NNNNNN.pfm files in `dir` whose number is not in `keep`;
// returns how many.
int remove_other_frames(const fs::path& dir, const std::set<dco::pipeline::FrameIndex>& keep) {
  static const std::regex kName("(frame|gt)_([0-9]{6})\\.pfm");
  int removed = 0;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    std::smatch m;
    const std::string name = e.path().filename().string();
    if (!e.is_regular_file() || !std::regex_match(name, m, kName)) continue;
    if (keep.count(std::stoll(m[2].str())) == 0 && fs::remove(e.path())) ++removed;
  }
  return removed;
}

int run_sequence(const Options& opt, dco::pipeline::PipelineParams params,
                 bool max_disparity_given) {
  std::unique_ptr<dco::tools::FrameSequence> frames =
      opt.synthetic ? dco::tools::make_synthetic_sequence(*opt.synthetic, opt.width, opt.height,
                                                          opt.frames, opt.color, opt.right_camera)
                    : dco::tools::make_pattern_sequence(*opt.left_pattern, *opt.right_pattern,
                                                        opt.first, opt.count, opt.calib);
  // A synthetic scene's nearest object, as far as the stage reaches.
  if (!max_disparity_given && frames->max_disparity()) {
    params.stereo.max_disparity =
        std::min(*frames->max_disparity(), dco::stereo::kMaxDisparityLimit);
    if (*frames->max_disparity() > params.stereo.max_disparity)
      fmt::print(stderr,
                 "dco-depth: warning: the scene's nearest depth needs {} px of disparity, the "
                 "search stops at {}: nearer surfaces are not measured\n",
                 *frames->max_disparity(), params.stereo.max_disparity);
  }
  dco::pipeline::validate(params);
  fs::create_directories(*opt.out_dir);
  dco::pipeline::DepthPipeline pipeline(params);
  dco::tools::StereoInput input;
  dco::pipeline::DepthResult result;
  float plane = 0.0f;
  int written = 0;
  std::set<dco::pipeline::FrameIndex> written_indices;
  double sum_ms = 0;
  dco::stereo::CameraCorrection correction;  // as last printed
  const auto emit = [&] {
    const dco::Image<float>& map = opt.sparse ? result.sparse : result.dense;
    const std::string suffix = fmt::format("_{:06d}", result.index);
    dco::write_pfm(*opt.out_dir / ("frame" + suffix + ".pfm"), map.view());
    if (written == 0) plane = median_disparity(map);  // one virtual plane for the whole sequence
    if (opt.overlays)
      write_overlays(*opt.out_dir / "overlay", suffix, result, opt.sparse,
                     static_cast<float>(params.stereo.max_disparity), plane);
    sum_ms += total_ms(result, opt.sparse);
    // The correction only when it changes: the frames after it are matched through it.
    fmt::print("frame {:6d}  {}{}{}\n", result.index, timing_text(result, opt.sparse),
               result.flow_cue ? "" : "  (no flow cue)",
               result.camera_correction == correction ? std::string() : correction_text(result));
    correction = result.camera_correction;
    written_indices.insert(result.index);
    ++written;
  };
  try {
    while (frames->next(input)) {
      if (!input.gt_disparity.empty()) {
        dco::write_pfm(*opt.out_dir / fmt::format("gt_{:06d}.pfm", input.index),
                       input.gt_disparity.view());
        written_indices.insert(input.index);
      }
      if (pipeline.push(input.left.cview(), input.right.cview(), result)) emit();
    }
    while (pipeline.finish(result)) emit();
  } catch (...) {
    // A run that fails part-way leaves its frames, and not an earlier run's beside them.
    std::error_code ignored;
    if (fs::is_directory(*opt.out_dir, ignored)) remove_other_frames(*opt.out_dir, written_indices);
    throw;
  }
  if (written == 0) throw dco::Error("the sequence holds no frame");
  // Frames of an earlier, longer run in the same folder would be scored with these.
  if (const int stale = remove_other_frames(*opt.out_dir, written_indices); stale > 0)
    fmt::print("removed {} frame and ground-truth maps of an earlier run from {}\n", stale,
               opt.out_dir->string());
  fmt::print("{} frames, max-disp {}, mean {:.1f} ms per frame\n", written,
             params.stereo.max_disparity, sum_ms / written);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  dco::retain_freed_memory();  // before any thread starts: see memory_policy.hpp
  return dco::tools::run_tool("dco-depth", [&] {
    const Options opt = parse_args(argc, argv);
    if (opt.help) {
      fmt::print("{}", kUsage);
      return 0;
    }
    if (opt.list_params) {
      dco::pipeline::PipelineParams params;
      dco::ConfigSchema schema;
      dco::pipeline::register_params(schema, params);
      fmt::print("{}", schema.describe());
      return 0;
    }
    bool max_disparity_given = false;
    const dco::pipeline::PipelineParams params = load_params(opt, max_disparity_given);
    if (opt.scenes) return run_batch(opt, params, max_disparity_given);
    if (opt.left) return run_pair(opt, params);
    return run_sequence(opt, params, max_disparity_given);
  });
}
