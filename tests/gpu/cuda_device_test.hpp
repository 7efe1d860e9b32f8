#pragma once

#include <gtest/gtest.h>

#include <cstdio>

#include "dco/gpu/backend.hpp"

namespace dco::gpu::testing {

// Tests that need a working CUDA device: skipped with the runtime's reason where there is none,
// and naming the device where there is one.
class CudaDeviceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const CudaDevice device = probe_cuda();
    if (!device.usable) GTEST_SKIP() << "no CUDA device to run on: " << device.why;
    std::printf("device: %s\n", device.describe().c_str());
  }
};

}  // namespace dco::gpu::testing
