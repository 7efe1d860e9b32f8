#pragma once

#include <cassert>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <type_traits>
#include <utility>

namespace dco {

// The largest image side dco takes anywhere (the depth ring's limit; remap maps stop at 32767).
inline constexpr int kMaxImageSide = 16384;

// A non-owning, strided view of an interleaved image. `stride` counts elements of T between the
// starts of consecutive rows, so a view of a sub-rectangle or of a padded buffer is still a view.
template <typename T>
struct ImageView {
  T* data = nullptr;
  int width = 0;
  int height = 0;
  int channels = 1;
  std::ptrdiff_t stride = 0;

  ImageView() = default;
  ImageView(T* d, int w, int h, int c, std::ptrdiff_t s)
      : data(d), width(w), height(h), channels(c), stride(s) {}

  // A mutable view converts to a read-only one.
  template <typename U,
            typename = std::enable_if_t<std::is_same_v<const U, T> && !std::is_same_v<U, T>>>
  ImageView(const ImageView<U>& o)  // NOLINT(google-explicit-constructor)
      : data(o.data), width(o.width), height(o.height), channels(o.channels), stride(o.stride) {}

  bool empty() const { return data == nullptr || width <= 0 || height <= 0; }
  T* row(int y) const {
    assert(y >= 0 && y < height);
    return data + y * stride;
  }
  T& at(int x, int y, int c = 0) const {
    assert(x >= 0 && x < width && c >= 0 && c < channels);
    return row(y)[x * channels + c];
  }
  ImageView sub(int x, int y, int w, int h) const {
    assert(x >= 0 && y >= 0 && x + w <= width && y + h <= height);
    return ImageView(data + y * stride + x * channels, w, h, channels, stride);
  }
  bool same_size(int w, int h) const { return width == w && height == h; }
  template <typename U>
  bool same_size(const ImageView<U>& o) const {
    return width == o.width && height == o.height;
  }
};

// Owning image with 64-byte aligned rows (SIMD loads and cache lines never straddle a row start).
// `resize` reuses the existing allocation whenever it is large enough, so buffers sized once at
// start-up never allocate again in the per-frame path.
template <typename T>
class Image {
  static_assert(std::is_trivially_copyable_v<T>, "Image holds plain pixels only");

 public:
  static constexpr std::size_t kAlignment = 64;

  Image() = default;
  Image(int width, int height, int channels = 1) { resize(width, height, channels); }
  Image(const Image& o) { *this = o; }
  Image(Image&& o) noexcept { swap(o); }
  Image& operator=(const Image& o) {
    if (this != &o) {
      resize(o.width_, o.height_, o.channels_);
      copy_from(o.view());
    }
    return *this;
  }
  Image& operator=(Image&& o) noexcept {
    Image tmp(std::move(o));
    swap(tmp);
    return *this;
  }
  ~Image() { std::free(storage_); }

  void swap(Image& o) noexcept {
    std::swap(storage_, o.storage_);
    std::swap(capacity_, o.capacity_);
    std::swap(width_, o.width_);
    std::swap(height_, o.height_);
    std::swap(channels_, o.channels_);
    std::swap(stride_, o.stride_);
  }

  // Returns true when it had to allocate.
  bool resize(int width, int height, int channels = 1) {
    assert(width >= 0 && height >= 0 && channels >= 1);
    const std::size_t row_bytes = static_cast<std::size_t>(width) * channels * sizeof(T);
    std::size_t padded = (row_bytes + kAlignment - 1) / kAlignment * kAlignment;
    if (padded % sizeof(T) != 0) padded = row_bytes;  // odd-sized T: keep rows dense
    const std::size_t bytes = padded * static_cast<std::size_t>(height);
    bool allocated = false;
    if (bytes > capacity_) {
      // The new block first: when it cannot be had, the image stays as it was.
      void* grown =
          std::aligned_alloc(kAlignment, (bytes + kAlignment - 1) / kAlignment * kAlignment);
      if (grown == nullptr) throw std::bad_alloc();
      std::free(storage_);
      storage_ = grown;
      capacity_ = bytes;
      allocated = true;
    }
    width_ = width;
    height_ = height;
    channels_ = channels;
    stride_ = static_cast<std::ptrdiff_t>(padded / sizeof(T));
    return allocated;
  }

  void fill(T value) {
    for (int y = 0; y < height_; ++y) {
      T* r = row(y);
      for (int i = 0; i < width_ * channels_; ++i) r[i] = value;
    }
  }

  void copy_from(ImageView<const T> src) {
    assert(src.width == width_ && src.height == height_ && src.channels == channels_);
    for (int y = 0; y < height_; ++y)
      std::memcpy(row(y), src.row(y), static_cast<std::size_t>(width_) * channels_ * sizeof(T));
  }

  ImageView<T> view() { return {data(), width_, height_, channels_, stride_}; }
  ImageView<const T> view() const { return {data(), width_, height_, channels_, stride_}; }
  ImageView<const T> cview() const { return view(); }

  T* data() { return static_cast<T*>(storage_); }
  const T* data() const { return static_cast<const T*>(storage_); }
  T* row(int y) { return data() + y * stride_; }
  const T* row(int y) const { return data() + y * stride_; }
  T& at(int x, int y, int c = 0) { return row(y)[x * channels_ + c]; }
  const T& at(int x, int y, int c = 0) const { return row(y)[x * channels_ + c]; }

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  std::ptrdiff_t stride() const { return stride_; }
  bool empty() const { return width_ == 0 || height_ == 0; }

 private:
  void* storage_ = nullptr;
  std::size_t capacity_ = 0;
  int width_ = 0;
  int height_ = 0;
  int channels_ = 1;
  std::ptrdiff_t stride_ = 0;
};

}  // namespace dco
