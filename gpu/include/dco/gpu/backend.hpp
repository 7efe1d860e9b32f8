#pragma once

#include <functional>
#include <memory>
#include <string>

#include "dco/core/rectifier.hpp"
#include "dco/pipeline/contour/contour_extractor.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"

// Where the stages run. The CUDA path (built when nvcc was found) computes the rectification,
// the sparse stereo stage, the image side of the contour stage, the densify solver and the
// photometric refinement on the GPU with the same per-pixel math as the CPU path; DIS optical
// flow and building the densify system stay on the CPU.
namespace dco::gpu {

// What the CUDA runtime reports about device 0.
struct CudaDevice {
  bool usable = false;
  std::string why;  // when not usable: the reason, in words
  std::string name;
  int compute_major = 0, compute_minor = 0;
  double memory_gib = 0;
  std::string describe() const;  // "NVIDIA H100 (sm_90, 79.1 GiB)"
};

// True when this build has the CUDA path.
bool built_with_cuda();
// Never throws; without CUDA in the build or without a working device, usable is false.
CudaDevice probe_cuda();

// The sparse stage on the GPU. Throws dco::Error when the build has no CUDA or CUDA cannot be
// initialised (no device, no driver, out of memory).
std::unique_ptr<stereo::StereoMatcher> make_cuda_stereo_matcher(const stereo::StereoParams& params);
// The contour stage with its stereo cue, Gaussian, gradient and Canny classification on the GPU
// (GridContourExtractor). Throws like make_cuda_stereo_matcher.
std::unique_ptr<contour::ContourExtractor> make_cuda_contour_extractor(
    const contour::ContourParams& params);
// The densify solver on the GPU (GridSystemSolver). Throws like make_cuda_stereo_matcher.
std::unique_ptr<densify::SystemSolver> make_cuda_densify_solver(
    const densify::DensifyParams& params);
// The densifier's photometric refinement on the GPU (GridPhotometricRefiner). Throws like
// make_cuda_stereo_matcher.
std::unique_ptr<densify::PhotometricRefinement> make_cuda_photometric_refinement();

// Rectification of raw pairs on the GPU (GridPairRemapper): the rectifier's maps, cv::remap's
// bytes. Throws like make_cuda_stereo_matcher, and when the rectifier is a pass-through.
std::unique_ptr<PairRemapper> make_cuda_pair_remapper(const Rectifier& rectifier);

// runtime.backend resolved on this machine: "auto" takes CUDA when a device works (a stage is
// made once to prove it) and else the CPU, saying why; "cuda" insists (dco::Error when CUDA is
// unusable); "cpu" is the CPU. Throws dco::Error on any other name.
struct BackendChoice {
  std::string backend;              // "cpu" or "cuda"
  std::string message;              // one line for the log: what was chosen and why
  bool fell_back = false;           // "auto" wanted CUDA but could not have it
  pipeline::StageFactories stages;  // empty for the CPU
  // Where raw frames need rectifying: how to get the GPU's remapper (empty for the CPU).
  std::function<std::unique_ptr<PairRemapper>(const Rectifier&)> remapper;
};
BackendChoice choose_backend(const std::string& requested, const stereo::StereoParams& params);

}  // namespace dco::gpu
