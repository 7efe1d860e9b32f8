// dco-eval: scores disparity maps written by dco-depth (or anything else that writes PFM) against
// the ground truth of the scene manifest, optionally next to the OpenCV SGBM+WLS baseline; scores
// the temporal stability of a disparity sequence; and checks the optical-flow stage on MPI Sintel.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/core.hpp>

#include "dco/core/disparity_io.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image_io.hpp"
#include "dco/tools/command_line.hpp"
#include "dco/tools/flow_eval.hpp"
#include "dco/tools/gt_alignment.hpp"
#include "dco/tools/gt_noise.hpp"
#include "dco/tools/json.hpp"
#include "dco/tools/metrics.hpp"
#include "dco/tools/occlusion_error_map.hpp"
#include "dco/tools/scene_manifest.hpp"
#include "dco/tools/sequence_eval.hpp"
#include "dco/tools/sgbm_wls.hpp"

namespace {

namespace fs = std::filesystem;
using dco::tools::BoundaryAccuracy;
using dco::tools::json_number;
using dco::tools::json_string;
using dco::tools::Scene;
using dco::tools::SceneMetrics;
using dco::tools::SequenceReport;
using dco::tools::UsageError;

constexpr std::string_view kUsage =
    R"(usage: dco-eval --scenes TSV [--data-root DIR] [--pred-dir DIR]
                [--baseline sgbm-wls] [--only SUBSTRING] [--gt-alignment]
                [--noise-floor SIGMA]... [--error-maps DIR] [--json]
       dco-eval --sequence DIR [--gt-dir DIR] [--noise-floor SIGMA]... [--json]
       dco-eval --flow-sintel DIR [--dis-preset NAME] [--json]

Scores disparity maps per scene against the manifest's ground truth (--scenes), over time on a
sequence of frames (--sequence), or checks the optical-flow stage on MPI Sintel (--flow-sintel).
The three modes are separate: give exactly one of them.

Scenes:
  --scenes TSV        scene manifest (stereo_scenes.tsv)
  --data-root DIR     directory the manifest's paths are relative to (default: the TSV's directory)
  --pred-dir DIR      predictions: DIR/<scene with '/' -> '_'>.pfm, float px at the GT resolution,
                      +inf / NaN / <= 0 = no prediction. An optional DIR/<same>.time_ms holding one
                      number (milliseconds) supplies the method's run time, and an optional
                      DIR/<same>.sparse.pfm the sparse map a dense prediction was filled in from
                      (fill%, bad2M, bad2F: is the error in the matches or in the fill?).
  --baseline sgbm-wls also run OpenCV StereoSGBM + WLS filter on every scene and compare
  --only SUBSTRING    only scenes whose name contains SUBSTRING
  --gt-alignment      also find each scene's GT offset: the d (within +-2 px, 0.05 px steps) for
                      which the right image sampled at x - (GT + d) matches the left image best on
                      textured pixels (from the images and the GT alone), and score the prediction
                      and the baseline once more against GT + d
  --error-maps DIR    also write, per scene and plane, DIR/<scene>.plane<NN>.png (NN = the
                      plane's GT quantile in %): the left image in grey, the band in green where
                      the prediction is right, wrong pixels red (predicted in front) or blue
                      (behind), bright where matched and dark where filled (with a sparse map),
                      yellow where there is no prediction; outside the band at half strength
  --noise-floor SIGMA also score the ground truth plus Gaussian noise of SIGMA px (0..10, a fixed
                      seed per scene) as a prediction: what a matcher whose only error is that
                      noise scores, chiefly on the occlusion metrics; may be given several times
                      (also with --sequence and --gt-dir, on the GT frames)
  At least one of --pred-dir, --baseline and --noise-floor is needed.

Sequence:
  --sequence DIR      predicted frames DIR/frame_000000.pfm, frame_000001.pfm, ... (from 0 up to
                      the first missing number, at least 2; values as for --pred-dir). Prints the
                      flicker: % of pixels whose side of the virtual planes (20..80 % disparity
                      quantiles of frame 0) changes between consecutive frames, holes included.
  --gt-dir DIR        ground truth DIR/gt_000000.pfm, ..., one per predicted frame. Frame 0 of the
                      GT then fixes the planes for both, and dco-eval adds the GT's own flicker,
                      the accuracy metrics of every frame with their mean, and boundary recall /
                      precision: % of GT (predicted) occlusion-boundary pixels with a predicted (GT)
                      one within 2 px, mean over planes and frames.

Sintel flow:
  --flow-sintel DIR   runs DIS optical flow frame_0002 -> frame_0003 in every DIR/<pass>/<sequence>/
                      that holds frame_0002.png, frame_0003.png and gt/frame_0002.flo with its
                      gt/invalid and gt/occlusions masks, and prints the end-point error over all
                      valid pixels and over non-occluded ones
  --dis-preset NAME   ultrafast, fast (default) or medium

  --json              print one JSON document instead of tables
  -h, --help          print this help

Exit status: 0 success, 1 bad data (missing or malformed files), 2 bad command line.
)";

