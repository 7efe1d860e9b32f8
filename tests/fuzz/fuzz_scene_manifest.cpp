// Entry point: arbitrary bytes as a scene manifest (stereo_scenes.tsv) over a data root holding
// a few small ground-truth files and masks. A malformed manifest must be refused with a dco::Error
// naming it; an accepted one has scenes dco-depth and dco-eval can tell apart, and their ground
// truth decodes to +inf or positive finite disparities, or is refused with a dco::Error.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "dco/core/disparity_io.hpp"
#include "dco/core/error.hpp"
#include "dco/core/image.hpp"
#include "dco/core/image_io.hpp"
#include "dco/tools/scene_manifest.hpp"
#include "fuzz_target.hpp"
#include "scratch_dir.hpp"

namespace {

using dco::tools::Scene;

// The files the seeds name: ground truth as PFM and 16-bit PNG, masks of its size and of another.
const dco::fuzz::ScratchDir& data_root() {
  static const dco::fuzz::ScratchDir dir("scene_manifest");
  static const bool written = [] {
    dco::Image<float> gt(8, 6);
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < 8; ++x) gt.row(y)[x] = x == y ? INFINITY : 1.5f + static_cast<float>(x);
    dco::write_pfm(dir.path() / "gt.pfm", gt.cview());
    dco::write_disparity_png16(dir.path() / "gt.png", gt.cview());
    dco::Image<std::uint8_t> mask(8, 6), small(4, 3);
    dco::save_image(dir.path() / "mask.png", mask.cview());
    dco::save_image(dir.path() / "small.png", small.cview());
    return true;
  }();
  (void)written;
  return dir;
}

void check_ground_truth(const Scene& scene) {
  dco::tools::GroundTruth gt;
  try {
    gt = dco::tools::load_ground_truth(scene);
  } catch (const dco::Error& e) {
    if (e.what()[0] == '\0') std::abort();
    return;
  }
  const dco::Image<float>& d = gt.disparity;
  for (int y = 0; y < d.height(); ++y)
    for (int x = 0; x < d.width(); ++x)
      if (!(d.row(y)[x] == INFINITY || (std::isfinite(d.row(y)[x]) && d.row(y)[x] > 0)))
        std::abort();
  if (!gt.nocc.empty() && (gt.nocc.width() != d.width() || gt.nocc.height() != d.height()))
    std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path& root = data_root().path();
  const std::filesystem::path manifest =
      data_root().write("scenes.tsv", {reinterpret_cast<const char*>(data), size});
  std::vector<Scene> scenes;
  try {
    scenes = dco::tools::load_scene_manifest(manifest, root);
  } catch (const dco::Error& e) {
    if (std::string_view(e.what()).find("scenes.tsv") == std::string_view::npos) std::abort();
    return 0;
  }
  std::set<std::string> stems;
  for (const Scene& scene : scenes) {
    if (scene.name.empty() || scene.max_disp <= 0) std::abort();
    if (!(scene.gt_divisor >= 1e-6 && scene.gt_divisor <= 1e6)) std::abort();
    if (!stems.insert(scene.file_stem()).second) std::abort();
  }
  // Decoding is the slow part: the first few scenes are enough to reach every decoder.
  for (std::size_t i = 0; i < scenes.size() && i < 4; ++i) check_ground_truth(scenes[i]);
  return 0;
}
