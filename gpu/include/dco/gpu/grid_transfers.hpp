#pragma once

#include <cstddef>
#include <cstring>

#include "dco/core/image.hpp"

// Moving images between the host and a Grid's tightly packed buffers through its staging memory
// (pinned for CUDA). The host must not refill a staging buffer while a transfer from it may still
// be queued: uploads queued together each need their own. Buffers are sized on a geometry's first
// frame and reused.
namespace dco::gpu {

// The rows of `v` into `staging`, then queued onto `device` (both sized to the view).
template <class Grid, class T, class Staging, class Buffer>
void upload_rows(Grid& grid, ImageView<const T> v, Staging& staging, Buffer& device) {
  const std::size_t row = static_cast<std::size_t>(v.width) * v.channels;
  staging.resize(row * v.height);
  device.resize(row * v.height);
  for (int y = 0; y < v.height; ++y)
    std::memcpy(staging.data() + row * y, v.row(y), row * sizeof(T));
  grid.upload(device.data(), staging.data(), row * v.height * sizeof(T));
}

// Queues n values of `device` into `staging`.
template <class Grid, class T, class Staging>
void download_values(Grid& grid, const T* device, std::size_t n, Staging& staging) {
  staging.resize(n);
  grid.download(staging.data(), device, n * sizeof(T));
}

// After the downloads completed: the tight rows of `staging` into `out`, all its channels.
template <class T, class Staging>
void copy_rows(const Staging& staging, ImageView<T> out) {
  const std::size_t row = static_cast<std::size_t>(out.width) * out.channels;
  for (int y = 0; y < out.height; ++y)
    std::memcpy(out.row(y), staging.data() + row * y, row * sizeof(T));
}

// The same into a one-channel image `width` x `height` (resized when it has another size).
template <class T, class Staging>
void copy_rows(const Staging& staging, int width, int height, Image<T>& out) {
  out.resize(width, height);
  copy_rows(staging, out.view());
}

}  // namespace dco::gpu