constexpr std::string_view kBaselineName = "sgbm-wls";
constexpr std::array<std::string_view, 3> kDisPresets = {"ultrafast", "fast", "medium"};

enum class Mode { kNone, kScenes, kSequence, kFlowSintel };

// The option that selects each mode.
std::string_view mode_option(Mode mode) {
  switch (mode) {
    case Mode::kScenes:
      return "--scenes";
    case Mode::kSequence:
      return "--sequence";
    case Mode::kFlowSintel:
      return "--flow-sintel";
    case Mode::kNone:
      break;
  }
  return "";
}

struct Options {
  Mode mode = Mode::kNone;
  // --scenes
  fs::path scenes;
  std::optional<fs::path> data_root;
  std::optional<fs::path> pred_dir;
  bool baseline = false;
  bool gt_alignment = false;
  std::vector<double> noise_floor;  // sigmas in px
  std::optional<fs::path> error_maps;
  std::string only;
  // --sequence
  fs::path sequence;
  std::optional<fs::path> gt_dir;
  // --flow-sintel
  fs::path sintel;
  std::string dis_preset = "fast";

  bool json = false;
  bool help = false;
};

Options parse_args(int argc, char** argv) {
  Options opt;
  // Options that belong to one mode, checked against the chosen mode once it is known.
  std::vector<std::pair<std::string, Mode>> mode_options;
  dco::tools::ArgCursor args(argc, argv);
  while (args.next()) {
    const std::string_view arg = args.name();
    const auto value = [&] { return args.value(); };
    const auto flag = [&] { return args.flag(); };
    const auto select = [&](Mode mode) {
      if (opt.mode != Mode::kNone && opt.mode != mode)
        throw UsageError(fmt::format("{} and {} are separate modes; give one of them",
                                     mode_option(opt.mode), arg));
      opt.mode = mode;
    };
    const auto belongs_to = [&](Mode mode) { mode_options.emplace_back(arg, mode); };

    if (arg == "-h" || arg == "--help")
      opt.help = flag();
    else if (arg == "--json")
      opt.json = flag();
    else if (arg == "--scenes")
      select(Mode::kScenes), opt.scenes = value();
    else if (arg == "--data-root")
      belongs_to(Mode::kScenes), opt.data_root = value();
    else if (arg == "--pred-dir")
      belongs_to(Mode::kScenes), opt.pred_dir = value();
    else if (arg == "--only")
      belongs_to(Mode::kScenes), opt.only = value();
    else if (arg == "--gt-alignment")
      belongs_to(Mode::kScenes), opt.gt_alignment = flag();
    else if (arg == "--error-maps")
      belongs_to(Mode::kScenes), opt.error_maps = value();
    else if (arg == "--noise-floor")
      opt.noise_floor.push_back(args.number_value(0, 10));
    else if (arg == "--baseline") {
      belongs_to(Mode::kScenes);
      const std::string name = value();
      if (name != kBaselineName)
        throw UsageError(fmt::format("unknown baseline '{}' (known: {})", name, kBaselineName));
      opt.baseline = true;
    } else if (arg == "--sequence")
      select(Mode::kSequence), opt.sequence = value();
    else if (arg == "--gt-dir")
      belongs_to(Mode::kSequence), opt.gt_dir = value();
    else if (arg == "--flow-sintel")
      select(Mode::kFlowSintel), opt.sintel = value();
    else if (arg == "--dis-preset") {
      belongs_to(Mode::kFlowSintel);
      opt.dis_preset = value();
      if (std::find(kDisPresets.begin(), kDisPresets.end(), opt.dis_preset) == kDisPresets.end())
        throw UsageError(fmt::format("unknown DIS preset '{}' (known: {})", opt.dis_preset,
                                     fmt::join(kDisPresets, ", ")));
    } else if (arg.starts_with("-")) {
      throw UsageError(fmt::format("unknown option {}", arg));
    } else {
      throw UsageError(fmt::format("unexpected argument '{}'", arg));
    }
  }
  if (opt.help) return opt;
  if (opt.mode == Mode::kNone)
    throw UsageError("give one of --scenes, --sequence or --flow-sintel");
  for (const auto& [name, mode] : mode_options)
    if (mode != opt.mode)
      throw UsageError(fmt::format("{} goes with {}, not with {}", name, mode_option(mode),
                                   mode_option(opt.mode)));
  if (!opt.noise_floor.empty() && opt.mode == Mode::kFlowSintel)
    throw UsageError("--noise-floor goes with --scenes or --sequence, not with --flow-sintel");
  if (!opt.noise_floor.empty() && opt.mode == Mode::kSequence && !opt.gt_dir)
    throw UsageError("--noise-floor needs --gt-dir with --sequence");
  if (opt.error_maps && !opt.pred_dir) throw UsageError("--error-maps needs --pred-dir");
  if (opt.mode == Mode::kScenes && !opt.pred_dir && !opt.baseline && opt.noise_floor.empty())
    throw UsageError("give --pred-dir, --baseline or --noise-floor (or several)");
  return opt;
}

