#pragma once

#include <cassert>
#include <cstddef>
#include <vector>

namespace dco::pipeline::runtime {

// A first-in first-out ring of at most `capacity` items, allocated once; a push into a full
// queue is refused instead of growing it. Not synchronised: the owner holds its own lock.
template <typename T>
class BoundedQueue {
 public:
  explicit BoundedQueue(std::size_t capacity) : items_(capacity) { assert(capacity > 0); }

  bool push(const T& item) {
    if (size_ == items_.size()) return false;
    items_[(head_ + size_) % items_.size()] = item;
    ++size_;
    high_water_ = size_ > high_water_ ? size_ : high_water_;
    return true;
  }
  T pop() {
    assert(size_ > 0);
    const T item = items_[head_];
    head_ = (head_ + 1) % items_.size();
    --size_;
    return item;
  }
  const T& front() const {
    assert(size_ > 0);
    return items_[head_];
  }
  void clear() { head_ = size_ = 0; }

  bool empty() const { return size_ == 0; }
  bool full() const { return size_ == items_.size(); }
  std::size_t size() const { return size_; }
  std::size_t capacity() const { return items_.size(); }
  // The most items it ever held at once.
  std::size_t high_water() const { return high_water_; }

 private:
  std::vector<T> items_;
  std::size_t head_ = 0, size_ = 0, high_water_ = 0;
};

}  // namespace dco::pipeline::runtime
