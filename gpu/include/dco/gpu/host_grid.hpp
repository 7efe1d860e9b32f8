#pragma once

#include <cstddef>
#include <cstring>
#include <vector>

// A Grid that runs the passes on the calling thread, one grid point after the other: what the
// CUDA grid computes, checkable on any machine (tests compare it with the CPU stage).
namespace dco::gpu {

class HostGrid {
 public:
  template <class T>
  class Buffer {
   public:
    void resize(std::size_t n) {
      if (n != data_.size()) data_.resize(n);
    }
    T* data() { return data_.data(); }
    const T* data() const { return data_.data(); }
    std::size_t size() const { return data_.size(); }

   private:
    std::vector<T> data_;
  };
  // Host memory the transfers go through (pinned for CUDA).
  template <class T>
  using Staging = Buffer<T>;

  static const char* name() { return "host grid"; }

  // CudaGrid's one-block limit, kept so both take the same path.
  static constexpr int kMaxStepPoints = 1024;

  template <class F>
  void launch(int nx, int ny, const F& f) {
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x) f(x, y);
  }
  // `steps` passes over the grid, f(x, y, step), each after the whole previous one.
  template <class F>
  void launch_steps(int nx, int ny, int steps, const F& f) {
    for (int s = 0; s < steps; ++s) launch(nx, ny, [&](int x, int y) { f(x, y, s); });
  }
  void upload(void* device, const void* host, std::size_t bytes) {
    if (bytes > 0) std::memcpy(device, host, bytes);
  }
  void download(void* host, const void* device, std::size_t bytes) {
    if (bytes > 0) std::memcpy(host, device, bytes);
  }
  void synchronize() {}
};

}  // namespace dco::gpu
