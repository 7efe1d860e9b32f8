#pragma once

// How the SIMD row kernels walk their rows: plain templates with no Highway types, so the code of
// every target uses the same ones. Always inlined: compiled for the baseline target, they could
// not inline the target code they are given, and would call it once per vector.

#include <type_traits>

#include <hwy/base.h>

namespace dco::kernels::detail {

// Calls vector(i) for vectors of n pixels from `begin` on, the last one ending at `end` and
// overlapping the one before it when the range is not a whole number of vectors. For kernels
// whose outputs are not among their inputs, so that a pixel done twice gets the same bits.
// Returns the first pixel left to the caller: `end`, or `begin` for a range narrower than a
// vector.
template <class Vector>
HWY_INLINE int cover_with_vectors(int begin, int end, int n, Vector&& vector) {
  if (end - begin < n) return begin;
  int i = begin;
  for (; i + n <= end; i += n) vector(i);
  if (i < end) vector(end - n);
  return end;
}

// f(std::bool_constant<below>{}, std::bool_constant<above>{}): whether a kernel reads the rows
// below and above a row, as compile-time constants, so its loop tests neither.
template <class F>
HWY_INLINE void with_rows_next_to(bool below, bool above, F&& f) {
  if (below && above)
    f(std::true_type{}, std::true_type{});
  else if (below)
    f(std::true_type{}, std::false_type{});
  else if (above)
    f(std::false_type{}, std::true_type{});
  else
    f(std::false_type{}, std::false_type{});
}

}  // namespace dco::kernels::detail
