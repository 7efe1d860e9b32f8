// Seeds of the scene manifest target: the shared manifest's layout with rows over the target's
// own files (PFM and PNG ground truth, masks of the right and of the wrong size), and the header
// in another column order with an extra column.

#include <cstdint>
#include <string_view>
#include <vector>

#include "fuzz_target.hpp"

namespace dco::fuzz {
namespace {

constexpr std::string_view kManifest =
    "# Stereo scenes with ground-truth disparity of the LEFT image.\n"
    "scene\tleft\tright\tgt\tgt_format\tgt_divisor\tnocc_mask\tmax_disp\n"
    "a/pfm\tl.png\tr.png\tgt.pfm\tpfm\t1\tmask.png\t16\n"
    "b/png\tl.png\tr.png\tgt.png\tpng\t256\t-\t32\n"
    "c/small_mask\tl.png\tr.png\tgt.png\tpng\t256\tsmall.png\t8\n"
    "d/mask_as_gt\tl.png\tr.png\tmask.png\tpng\t4\t-\t8\n";

constexpr std::string_view kReordered =
    "max_disp\tgt\tscene\tnote\tleft\tright\tgt_format\tgt_divisor\tnocc_mask\r\n"
    "64\tgt.pfm\tkitti/000046\tfree text\tleft.png\tright.png\tpfm\t1\t-\r\n";

std::vector<std::uint8_t> bytes(std::string_view text) {
  return {text.begin(), text.end()};
}

}  // namespace

std::vector<std::vector<std::uint8_t>> seeds() {
  return {bytes(kManifest), bytes(kReordered)};
}

}  // namespace dco::fuzz
