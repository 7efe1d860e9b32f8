// dco-eval: scores disparity maps written by dco-depth (or anything else that writes PFM) against
// the ground truth of the scene manifest, optionally next to the OpenCV SGBM+WLS baseline.

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/core.hpp>

#include "dco/core/disparity_io.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image_io.hpp"
#include "dco/tools/command_line.hpp"
#include "dco/tools/json.hpp"
#include "dco/tools/metrics.hpp"
#include "dco/tools/scene_manifest.hpp"
#include "dco/tools/sgbm_wls.hpp"

namespace {

namespace fs = std::filesystem;
using dco::tools::Scene;
using dco::tools::SceneMetrics;
using dco::tools::UsageError;

constexpr std::string_view kUsage =
    R"(usage: dco-eval --scenes TSV [--data-root DIR] [--pred-dir DIR]
                [--baseline sgbm-wls] [--only SUBSTRING] [--json]

Scores predicted disparity maps against the ground truth of every scene in the manifest.

  --scenes TSV        scene manifest (stereo_scenes.tsv)
  --data-root DIR     directory the manifest's paths are relative to (default: the TSV's directory)
  --pred-dir DIR      predictions: DIR/<scene with '/' -> '_'>.pfm, float px at the GT resolution,
                      +inf / NaN / <= 0 = no prediction. An optional DIR/<same>.time_ms holding one
                      number (milliseconds) supplies the method's run time.
  --baseline sgbm-wls also run OpenCV StereoSGBM + WLS filter on every scene and compare
  --only SUBSTRING    only scenes whose name contains SUBSTRING
  --json              print one JSON document instead of tables
  -h, --help          print this help

At least one of --pred-dir and --baseline is needed.
Exit status: 0 success, 1 bad data (missing or malformed files), 2 bad command line.
)";

constexpr std::string_view kBaselineName = "sgbm-wls";

struct Options {
  fs::path scenes;
  std::optional<fs::path> data_root;
  std::optional<fs::path> pred_dir;
  bool baseline = false;
  std::string only;
  bool json = false;
  bool help = false;
};

Options parse_args(int argc, char** argv) {
  Options opt;
  dco::tools::ArgCursor args(argc, argv);
  while (args.next()) {
    const std::string_view arg = args.name();
    const auto value = [&] { return args.value(); };
    const auto flag = [&] { return args.flag(); };

    if (arg == "-h" || arg == "--help")
      opt.help = flag();
    else if (arg == "--json")
      opt.json = flag();
    else if (arg == "--scenes")
      opt.scenes = value();
    else if (arg == "--data-root")
      opt.data_root = value();
    else if (arg == "--pred-dir")
      opt.pred_dir = value();
    else if (arg == "--only")
      opt.only = value();
    else if (arg == "--baseline") {
      const std::string name = value();
      if (name != kBaselineName)
        throw UsageError(fmt::format("unknown baseline '{}' (known: {})", name, kBaselineName));
      opt.baseline = true;
    } else if (arg.starts_with("-")) {
      throw UsageError(fmt::format("unknown option {}", arg));
    } else {
      throw UsageError(fmt::format("unexpected argument '{}'", arg));
    }
  }
  if (opt.help) return opt;
  if (opt.scenes.empty()) throw UsageError("--scenes is required");
  if (!opt.pred_dir && !opt.baseline) throw UsageError("give --pred-dir, --baseline or both");
  return opt;
}

std::vector<Scene> select_scenes(const Options& opt) {
  const fs::path data_root = opt.data_root.value_or(opt.scenes.parent_path());
  std::vector<Scene> scenes = dco::tools::load_scene_manifest(opt.scenes, data_root);
  std::erase_if(scenes, [&](const Scene& s) { return s.name.find(opt.only) == std::string::npos; });
  if (scenes.empty())
    throw UsageError(opt.only.empty() ? fmt::format("'{}' lists no scene", opt.scenes.string())
                                      : fmt::format("no scene name contains '{}'", opt.only));
  return scenes;
}

// The optional DIR/<stem>.time_ms sidecar; NaN when there is none.
double read_time_ms(const fs::path& path) {
  if (!fs::exists(path)) return dco::tools::kUndefined;
  std::ifstream in(path);
  double ms = 0;
  if (!(in >> ms) || !(ms >= 0))
    throw dco::Error(fmt::format("'{}' does not hold a time in milliseconds", path.string()));
  return ms;
}

std::vector<SceneMetrics> evaluate_predictions(const std::vector<Scene>& scenes,
                                               const fs::path& pred_dir) {
  if (!fs::is_directory(pred_dir))
    throw dco::Error(fmt::format("prediction directory '{}' does not exist", pred_dir.string()));
  std::vector<SceneMetrics> results;
  for (const Scene& scene : scenes) {
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
    SceneMetrics m = dco::tools::evaluate_disparity(scene.name, prediction.view(), gt);
    m.time_ms = read_time_ms(pred_dir / (scene.file_stem() + ".time_ms"));
    results.push_back(std::move(m));
  }
  return results;
}

std::vector<SceneMetrics> evaluate_baseline(const std::vector<Scene>& scenes) {
  std::vector<SceneMetrics> results;
  for (const Scene& scene : scenes) {
    const dco::Image<std::uint8_t> left = dco::load_image(scene.left);
    const dco::Image<std::uint8_t> right = dco::load_image(scene.right);
    const dco::tools::BaselineResult baseline =
        dco::tools::run_sgbm_wls(left.view(), right.view(), scene.max_disp);
    SceneMetrics m = dco::tools::evaluate_disparity(scene.name, baseline.disparity.view(),
                                                    dco::tools::load_ground_truth(scene));
    m.time_ms = baseline.time_ms;
    results.push_back(std::move(m));
  }
  return results;
}

void print_text(const Options& opt, const std::vector<SceneMetrics>& predicted,
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

void print_json(const Options& opt, const std::vector<SceneMetrics>& predicted,
                const std::vector<SceneMetrics>& baseline) {
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
  fmt::print("{{\n{}\n}}\n", fmt::join(members, ",\n"));
}

}  // namespace

int main(int argc, char** argv) {
  return dco::tools::run_tool("dco-eval", [&] {
    const Options opt = parse_args(argc, argv);
    if (opt.help) {
      fmt::print("{}", kUsage);
      return 0;
    }
    const std::vector<Scene> scenes = select_scenes(opt);
    std::vector<SceneMetrics> predicted, baseline;
    if (opt.pred_dir) predicted = evaluate_predictions(scenes, *opt.pred_dir);
    if (opt.baseline) baseline = evaluate_baseline(scenes);
    if (opt.json)
      print_json(opt, predicted, baseline);
    else
      print_text(opt, predicted, baseline);
    return 0;
  });
}