// ---------------------------------------------------------------------------------------------
// --scenes

std::vector<Scene> select_scenes(const Options& opt) {
  const fs::path data_root = opt.data_root.value_or(opt.scenes.parent_path());
  std::vector<Scene> scenes = dco::tools::load_scene_manifest(opt.scenes, data_root);
  std::erase_if(scenes, [&](const Scene& s) { return s.name.find(opt.only) == std::string::npos; });
  // A manifest without rows is bad data; --only that matches nothing, a bad command line.
  if (scenes.empty() && opt.only.empty())
    throw dco::Error(fmt::format("'{}' lists no scene", opt.scenes.string()));
  if (scenes.empty()) throw UsageError(fmt::format("no scene name contains '{}'", opt.only));
  return scenes;
}

// The optional DIR/<stem>.time_ms sidecar; NaN when there is none.
double read_time_ms(const fs::path& path) {
  if (!fs::exists(path)) return dco::tools::kUndefined;
  std::ifstream in(path);
  double ms = 0;
  if (!(in >> ms) || !(ms >= 0) || !(in >> std::ws).eof())
    throw dco::Error(fmt::format("'{}' does not hold a time in milliseconds", path.string()));
  return ms;
}

// --gt-alignment: each scene's photometric GT offset, and the scores against the GT moved by it.
struct Alignment {
  std::vector<dco::tools::GtAlignment> offsets;  // one per scene
  std::vector<SceneMetrics> predicted, baseline;
};

std::vector<dco::tools::GtAlignment> align_scenes(const std::vector<Scene>& scenes) {
  std::vector<dco::tools::GtAlignment> offsets;
  for (const Scene& scene : scenes) {
    const dco::Image<std::uint8_t> left = dco::load_image(scene.left, dco::ImageColor::kGray);
    const dco::Image<std::uint8_t> right = dco::load_image(scene.right, dco::ImageColor::kGray);
    try {
      offsets.push_back(dco::tools::photometric_gt_alignment(
          left.view(), right.view(), dco::tools::load_ground_truth(scene).disparity.view()));
    } catch (const dco::Error& e) {
      throw dco::Error(fmt::format("scene '{}': {}", scene.name, e.what()));
    }
  }
  return offsets;
}

// The scores against the GT as given, and with `offsets` (one per scene) also against the GT
// moved by each scene's offset, into `moved`.
struct Scorer {
  const std::vector<dco::tools::GtAlignment>* offsets = nullptr;
  std::vector<SceneMetrics>* moved = nullptr;

  SceneMetrics operator()(std::size_t scene_index, const Scene& scene,
                          dco::ImageView<const float> prediction, const dco::tools::GroundTruth& gt,
                          dco::ImageView<const float> matches = {}) const {
    if (offsets != nullptr) {
      dco::tools::GroundTruth shifted{
          dco::tools::shifted_ground_truth(gt.disparity.view(), (*offsets)[scene_index].offset_px),
          gt.nocc};
      moved->push_back(dco::tools::evaluate_disparity(scene.name, prediction, shifted, matches));
    }
    return dco::tools::evaluate_disparity(scene.name, prediction, gt, matches);
  }
};

// --error-maps: one picture per plane of the scene's occlusion errors.
void write_error_maps(const fs::path& dir, const Scene& scene,
                      dco::ImageView<const float> prediction, const dco::tools::GroundTruth& gt,
                      dco::ImageView<const float> matches) {
  const dco::Image<std::uint8_t> left = dco::load_image(scene.left);
  const auto planes = dco::tools::occlusion_planes(gt.disparity.view());
  for (std::size_t i = 0; i < planes.size(); ++i) {
    if (std::isnan(planes[i])) continue;
    const fs::path path =
        dir /
        fmt::format("{}.plane{:02d}.png", scene.file_stem(),
                    static_cast<int>(std::lround(100 * dco::tools::kOcclusionPlaneQuantiles[i])));
    try {
      dco::save_image(path, dco::tools::occlusion_error_map(left.view(), prediction,
                                                            gt.disparity.view(), planes[i], matches)
                                .view());
    } catch (const dco::Error& e) {
      throw dco::Error(fmt::format("scene '{}': {}", scene.name, e.what()));
    }
  }
}

