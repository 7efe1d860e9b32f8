#pragma once

namespace dco {

// Makes the C library keep the memory this process frees for its next allocations instead of
// handing it back to the kernel. OpenCV allocates and frees its working images on every call (the
// DIS optical flow of the contour stage, StereoSGBM); with glibc's defaults freed blocks above a
// threshold can go back to the kernel, and every page of them faults in again on the next call.
// On the main thread at 1280x720 that doubled the time of the flow. Process-wide: the executables
// call it once at the start of main, before any thread starts. Returns false, changing nothing,
// where the C library offers no such setting.
bool retain_freed_memory();

}  // namespace dco
