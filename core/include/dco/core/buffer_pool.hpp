#pragma once

#include <cassert>
#include <cstddef>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

#include "dco/core/image.hpp"

namespace dco {

// A fixed set of equally sized images allocated once. `try_acquire` hands one out as a move-only
// lease that returns it on destruction; when all are out it returns nothing instead of allocating,
// so a producer that outruns its consumers drops work rather than growing memory.
// The pool must outlive its leases.
template <typename T>
class BufferPool {
 public:
  class Lease {
   public:
    Lease() = default;
    Lease(Lease&& o) noexcept : pool_(std::exchange(o.pool_, nullptr)), index_(o.index_) {}
    Lease& operator=(Lease&& o) noexcept {
      if (this != &o) {
        release();
        pool_ = std::exchange(o.pool_, nullptr);
        index_ = o.index_;
      }
      return *this;
    }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ~Lease() { release(); }

    explicit operator bool() const { return pool_ != nullptr; }
    Image<T>& image() const {
      assert(pool_);
      return pool_->images_[index_];
    }
    ImageView<T> view() const { return image().view(); }
    std::size_t index() const { return index_; }

    void release() {
      if (pool_ != nullptr) std::exchange(pool_, nullptr)->give_back(index_);
    }

   private:
    friend class BufferPool;
    Lease(BufferPool* pool, std::size_t index) : pool_(pool), index_(index) {}
    BufferPool* pool_ = nullptr;
    std::size_t index_ = 0;
  };

  BufferPool(std::size_t count, int width, int height, int channels = 1) : images_(count) {
    free_.reserve(count);
    for (std::size_t i = 0; i < count; ++i) {
      images_[i].resize(width, height, channels);
      free_.push_back(count - 1 - i);
    }
  }
  BufferPool(const BufferPool&) = delete;
  BufferPool& operator=(const BufferPool&) = delete;
  ~BufferPool() { assert(free_.size() == images_.size() && "a lease outlived its pool"); }

  std::optional<Lease> try_acquire() {
    std::lock_guard lock(mutex_);
    if (free_.empty()) return std::nullopt;
    const std::size_t index = free_.back();
    free_.pop_back();
    return Lease(this, index);
  }

  std::size_t capacity() const { return images_.size(); }
  std::size_t available() const {
    std::lock_guard lock(mutex_);
    return free_.size();
  }

 private:
  void give_back(std::size_t index) {
    std::lock_guard lock(mutex_);
    free_.push_back(index);  // never reallocates: capacity was reserved for every image
  }

  std::vector<Image<T>> images_;
  std::vector<std::size_t> free_;
  mutable std::mutex mutex_;
};

}  // namespace dco
