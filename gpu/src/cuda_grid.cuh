#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <string>
#include <utility>

#include "dco/core/error.hpp"

// The Grid of GridStereoMatcher on a CUDA device: device buffers, pinned staging buffers, one
// stream; every pass is one kernel launch over the grid.
namespace dco::gpu {

inline void cuda_check(cudaError_t status, const char* what) {
  if (status == cudaSuccess) return;
  // The runtime keeps a failed call's error as the thread's last one until it is read: read here,
  // or the next launch's check would report it again for a launch that succeeded.
  (void)cudaGetLastError();
  throw Error(std::string("cuda: ") + what + ": " + cudaGetErrorString(status));
}

template <class F>
__global__ void grid_kernel(F f, int nx, int ny) {
  const int x = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x);
  const int y = static_cast<int>(blockIdx.y * blockDim.y + threadIdx.y);
  if (x < nx && y < ny) f(x, y);
}

template <class F>
__global__ void steps_kernel(F f, int steps) {
  const int x = static_cast<int>(threadIdx.x);
  const int y = static_cast<int>(threadIdx.y);
  for (int s = 0; s < steps; ++s) {
    f(x, y, s);
    __syncthreads();  // also makes the step's global writes visible to the whole block
  }
}

class CudaGrid {
 public:
  // The most grid points launch_steps takes: one thread block.
  static constexpr int kMaxStepPoints = 1024;

  template <class T, bool kPinned>
  class Memory {
   public:
    Memory() = default;
    Memory(const Memory&) = delete;
    Memory& operator=(const Memory&) = delete;
    ~Memory() { release(); }
    // Reallocates only when the size changes (a new geometry), never per frame.
    void resize(std::size_t n) {
      if (n == size_) return;
      release();
      if (n == 0) return;
      void* p = nullptr;
      if (kPinned)
        cuda_check(cudaHostAlloc(&p, n * sizeof(T), cudaHostAllocDefault), "cudaHostAlloc");
      else
        cuda_check(cudaMalloc(&p, n * sizeof(T)), "cudaMalloc");
      data_ = static_cast<T*>(p);
      size_ = n;
    }
    T* data() { return data_; }
    const T* data() const { return data_; }
    std::size_t size() const { return size_; }

   private:
    void release() {
      if (data_ == nullptr) return;
      // A failure here (the context already broken) must not linger as the next launch's error.
      if ((kPinned ? cudaFreeHost(data_) : cudaFree(data_)) != cudaSuccess)
        (void)cudaGetLastError();
      data_ = nullptr;
      size_ = 0;
    }
    T* data_ = nullptr;
    std::size_t size_ = 0;
  };
  template <class T>
  using Buffer = Memory<T, false>;
  template <class T>
  using Staging = Memory<T, true>;

  CudaGrid() {
    cuda_check(cudaSetDevice(0), "cudaSetDevice");
    cuda_check(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking), "cudaStreamCreate");
  }
  CudaGrid(const CudaGrid&) = delete;
  CudaGrid& operator=(const CudaGrid&) = delete;
  ~CudaGrid() {
    if (stream_ != nullptr) cudaStreamDestroy(stream_);
  }

  template <class F>
  void launch(int nx, int ny, const F& f) {
    if (nx <= 0 || ny <= 0) return;
    const dim3 block = ny == 1 ? dim3(256, 1) : dim3(64, 4);
    const dim3 grid((static_cast<unsigned>(nx) + block.x - 1) / block.x,
                    (static_cast<unsigned>(ny) + block.y - 1) / block.y);
    grid_kernel<<<grid, block, 0, stream_>>>(f, nx, ny);
    cuda_check(cudaGetLastError(), "kernel launch");
  }
  // `steps` passes over a grid of at most kMaxStepPoints points in one launch, f(x, y, step):
  // every point's step s sees every point's step s - 1 (one block, a barrier between steps).
  template <class F>
  void launch_steps(int nx, int ny, int steps, const F& f) {
    if (nx <= 0 || ny <= 0 || steps <= 0) return;
    if (nx * ny > kMaxStepPoints) throw Error("cuda: launch_steps over more than one block");
    steps_kernel<<<1, dim3(static_cast<unsigned>(nx), static_cast<unsigned>(ny)), 0, stream_>>>(
        f, steps);
    cuda_check(cudaGetLastError(), "kernel launch");
  }
  void upload(void* device, const void* host, std::size_t bytes) {
    if (bytes > 0)
      cuda_check(cudaMemcpyAsync(device, host, bytes, cudaMemcpyHostToDevice, stream_),
                 "cudaMemcpyAsync to the device");
  }
  void download(void* host, const void* device, std::size_t bytes) {
    if (bytes > 0)
      cuda_check(cudaMemcpyAsync(host, device, bytes, cudaMemcpyDeviceToHost, stream_),
                 "cudaMemcpyAsync from the device");
  }
  void synchronize() { cuda_check(cudaStreamSynchronize(stream_), "cudaStreamSynchronize"); }

 private:
  cudaStream_t stream_ = nullptr;
};

}  // namespace dco::gpu
