#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/gpu/backend.hpp"
#include "support/example_rigs.hpp"

namespace dco::gpu {
namespace {

TEST(Backend, CpuIsTheCpuStage) {
  const BackendChoice c = choose_backend("cpu", {});
  EXPECT_EQ(c.backend, "cpu");
  EXPECT_FALSE(c.stages.stereo);
  EXPECT_FALSE(c.stages.contour);
  EXPECT_FALSE(c.stages.densify_solver);
  EXPECT_FALSE(c.stages.photometric_refinement);
  EXPECT_FALSE(c.remapper);
  EXPECT_FALSE(c.fell_back);
}

TEST(Backend, AutoTakesCudaExactlyWhenADeviceWorks) {
  const CudaDevice device = probe_cuda();
  const BackendChoice c = choose_backend("auto", {});
  if (device.usable) {
    EXPECT_EQ(c.backend, "cuda") << c.message;
    ASSERT_TRUE(c.stages.stereo);
    ASSERT_TRUE(c.stages.contour);
    ASSERT_TRUE(c.stages.densify_solver);
    ASSERT_TRUE(c.stages.photometric_refinement);
    // The GPU refinement is not held to the CPU's pixel budget: the camera's full size too.
    EXPECT_TRUE(c.stages.photometric_refinement()->refines({}, 1280, 720));
    ASSERT_TRUE(c.remapper);
    EXPECT_NE(c.message.find(device.name), std::string::npos) << c.message;
  } else {
    EXPECT_EQ(c.backend, "cpu");
    EXPECT_FALSE(c.stages.stereo);
    EXPECT_FALSE(c.stages.contour);
    EXPECT_FALSE(c.stages.densify_solver);
    EXPECT_FALSE(c.stages.photometric_refinement);
    EXPECT_FALSE(c.remapper);
    EXPECT_EQ(c.fell_back, built_with_cuda());
    // The log line says why.
    EXPECT_NE(c.message.find(device.why), std::string::npos) << c.message;
    EXPECT_FALSE(device.why.empty());
  }
}

TEST(Backend, CudaWithoutADeviceIsOneClearError) {
  const CudaDevice device = probe_cuda();
  if (device.usable) GTEST_SKIP() << "a CUDA device works here: " << device.describe();
  try {
    choose_backend("cuda", {});
    FAIL() << "cuda chosen without a device";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("runtime.backend = cuda, but"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(make_cuda_stereo_matcher({}), Error);
  EXPECT_THROW(make_cuda_contour_extractor({}), Error);
  EXPECT_THROW(make_cuda_densify_solver({}), Error);
  EXPECT_THROW(make_cuda_photometric_refinement(), Error);
  EXPECT_THROW(make_cuda_pair_remapper(Rectifier(test::pinhole_rig())), Error);
}

TEST(Backend, APassThroughRectifierHasNothingToRemap) {
  StereoCalibration calib = test::pinhole_rig();
  calib.is_rectified = true;
  calib.rectified = {640, 480, 500, 320, 320, 240, 0.1};
  try {
    make_cuda_pair_remapper(Rectifier(calib));
    FAIL() << "a remapper for a pass-through";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("already rectified"), std::string::npos) << e.what();
  }
}

TEST(Backend, UnknownNamesAreRefused) {
  EXPECT_THROW(choose_backend("opencl", {}), Error);
}

}  // namespace
}  // namespace dco::gpu
