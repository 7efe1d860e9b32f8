#pragma once

#include <cstdint>
#include <filesystem>
#include <string_view>

#include "dco/core/image.hpp"

// A sanity check of the optical-flow stage: DIS flow against the ground truth of MPI Sintel (or any
// sequence stored with Middlebury .flo files).
namespace dco::tools {

// Middlebury .flo: float32 tag 202021.25 ("PIEH"), int32 width, int32 height, then width*height
// (u, v) float32 pairs, row-major, little-endian; pixels. Returns a 2-channel image (u, v).
// Throws dco::Error naming the file when it is missing, has the wrong tag, an implausible size or
// not exactly the expected number of bytes.
Image<float> read_flo(const std::filesystem::path& path);

// Writes `flow` (2 channels) in the same format. Throws dco::Error when the file cannot be written.
void write_flo(const std::filesystem::path& path, ImageView<const float> flow);

// Mean end-point error |flow - gt| (pixels) of cv::DISOpticalFlow from `frame_a` to `frame_b`.
// Frames: 8-bit, 1 or 3 (BGR) channels, same size as `gt_flow` (2 channels). Pixels count where
// `valid_mask` (optional, 8-bit) is non-zero and the ground truth is known (finite and below the
// Middlebury "unknown" magnitude 1e9). `preset`: ultrafast, fast or medium. Runs with OpenCV's
// current thread setting. Throws dco::Error on bad input or when no pixel counts.
double dis_endpoint_error(ImageView<const std::uint8_t> frame_a,
                          ImageView<const std::uint8_t> frame_b, ImageView<const float> gt_flow,
                          ImageView<const std::uint8_t> valid_mask = {},
                          std::string_view preset = "fast");

// One Sintel sequence in the layout of shared/data/sintel_flow/<pass>/<sequence>/: flow
// frame_0002 -> frame_0003 against gt/frame_0002.flo, excluding gt/invalid (255) everywhere and
// also gt/occlusions (255) for the non-occluded number.
struct SintelFlowResult {
  double epe_all = 0;  // over every valid pixel
  double epe_noc = 0;  // over valid pixels visible in both frames
};
SintelFlowResult evaluate_sintel_flow(const std::filesystem::path& sequence_dir,
                                      std::string_view preset = "fast");

}  // namespace dco::tools
