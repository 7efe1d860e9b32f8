#pragma once

#include <memory>

#include "dco/gpu/backend.hpp"

// What the CUDA translation unit provides to backend.cpp (only in builds with CUDA).
namespace dco::gpu::detail {

CudaDevice cuda_probe();
std::unique_ptr<stereo::StereoMatcher> cuda_stereo_matcher(const stereo::StereoParams& params);
std::unique_ptr<contour::ContourExtractor> cuda_contour_extractor(
    const contour::ContourParams& params);
std::unique_ptr<densify::SystemSolver> cuda_densify_solver(const densify::DensifyParams& params);
std::unique_ptr<densify::PhotometricRefinement> cuda_photometric_refinement();
std::unique_ptr<PairRemapper> cuda_pair_remapper(const Rectifier& rectifier);

}  // namespace dco::gpu::detail
