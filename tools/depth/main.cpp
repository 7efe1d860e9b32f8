// dco-depth: runs the depth pipeline offline on image files — one rectified (or calibrated raw)
// stereo pair, or every scene of a manifest — and writes disparity as PFM.

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "dco/core/calibration.hpp"
#include "dco/core/config.hpp"
#include "dco/core/depth_conversion.hpp"
#include "dco/core/disparity_io.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image_io.hpp"
#include "dco/core/rectifier.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "dco/tools/command_line.hpp"
#include "dco/tools/scene_manifest.hpp"

namespace {

namespace fs = std::filesystem;
using dco::tools::UsageError;

constexpr std::string_view kUsage =
    R"(usage: dco-depth --left L --right R [--calib FILE] [--max-disp N] --out D.pfm
                 [--depth-out Z.pfm|Z.png] [--sparse] [--config FILE] [--set KEY=VALUE]...
       dco-depth --scenes TSV [--data-root DIR] --out-dir DIR [--max-disp N] [--sparse]
                 [--config FILE] [--set KEY=VALUE]...
       dco-depth --list-params

Computes disparity for a stereo pair and writes it in pixels of the input image as PFM,
+inf where the map has no value.

  --left, --right L R  the pair (8-bit PNG/PGM/JPEG, gray or colour, same size)
  --calib FILE         calibration (dco TOML, Middlebury calib.txt, KITTI/Karlsruhe); raw
                       images are rectified first, and --depth-out needs it
  --max-disp N         largest disparity searched, input pixels (default: the scene's
                       max_disp in batch mode, else stereo.max_disparity = 64)
  --out D.pfm          disparity output
  --depth-out Z        metric depth: .pfm in metres (+inf unknown) or .png in millimetres (0 unknown)
  --sparse             write the sparse stage's map: only pixels that pass the checks carry a
                       value (the stage this version runs)
  --scenes TSV         batch mode: every scene of the manifest, written to
                       DIR/<scene with '/' replaced by '_'>.pfm, with the stage time in
                       DIR/<same>.time_ms for dco-eval
  --data-root DIR      what the manifest's paths are relative to (default: the TSV's folder)
  --out-dir DIR        batch output folder (created if missing)
  --config FILE        TOML file with a [stereo] table (see --list-params)
  --set KEY=VALUE      override one parameter, e.g. --set stereo.uniqueness=0.2
  --list-params        print every parameter with its value and range
  -h, --help           print this help

Exit status: 0 success, 1 bad data (missing or unreadable files, size mismatch, bad calibration),
2 bad command line.
)";

struct Options {
  std::optional<fs::path> left, right, calib, out, depth_out;
  std::optional<fs::path> scenes, data_root, out_dir;
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
    else if (arg == "--scenes")
      opt.scenes = args.value();
    else if (arg == "--data-root")
      opt.data_root = args.value();
    else if (arg == "--out-dir")
      opt.out_dir = args.value();
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
  if (opt.scenes) {
    if (opt.left || opt.right || opt.out || opt.calib || opt.depth_out)
      throw UsageError("--scenes (batch mode) does not combine with --left/--right/--out/--calib");
    if (!opt.out_dir) throw UsageError("--scenes needs --out-dir");
  } else {
    if (!opt.left || !opt.right) throw UsageError("give --left and --right (or --scenes)");
    if (!opt.out) throw UsageError("--out is required");
    if (opt.depth_out && !opt.calib) throw UsageError("--depth-out needs --calib");
    if (opt.out_dir || opt.data_root) throw UsageError("--out-dir and --data-root need --scenes");
  }
  return opt;
}

dco::stereo::StereoParams load_params(const Options& opt) {
  dco::stereo::StereoParams params;
  dco::ConfigSchema schema;
  dco::stereo::register_params(schema, params);
  if (opt.config) schema.load_file(*opt.config);
  for (const std::string& assignment : opt.overrides) schema.set(assignment);
  if (opt.max_disp) params.max_disparity = *opt.max_disp;
  dco::stereo::validate(params);
  return params;
}

void write_depth(const fs::path& path, const dco::Image<float>& disparity,
                 const dco::RectifiedGeometry& geometry) {
  dco::Image<float> depth(disparity.width(), disparity.height());
  dco::disparity_to_depth(disparity.view(), geometry, depth.view());
  if (path.extension() == ".png")
    dco::write_depth_png16(path, depth.view());
  else
    dco::write_pfm(path, depth.view());
}

int run_pair(const Options& opt, const dco::stereo::StereoParams& params) {
  dco::Image<std::uint8_t> left = dco::load_image(*opt.left);
  dco::Image<std::uint8_t> right = dco::load_image(*opt.right);
  if (left.channels() != right.channels())
    throw dco::Error(fmt::format("'{}' has {} channel(s) but '{}' has {}", opt.left->string(),
                                 left.channels(), opt.right->string(), right.channels()));

  std::optional<dco::Rectifier> rectifier;
  if (opt.calib) {
    rectifier.emplace(dco::load_calibration(*opt.calib));
    if (rectifier->needs_remap()) {
      dco::Image<std::uint8_t> left_rect, right_rect;
      rectifier->rectify(left.cview(), right.cview(), left_rect, right_rect);
      left = std::move(left_rect);
      right = std::move(right_rect);
    }
  }

  const auto matcher = dco::stereo::make_cpu_stereo_matcher(params);
  dco::Image<float> disparity;
  matcher->compute(left.cview(), right.cview(), disparity);
  dco::write_pfm(*opt.out, disparity.view());
  if (opt.depth_out) write_depth(*opt.depth_out, disparity, rectifier->geometry());
  fmt::print("{}: {}x{} in {:.1f} ms\n", opt.out->string(), disparity.width(), disparity.height(),
             matcher->last_timings().total_ms);
  return 0;
}

int run_batch(const Options& opt, dco::stereo::StereoParams params) {
  const fs::path data_root = opt.data_root.value_or(opt.scenes->parent_path());
  const std::vector<dco::tools::Scene> scenes =
      dco::tools::load_scene_manifest(*opt.scenes, data_root);
  fs::create_directories(*opt.out_dir);
  dco::Image<float> disparity;
  for (const dco::tools::Scene& scene : scenes) {
    if (!opt.max_disp) params.max_disparity = scene.max_disp;
    const auto matcher = dco::stereo::make_cpu_stereo_matcher(params);
    const dco::Image<std::uint8_t> left = dco::load_image(scene.left);
    const dco::Image<std::uint8_t> right = dco::load_image(scene.right);
    matcher->compute(left.cview(), right.cview(), disparity);
    const fs::path out = *opt.out_dir / (scene.file_stem() + ".pfm");
    dco::write_pfm(out, disparity.view());
    const dco::stereo::StereoTimings& t = matcher->last_timings();
    std::ofstream(*opt.out_dir / (scene.file_stem() + ".time_ms")) << t.total_ms << '\n';
    fmt::print("{:<40} {}x{} max-disp {:3}  {:7.1f} ms\n", scene.name, left.width(), left.height(),
               params.max_disparity, t.total_ms);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return dco::tools::run_tool("dco-depth", [&] {
    const Options opt = parse_args(argc, argv);
    if (opt.help) {
      fmt::print("{}", kUsage);
      return 0;
    }
    if (opt.list_params) {
      dco::stereo::StereoParams params;
      dco::ConfigSchema schema;
      dco::stereo::register_params(schema, params);
      fmt::print("{}", schema.describe());
      return 0;
    }
    const dco::stereo::StereoParams params = load_params(opt);
    return opt.scenes ? run_batch(opt, params) : run_pair(opt, params);
  });
}
