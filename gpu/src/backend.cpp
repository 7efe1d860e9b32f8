#include "dco/gpu/backend.hpp"

#include <fmt/format.h>

#include "dco/core/error.hpp"

#ifdef DCO_HAVE_CUDA
#include "cuda_entry.hpp"
#endif

namespace dco::gpu {

std::string CudaDevice::describe() const {
  if (!usable) return "no usable CUDA device: " + why;
  return fmt::format("{} (sm_{}{}, {:.1f} GiB)", name, compute_major, compute_minor, memory_gib);
}

bool built_with_cuda() {
#ifdef DCO_HAVE_CUDA
  return true;
#else
  return false;
#endif
}

CudaDevice probe_cuda() {
#ifdef DCO_HAVE_CUDA
  return detail::cuda_probe();
#else
  CudaDevice d;
  d.why = "this build has no CUDA path (nvcc was not found when it was configured)";
  return d;
#endif
}

std::unique_ptr<stereo::StereoMatcher> make_cuda_stereo_matcher(
    const stereo::StereoParams& params) {
#ifdef DCO_HAVE_CUDA
  return detail::cuda_stereo_matcher(params);
#else
  (void)params;
  throw Error("cuda: " + probe_cuda().why);
#endif
}

std::unique_ptr<contour::ContourExtractor> make_cuda_contour_extractor(
    const contour::ContourParams& params) {
#ifdef DCO_HAVE_CUDA
  return detail::cuda_contour_extractor(params);
#else
  (void)params;
  throw Error("cuda: " + probe_cuda().why);
#endif
}

std::unique_ptr<densify::SystemSolver> make_cuda_densify_solver(
    const densify::DensifyParams& params) {
#ifdef DCO_HAVE_CUDA
  return detail::cuda_densify_solver(params);
#else
  (void)params;
  throw Error("cuda: " + probe_cuda().why);
#endif
}

std::unique_ptr<densify::PhotometricRefinement> make_cuda_photometric_refinement() {
#ifdef DCO_HAVE_CUDA
  return detail::cuda_photometric_refinement();
#else
  throw Error("cuda: " + probe_cuda().why);
#endif
}

std::unique_ptr<PairRemapper> make_cuda_pair_remapper(const Rectifier& rectifier) {
  if (!rectifier.needs_remap())
    throw Error("cuda: the calibration is already rectified; there is nothing to remap");
#ifdef DCO_HAVE_CUDA
  return detail::cuda_pair_remapper(rectifier);
#else
  throw Error("cuda: " + probe_cuda().why);
#endif
}

BackendChoice choose_backend(const std::string& requested, const stereo::StereoParams& params) {
  BackendChoice c;
  if (requested == "cpu") {
    c.backend = "cpu";
    c.message = "backend cpu (runtime.backend = cpu)";
    return c;
  }
  if (requested != "auto" && requested != "cuda")
    throw Error("runtime.backend must be auto, cpu or cuda, not '" + requested + "'");
  const CudaDevice device = probe_cuda();
  std::string why = device.why;
  if (device.usable) {
    try {
      make_cuda_stereo_matcher(params);  // initialises the context and the stream once
      c.backend = "cuda";
      c.message = "backend cuda on " + device.describe() +
                  ": rectification, sparse stereo, the contour image passes, the densify "
                  "solver and the photometric refinement on the GPU, optical flow and the "
                  "densify system on the CPU";
      c.stages.stereo = [](const stereo::StereoParams& p) { return make_cuda_stereo_matcher(p); };
      c.stages.contour = [](const contour::ContourParams& p) {
        return make_cuda_contour_extractor(p);
      };
      c.stages.densify_solver = [](const densify::DensifyParams& p) {
        return make_cuda_densify_solver(p);
      };
      c.stages.photometric_refinement = [] { return make_cuda_photometric_refinement(); };
      c.stages.on_gpu = true;
      c.remapper = [](const Rectifier& r) { return make_cuda_pair_remapper(r); };
      return c;
    } catch (const std::exception& e) {
      why = e.what();
    }
  }
  if (requested == "cuda") throw Error("runtime.backend = cuda, but " + why);
  c.backend = "cpu";
  c.fell_back = built_with_cuda();
  c.message = "backend cpu (auto: " + why + ")";
  return c;
}

}  // namespace dco::gpu
