#include "allocation_counter.hpp"

#include <cstdlib>
#include <new>

namespace dco::testing {
namespace {

std::atomic<bool> g_counting{false};
std::atomic<long> g_new_calls{0};
std::atomic<long> g_aligned_alloc_calls{0};

void* counted_malloc(std::size_t n) {
  if (g_counting.load(std::memory_order_relaxed)) g_new_calls.fetch_add(1);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}

void* counted_aligned(std::size_t n, std::align_val_t al) {
  if (g_counting.load(std::memory_order_relaxed)) g_new_calls.fetch_add(1);
  const auto a = static_cast<std::size_t>(al);
  void* p = nullptr;
  if (posix_memalign(&p, a < sizeof(void*) ? sizeof(void*) : a, n == 0 ? 1 : n) != 0)
    throw std::bad_alloc();
  return p;
}

}  // namespace

std::atomic<const void*> allocation_sink{nullptr};

void start_counting_allocations() {
  g_new_calls = 0;
  g_aligned_alloc_calls = 0;
  g_counting = true;
}

AllocationCounts stop_counting_allocations() {
  g_counting = false;
  return {g_new_calls.load(), g_aligned_alloc_calls.load()};
}

}  // namespace dco::testing

using dco::testing::counted_aligned;
using dco::testing::counted_malloc;

void* operator new(std::size_t n) {
  return counted_malloc(n);
}
void* operator new[](std::size_t n) {
  return counted_malloc(n);
}
void* operator new(std::size_t n, std::align_val_t al) {
  return counted_aligned(n, al);
}
void* operator new[](std::size_t n, std::align_val_t al) {
  return counted_aligned(n, al);
}
// The nothrow forms too: std::stable_sort's temporary buffer uses them and frees with the plain
// operator delete, so every form must come from the same allocator.
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_malloc(n);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_malloc(n);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
  std::free(p);
}

#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
// dco::Image allocates with std::aligned_alloc, which operator new does not see. glibc's
// __libc_memalign does the work, so no symbol lookup is needed.
extern "C" void* __libc_memalign(std::size_t, std::size_t);
extern "C" void* aligned_alloc(std::size_t alignment, std::size_t size) noexcept {
  if (dco::testing::g_counting.load(std::memory_order_relaxed))
    dco::testing::g_aligned_alloc_calls.fetch_add(1);
  return __libc_memalign(alignment, size);
}
#endif