std::vector<SceneMetrics> evaluate_predictions(const Options& opt, const std::vector<Scene>& scenes,
                                               const fs::path& pred_dir, const Scorer& score) {
  if (opt.error_maps) fs::create_directories(*opt.error_maps);
  if (!fs::is_directory(pred_dir))
    throw dco::Error(fmt::format("prediction directory '{}' does not exist", pred_dir.string()));
  std::vector<SceneMetrics> results;
  for (std::size_t i = 0; i < scenes.size(); ++i) {
    const Scene& scene = scenes[i];
    const fs::path pfm = pred_dir / (scene.file_stem() + ".pfm");
    if (!fs::exists(pfm))
      throw dco::Error(fmt::format("no prediction '{}' for scene '{}'", pfm.string(), scene.name));
    const dco::tools::GroundTruth gt = dco::tools::load_ground_truth(scene);
    const dco::Image<float> prediction = dco::read_pfm(pfm);
    if (prediction.channels() != 1 || prediction.width() != gt.disparity.width() ||
        prediction.height() != gt.disparity.height())
      throw dco::Error(fmt::format("prediction '{}' is {}x{}x{}, scene '{}' needs {}x{}x1",
                                   pfm.string(), prediction.width(), prediction.height(),
                                   prediction.channels(), scene.name, gt.disparity.width(),
                                   gt.disparity.height()));
    const fs::path sparse_pfm = pred_dir / (scene.file_stem() + ".sparse.pfm");
    const dco::Image<float> matches =
        fs::exists(sparse_pfm) ? dco::read_pfm(sparse_pfm) : dco::Image<float>();
    SceneMetrics m = score(i, scene, prediction.view(), gt, matches.view());
    if (opt.error_maps)
      write_error_maps(*opt.error_maps, scene, prediction.view(), gt, matches.view());
    m.time_ms = read_time_ms(pred_dir / (scene.file_stem() + ".time_ms"));
    results.push_back(std::move(m));
  }
  return results;
}

std::vector<SceneMetrics> evaluate_baseline(const std::vector<Scene>& scenes, const Scorer& score) {
  std::vector<SceneMetrics> results;
  for (std::size_t i = 0; i < scenes.size(); ++i) {
    const Scene& scene = scenes[i];
    const dco::Image<std::uint8_t> left = dco::load_image(scene.left);
    const dco::Image<std::uint8_t> right = dco::load_image(scene.right);
    const dco::tools::BaselineResult baseline =
        dco::tools::run_sgbm_wls(left.view(), right.view(), scene.max_disp);
    SceneMetrics m =
        score(i, scene, baseline.disparity.view(), dco::tools::load_ground_truth(scene));
    m.time_ms = baseline.time_ms;
    results.push_back(std::move(m));
  }
  return results;
}

// --noise-floor: the GT plus N(0, sigma²) scored as a prediction, per sigma.
struct NoiseFloor {
  double sigma_px = 0;
  std::vector<SceneMetrics> metrics;  // one per scene
};

std::vector<NoiseFloor> evaluate_noise_floor(const std::vector<Scene>& scenes,
                                             const std::vector<double>& sigmas) {
  std::vector<NoiseFloor> floors;
  for (const double sigma : sigmas) floors.push_back({sigma, {}});
  for (std::size_t i = 0; i < scenes.size(); ++i) {
    const dco::tools::GroundTruth gt = dco::tools::load_ground_truth(scenes[i]);
    for (NoiseFloor& f : floors) {
      const dco::Image<float> noisy =
          dco::tools::noisy_ground_truth(gt.disparity.view(), f.sigma_px, scenes[i].position + 1);
      f.metrics.push_back(dco::tools::evaluate_disparity(scenes[i].name, noisy.view(), gt));
    }
  }
  return floors;
}

void print_noise_floor_text(const std::vector<NoiseFloor>& floors) {
  fmt::print(
      "\nnoise floor: the ground truth plus Gaussian noise of sigma px scored as a prediction "
      "(a matcher whose only error is that noise)\n");
  for (const NoiseFloor& f : floors) {
    fmt::print("sigma {:.2f} px\n{:<40}{:>9}{:>9}{:>9}{:>9}{:>9}{:>9}{:>9}{:>9}\n", f.sigma_px,
               "scene", "bad1", "bad2", "occErr", "bandErr", "bandFr", "bandBh", "bandEdge",
               "bandSurf");
    const auto row = [](const SceneMetrics& m) {
      fmt::print("{:<40}{:>9.2f}{:>9.2f}{:>9.2f}{:>9.2f}{:>9.2f}{:>9.2f}{:>9.2f}{:>9.2f}\n",
                 m.scene, m.all.bad1, m.all.bad2, m.occ_err, m.band_err, m.band_front,
                 m.band_behind, m.band_edge, m.band_surface);
    };
    for (const SceneMetrics& m : f.metrics) row(m);
    row(dco::tools::mean_metrics(f.metrics));
  }
}

