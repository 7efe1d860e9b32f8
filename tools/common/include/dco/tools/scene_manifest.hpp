#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "dco/core/image.hpp"

namespace dco::tools {

enum class GroundTruthFormat { kPfm, kPng };

// One row of stereo_scenes.tsv, with paths resolved against the data root.
struct Scene {
  std::string name;  // e.g. "middlebury2014/Motorcycle"
  std::filesystem::path left, right, gt;
  GroundTruthFormat gt_format = GroundTruthFormat::kPfm;
  double gt_divisor = 1;
  std::optional<std::filesystem::path> nocc_mask;
  int max_disp = 0;
  int position = 0;  // among the manifest's scenes, from 0: stays with the scene when some are
                     // left out (per-scene seeds)

  // "middlebury2014_Motorcycle": the file stem dco-depth and dco-eval agree on.
  std::string file_stem() const;
};

// Reads the tab-separated manifest (lines starting with '#' are comments; the header row names
// the columns scene, left, right, gt, gt_format, gt_divisor, nocc_mask, max_disp in any order).
// Throws dco::Error("FILE:LINE: ...") on a malformed row or an unknown format.
std::vector<Scene> load_scene_manifest(const std::filesystem::path& tsv,
                                       const std::filesystem::path& data_root);

struct GroundTruth {
  Image<float> disparity;    // pixels, +inf where unknown
  Image<std::uint8_t> nocc;  // 255 = non-occluded with GT, empty when the scene has no mask
};

// Decodes the scene's GT as the manifest says (PFM as is; PNG channel 0 / divisor, 0 = unknown).
GroundTruth load_ground_truth(const Scene& scene);

}  // namespace dco::tools