std::string noise_floor_json(const std::vector<NoiseFloor>& floors) {
  std::vector<std::string> items;
  for (const NoiseFloor& f : floors)
    items.push_back(fmt::format(R"({{"sigma_px": {}, "metrics": {}}})", json_number(f.sigma_px),
                                dco::tools::format_metrics_json(f.metrics)));
  return fmt::format(R"("noise_floor": [{}])", fmt::join(items, ", "));
}

// One method's bad-2, occErr and bandErr against the GT as given and moved by its offset.
std::string given_and_moved(const SceneMetrics& given, const SceneMetrics& moved) {
  return fmt::format("{:>8.2f}{:>8.2f}{:>8.2f}{:>8.2f}{:>8.2f}{:>8.2f}", given.all.bad2,
                     moved.all.bad2, given.occ_err, moved.occ_err, given.band_err, moved.band_err);
}

void print_alignment_text(const Options& opt, const std::vector<Scene>& scenes,
                          const std::vector<SceneMetrics>& predicted,
                          const std::vector<SceneMetrics>& baseline, const Alignment& a) {
  fmt::print(
      "\nground-truth alignment: GT + d matches the images best (photometric error in grey "
      "levels, at d = 0 and at d); the scores against GT and GT + d\n");
  std::string header = fmt::format("{:<40}{:>9}{:>9}{:>9}", "scene", "d px", "photo0", "photoD");
  const auto method_header = [&](std::string_view name) {
    header += fmt::format("  {:>8}{:>8}{:>8}{:>8}{:>8}{:>8}", fmt::format("{}bad2", name), "+d",
                          "occErr", "+d", "bandErr", "+d");
  };
  if (opt.pred_dir) method_header("");
  if (opt.baseline) method_header("bl ");
  fmt::print("{}\n", header);
  for (std::size_t i = 0; i < scenes.size(); ++i) {
    const dco::tools::GtAlignment& o = a.offsets[i];
    std::string line = fmt::format("{:<40}{:>+9.2f}{:>9.2f}{:>9.2f}", scenes[i].name, o.offset_px,
                                   o.error_at_zero, o.error_at_offset);
    if (opt.pred_dir) line += "  " + given_and_moved(predicted[i], a.predicted[i]);
    if (opt.baseline) line += "  " + given_and_moved(baseline[i], a.baseline[i]);
    fmt::print("{}\n", line);
  }
  std::string mean = fmt::format("{:<40}{:>9}{:>9}{:>9}", "mean", "-", "-", "-");
  if (opt.pred_dir)
    mean += "  " + given_and_moved(dco::tools::mean_metrics(predicted),
                                   dco::tools::mean_metrics(a.predicted));
  if (opt.baseline)
    mean += "  " + given_and_moved(dco::tools::mean_metrics(baseline),
                                   dco::tools::mean_metrics(a.baseline));
  fmt::print(
      "{}\n(bl = baseline {}; +d = against GT + d; the tables above score against the GT "
      "as given)\n",
      mean, kBaselineName);
}

std::string alignment_json(const Options& opt, const std::vector<Scene>& scenes,
                           const Alignment& a) {
  std::vector<std::string> offsets;
  for (std::size_t i = 0; i < scenes.size(); ++i) {
    const dco::tools::GtAlignment& o = a.offsets[i];
    offsets.push_back(fmt::format(
        R"({{"scene": {}, "offset_px": {}, "error_at_zero": {}, "error_at_offset": {}, "pixels": {}}})",
        json_string(scenes[i].name), json_number(o.offset_px), json_number(o.error_at_zero),
        json_number(o.error_at_offset), o.pixels));
  }
  std::string out = fmt::format(R"("gt_alignment": {{"offsets": [{}])", fmt::join(offsets, ", "));
  if (opt.pred_dir)
    out += fmt::format(R"(, "prediction": {})", dco::tools::format_metrics_json(a.predicted));
  if (opt.baseline)
    out += fmt::format(R"(, "baseline": {})", dco::tools::format_metrics_json(a.baseline));
  return out + "}";
}

void print_scenes_text(const Options& opt, const std::vector<SceneMetrics>& predicted,
                       const std::vector<SceneMetrics>& baseline) {
  if (opt.pred_dir) {
    fmt::print("prediction: {} ({} scenes)\n{}", opt.pred_dir->string(), predicted.size(),
               dco::tools::format_metrics_table(predicted));
  }
  if (opt.baseline) {
    fmt::print("{}baseline: {} ({} scenes)\n{}", opt.pred_dir ? "\n" : "", kBaselineName,
               baseline.size(), dco::tools::format_metrics_table(baseline));
  }
  if (opt.pred_dir && opt.baseline) {
    const auto rows = dco::tools::compare_key_metrics(dco::tools::mean_metrics(predicted),
                                                      dco::tools::mean_metrics(baseline));
    fmt::print("\ncomparison of the means: prediction vs {}\n{}", kBaselineName,
               dco::tools::format_comparison_table(rows, "prediction", kBaselineName));
  }
}

void print_scenes_json(const Options& opt, const std::vector<Scene>& scenes,
                       const std::vector<SceneMetrics>& predicted,
                       const std::vector<SceneMetrics>& baseline, const Alignment* alignment,
                       const std::vector<NoiseFloor>& floors) {
  std::vector<std::string> members;
  if (opt.pred_dir) {
    members.push_back(fmt::format(R"("prediction": {{"pred_dir": {}, "metrics": {}}})",
                                  dco::tools::json_string(opt.pred_dir->string()),
                                  dco::tools::format_metrics_json(predicted)));
  }
  if (opt.baseline) {
    members.push_back(fmt::format(R"("baseline": {{"name": {}, "metrics": {}}})",
                                  dco::tools::json_string(kBaselineName),
                                  dco::tools::format_metrics_json(baseline)));
  }
  if (opt.pred_dir && opt.baseline) {
    const auto rows = dco::tools::compare_key_metrics(dco::tools::mean_metrics(predicted),
                                                      dco::tools::mean_metrics(baseline));
    members.push_back(fmt::format(R"("comparison": {})", dco::tools::format_comparison_json(
                                                             rows, "prediction", kBaselineName)));
  }
  if (alignment != nullptr) members.push_back(alignment_json(opt, scenes, *alignment));
  if (!floors.empty()) members.push_back(noise_floor_json(floors));
  fmt::print("{{\n{}\n}}\n", fmt::join(members, ",\n"));
}

int run_scenes(const Options& opt) {
  const std::vector<Scene> scenes = select_scenes(opt);
  std::vector<SceneMetrics> predicted, baseline;
  std::optional<Alignment> alignment;
  if (opt.gt_alignment) alignment = Alignment{align_scenes(scenes), {}, {}};
  Alignment* a = alignment ? &*alignment : nullptr;
  if (opt.pred_dir)
    predicted = evaluate_predictions(opt, scenes, *opt.pred_dir,
                                     a ? Scorer{&a->offsets, &a->predicted} : Scorer{});
  if (opt.baseline)
    baseline = evaluate_baseline(scenes, a ? Scorer{&a->offsets, &a->baseline} : Scorer{});
  const std::vector<NoiseFloor> floors = evaluate_noise_floor(scenes, opt.noise_floor);
  if (opt.json) {
    print_scenes_json(opt, scenes, predicted, baseline, a, floors);
  } else {
    print_scenes_text(opt, predicted, baseline);
    if (opt.error_maps)
      fmt::print("\nerror maps: {}/<scene>.plane<NN>.png\n", opt.error_maps->string());
    if (a != nullptr) print_alignment_text(opt, scenes, predicted, baseline, *a);
    if (!floors.empty()) print_noise_floor_text(floors);
  }
  return 0;
}

// ---------------------------------------------------------------------------------------------
// --sequence

std::string_view planes_source(const SequenceReport& r) {
  return r.has_gt ? "ground-truth frame 0" : "prediction frame 0";
}

std::string percent_text(double value) {
  return std::isnan(value) ? "-" : fmt::format("{:.2f} %", value);
}

void print_sequence_text(const Options& opt, const SequenceReport& r) {
  fmt::print("sequence: {} ({} frames)\n", opt.sequence.string(), r.frames);
  fmt::print("planes from {}: {:.2f} px\n", planes_source(r), fmt::join(r.planes, " "));
  if (!r.has_gt) {
    fmt::print("flicker: {} of pixels change side between frames\n", percent_text(r.flicker));
    return;
  }
  fmt::print("flicker: prediction {}, ground truth {} of pixels change side between frames\n",
             percent_text(r.flicker), percent_text(r.gt_flicker));
  fmt::print("boundary within {} px (mean over frames): recall {}, precision {}\n",
             r.boundary_tolerance, percent_text(r.boundary.recall),
             percent_text(r.boundary.precision));
  fmt::print(
      "silhouettes within {} px (planes in the depth gaps, mean over frames): recall {}, "
      "precision {}\n",
      r.boundary_tolerance, percent_text(r.silhouette.recall),
      percent_text(r.silhouette.precision));
  fmt::print("\naccuracy per frame against {}\n{}", opt.gt_dir->string(),
             dco::tools::format_metrics_table(r.frame_metrics));
}

std::string boundary_json(const BoundaryAccuracy& b) {
  return fmt::format(R"({{"recall": {}, "precision": {}}})", json_number(b.recall),
                     json_number(b.precision));
}

void print_sequence_json(const Options& opt, const SequenceReport& r,
                         const std::string& noise_floor) {
  std::vector<std::string> planes, members, frames;
  for (const double p : r.planes) planes.push_back(json_number(p));
  members.push_back(fmt::format(
      R"("sequence": {{"dir": {}, "frames": {}, "planes": [{}], "planes_from": {}, "flicker": {}}})",
      json_string(opt.sequence.string()), r.frames, fmt::join(planes, ", "),
      json_string(planes_source(r)), json_number(r.flicker)));
  if (r.has_gt) {
    members.push_back(fmt::format(R"("ground_truth": {{"dir": {}, "flicker": {}}})",
                                  json_string(opt.gt_dir->string()), json_number(r.gt_flicker)));
    for (const BoundaryAccuracy& b : r.frame_boundary) frames.push_back(boundary_json(b));
    members.push_back(
        fmt::format(R"("boundary": {{"tolerance_px": {}, "mean": {}, "frames": [{}]}})",
                    r.boundary_tolerance, boundary_json(r.boundary), fmt::join(frames, ", ")));
    members.push_back(fmt::format(R"("silhouette": {{"tolerance_px": {}, "mean": {}}})",
                                  r.boundary_tolerance, boundary_json(r.silhouette)));
    members.push_back(
        fmt::format(R"("metrics": {})", dco::tools::format_metrics_json(r.frame_metrics)));
  }
  if (!noise_floor.empty()) members.push_back(noise_floor);
  fmt::print("{{\n{}\n}}\n", fmt::join(members, ",\n"));
}

// --noise-floor with --sequence: the GT frames plus noise as the predicted frames, per sigma.
struct SequenceNoiseFloor {
  double sigma_px = 0;
  SequenceReport report;
};

void print_sequence_noise_floor_text(const std::vector<SequenceNoiseFloor>& floors) {
  fmt::print(
      "\nnoise floor: the ground-truth frames plus Gaussian noise of sigma px as the predicted "
      "frames (means over frames)\n{:<12}{:>9}{:>9}{:>9}{:>9}{:>9}{:>9}{:>11}{:>11}\n",
      "sigma px", "flicker", "bad2", "occErr", "bandErr", "bandEdge", "bandSurf", "sil. rec.",
      "sil. prec.");
  for (const SequenceNoiseFloor& f : floors) {
    const SceneMetrics m = dco::tools::mean_metrics(f.report.frame_metrics);
    fmt::print("{:<12.2f}{:>9.2f}{:>9.2f}{:>9.2f}{:>9.2f}{:>9.2f}{:>9.2f}{:>11.2f}{:>11.2f}\n",
               f.sigma_px, f.report.flicker, m.all.bad2, m.occ_err, m.band_err, m.band_edge,
               m.band_surface, f.report.silhouette.recall, f.report.silhouette.precision);
  }
}

std::string sequence_noise_floor_json(const std::vector<SequenceNoiseFloor>& floors) {
  std::vector<std::string> items;
  for (const SequenceNoiseFloor& f : floors)
    items.push_back(fmt::format(
        R"({{"sigma_px": {}, "flicker": {}, "silhouette": {}, "metrics": {}}})",
        json_number(f.sigma_px), json_number(f.report.flicker), boundary_json(f.report.silhouette),
        dco::tools::format_metrics_json(f.report.frame_metrics)));
  return fmt::format(R"("noise_floor": [{}])", fmt::join(items, ", "));
}

int run_sequence(const Options& opt) {
  const SequenceReport report = dco::tools::evaluate_sequence(opt.sequence, opt.gt_dir);
  std::vector<SequenceNoiseFloor> floors;
  for (const double sigma : opt.noise_floor)
    floors.push_back({sigma, dco::tools::evaluate_noisy_gt_sequence(*opt.gt_dir, sigma)});
  if (opt.json) {
    print_sequence_json(opt, report, floors.empty() ? "" : sequence_noise_floor_json(floors));
  } else {
    print_sequence_text(opt, report);
    if (!floors.empty()) print_sequence_noise_floor_text(floors);
  }
  return 0;
}

// ---------------------------------------------------------------------------------------------
// --flow-sintel

struct SintelRow {
  std::string sequence;  // "<pass>/<sequence>", e.g. "clean/easy"
  dco::tools::SintelFlowResult epe;
};

// DIR/<pass>/<sequence>/ folders with everything evaluate_sintel_flow reads, sorted by name.
std::vector<std::pair<std::string, fs::path>> find_sintel_sequences(const fs::path& dir) {
  if (!fs::is_directory(dir))
    throw dco::Error(fmt::format("Sintel directory '{}' does not exist", dir.string()));
  std::vector<std::pair<std::string, fs::path>> found;
  for (const fs::directory_entry& pass : fs::directory_iterator(dir)) {
    if (!pass.is_directory()) continue;
    for (const fs::directory_entry& seq : fs::directory_iterator(pass.path())) {
      const fs::path& p = seq.path();
      const bool complete = seq.is_directory() && fs::exists(p / "frame_0002.png") &&
                            fs::exists(p / "frame_0003.png") &&
                            fs::exists(p / "gt" / "frame_0002.flo") &&
                            fs::exists(p / "gt" / "invalid" / "frame_0002.png") &&
                            fs::exists(p / "gt" / "occlusions" / "frame_0002.png");
      if (complete) found.emplace_back((pass.path().filename() / p.filename()).generic_string(), p);
    }
  }
  if (found.empty())
    throw dco::Error(fmt::format(
        "'{}' holds no <pass>/<sequence>/ folder with frame_0002.png, frame_0003.png and "
        "gt/frame_0002.flo (+ gt/invalid, gt/occlusions)",
        dir.string()));
  std::sort(found.begin(), found.end());
  return found;
}

SintelRow mean_row(const std::vector<SintelRow>& rows) {
  SintelRow mean{"mean", {}};
  for (const SintelRow& r : rows) {
    mean.epe.epe_all += r.epe.epe_all / static_cast<double>(rows.size());
    mean.epe.epe_noc += r.epe.epe_noc / static_cast<double>(rows.size());
  }
  return mean;
}

void print_sintel_text(const Options& opt, const std::vector<SintelRow>& rows) {
  fmt::print("Sintel flow: {} (DIS preset {}, {} sequences)\n", opt.sintel.string(), opt.dis_preset,
             rows.size());
  fmt::print("{:<16}{:>12}{:>12}\n", "sequence", "EPE all", "EPE noc");
  for (const SintelRow& r : rows)
    fmt::print("{:<16}{:>12.3f}{:>12.3f}\n", r.sequence, r.epe.epe_all, r.epe.epe_noc);
  const SintelRow mean = mean_row(rows);
  fmt::print("{:<16}{:>12.3f}{:>12.3f}\n", mean.sequence, mean.epe.epe_all, mean.epe.epe_noc);
  fmt::print("(mean end-point error in px over valid pixels; noc = visible in both frames)\n");
}

std::string sintel_row_json(const SintelRow& r) {
  return fmt::format(R"({{"sequence": {}, "epe_all": {}, "epe_noc": {}}})", json_string(r.sequence),
                     json_number(r.epe.epe_all), json_number(r.epe.epe_noc));
}

void print_sintel_json(const Options& opt, const std::vector<SintelRow>& rows) {
  std::vector<std::string> items;
  for (const SintelRow& r : rows) items.push_back("\n  " + sintel_row_json(r));
  fmt::print(
      "{{\n\"flow_sintel\": {{\"dir\": {}, \"dis_preset\": {}, \"sequences\": [{}\n], \"mean\": "
      "{}}}\n}}\n",
      json_string(opt.sintel.string()), json_string(opt.dis_preset), fmt::join(items, ","),
      sintel_row_json(mean_row(rows)));
}

int run_flow_sintel(const Options& opt) {
  std::vector<SintelRow> rows;
  for (const auto& [name, dir] : find_sintel_sequences(opt.sintel))
    rows.push_back({name, dco::tools::evaluate_sintel_flow(dir, opt.dis_preset)});
  if (opt.json)
    print_sintel_json(opt, rows);
  else
    print_sintel_text(opt, rows);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return dco::tools::run_tool("dco-eval", [&] {
    const Options opt = parse_args(argc, argv);
    if (opt.help) {
      fmt::print("{}", kUsage);
      return 0;
    }
    switch (opt.mode) {
      case Mode::kScenes:
        return run_scenes(opt);
      case Mode::kSequence:
        return run_sequence(opt);
      case Mode::kFlowSintel:
        return run_flow_sintel(opt);
      case Mode::kNone:
        break;
    }
    throw std::logic_error("dco-eval: no mode chosen");
  });
}
