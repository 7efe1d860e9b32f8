#pragma once

// The LCM channels dcod publishes and a decoder that rejects malformed messages instead of
// trusting them. lcm-gen's own decode sizes each array from a length taken from the message
// before checking it against the bytes received (a forged length makes it allocate gigabytes),
// and derives string lengths with signed arithmetic that overflows; so every length is checked
// against the received bytes first, with a description of each type's encoding below. The
// round-trip tests fail when a description no longer matches its .lcm file.

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>

#include "dco/depth_frame_t.hpp"
#include "dco/depth_preview_t.hpp"
#include "dco/device_status_t.hpp"
#include "dco/log_event_t.hpp"
#include "dco/pipeline_stats_t.hpp"
#include "dco/raw_stereo_t.hpp"

namespace dco::ipc {

namespace channel {
inline constexpr const char* kDepth = "DCO_DEPTH";
inline constexpr const char* kDepthPreview = "DCO_DEPTH_PREVIEW";
inline constexpr const char* kStats = "DCO_STATS";
inline constexpr const char* kStatus = "DCO_STATUS";
inline constexpr const char* kLog = "DCO_LOG";
inline constexpr const char* kRaw = "DCO_RAW";
}  // namespace channel

namespace wire {

// One step of an encoding, after the 8-byte fingerprint. Counts and arrays refer to a count by
// its number (0, 1, ...) in declaration order.
enum class Kind : std::uint8_t {
  kFixed,    // `bytes` bytes of scalars
  kCount,    // int32 element count of later arrays
  kArray,    // count[`count`] elements of `bytes` bytes each
  kString,   // int32 length including the terminating NUL, then the bytes
  kStrings,  // count[`count`] strings
};

struct Step {
  Kind kind;
  std::uint32_t bytes = 0;
  int count = 0;
};

constexpr Step fixed(std::uint32_t bytes) {
  return {Kind::kFixed, bytes, 0};
}
constexpr Step count() {
  return {Kind::kCount, 4, 0};
}
constexpr Step array(std::uint32_t element_bytes, int count_number) {
  return {Kind::kArray, element_bytes, count_number};
}
constexpr Step string() {
  return {Kind::kString, 0, 0};
}
constexpr Step strings(int count_number) {
  return {Kind::kStrings, 0, count_number};
}

template <class T>
struct Encoding;

// clear_arrays: the generated decode() only touches an array whose count is non-zero, so a
// message object decoded again would keep the last message's elements under a count of 0.
// Clearing keeps the capacity (no allocation per message).
template <>
struct Encoding<::dco::depth_frame_t> {
  static constexpr const char* kName = "dco.depth_frame_t";
  static constexpr std::array steps{fixed(8 + 4 + 8 * 4 + 4 * 2)};
  static void clear_arrays(::dco::depth_frame_t&) {}
};
template <>
struct Encoding<::dco::depth_preview_t> {
  static constexpr const char* kName = "dco.depth_preview_t";
  static constexpr std::array steps{fixed(8 * 4 + 4 * 4), count(), array(2, 0)};
  static void clear_arrays(::dco::depth_preview_t& m) { m.depth_mm.clear(); }
};
template <>
struct Encoding<::dco::pipeline_stats_t> {
  static constexpr const char* kName = "dco.pipeline_stats_t";
  static constexpr std::array steps{
      fixed(8 + 8 * 3 + 8 * 3 + 8 * 8 + 4 * 3 + 1 + 8 * 3 + 8 * 3 + 8 + 8 + 8)};
  static void clear_arrays(::dco::pipeline_stats_t&) {}
};
template <>
struct Encoding<::dco::device_status_t> {
  static constexpr const char* kName = "dco.device_status_t";
  static constexpr std::array steps{fixed(8 + 1), string(), string(),   string(),   fixed(4),
                                    string(),     count(),  strings(0), array(8, 0)};
  static void clear_arrays(::dco::device_status_t& m) {
    m.counter_names.clear();
    m.counter_values.clear();
  }
};
template <>
struct Encoding<::dco::log_event_t> {
  static constexpr const char* kName = "dco.log_event_t";
  static constexpr std::array steps{fixed(8 + 1), string(), string()};
  static void clear_arrays(::dco::log_event_t&) {}
};
template <>
struct Encoding<::dco::raw_stereo_t> {
  static constexpr const char* kName = "dco.raw_stereo_t";
  static constexpr std::array steps{
      fixed(8 * 2 + 4 * 2), string(),    count(),  array(1, 0), count(),
      array(1, 1),          string(),    string(), count(),     array(8, 2),
      array(12, 2),         array(12, 2)};
  static void clear_arrays(::dco::raw_stereo_t& m) {
    m.left.clear();
    m.right.clear();
    m.imu_ns.clear();
    m.accel.clear();
    m.gyro.clear();
  }
};

inline std::int64_t read_be(const unsigned char* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = v << 8 | p[i];
  if (bytes == 4) return static_cast<std::int32_t>(static_cast<std::uint32_t>(v));
  return static_cast<std::int64_t>(v);
}

// Empty when `size` bytes after the fingerprint follow `steps` exactly, else what is wrong.
inline std::string check(std::span<const Step> steps, const unsigned char* p, std::size_t size) {
  std::array<std::int64_t, 4> counts{};
  int declared = 0;
  std::size_t pos = 0;
  const auto need = [&](std::uint64_t n) { return n <= size - pos; };
  const auto one_string = [&]() -> std::string {
    if (!need(4)) return "truncated";
    const std::int64_t n = read_be(p + pos, 4);
    pos += 4;
    if (n < 1 || !need(static_cast<std::uint64_t>(n)))
      return "string length " + std::to_string(n) + " out of range";
    // A NUL inside would be cut off on re-encoding: one string, one encoding.
    const auto* nul = std::memchr(p + pos, 0, static_cast<std::size_t>(n));
    if (nul == nullptr) return "string not terminated";
    if (nul != p + pos + n - 1) return "NUL inside a string";
    pos += static_cast<std::size_t>(n);
    return {};
  };
  for (const Step& s : steps) {
    switch (s.kind) {
      case Kind::kFixed:
        if (!need(s.bytes)) return "truncated";
        pos += s.bytes;
        break;
      case Kind::kCount: {
        if (declared >= static_cast<int>(counts.size())) return "encoding has too many counts";
        if (!need(4)) return "truncated";
        const std::int64_t n = read_be(p + pos, 4);
        if (n < 0) return "negative element count " + std::to_string(n);
        counts[declared++] = n;
        pos += 4;
        break;
      }
      case Kind::kArray: {
        const std::uint64_t n = static_cast<std::uint64_t>(counts[s.count]) * s.bytes;
        if (!need(n))
          return "array of " + std::to_string(counts[s.count]) + " elements exceeds the message";
        pos += n;
        break;
      }
      case Kind::kString:
        if (std::string e = one_string(); !e.empty()) return e;
        break;
      case Kind::kStrings:
        for (std::int64_t i = 0; i < counts[s.count]; ++i)
          if (std::string e = one_string(); !e.empty()) return e;
        break;
    }
  }
  if (pos != size) return std::to_string(size - pos) + " bytes after the message";
  return {};
}

}  // namespace wire

// Decodes one message of type T (one of the dco LCM types). On failure returns false and says why
// in `error`, leaving `out` unspecified; never throws for malformed input.
template <class T>
bool decode_message(const void* data, std::size_t size, T& out, std::string& error) {
  using E = wire::Encoding<T>;
  const auto* p = static_cast<const unsigned char*>(data);
  const std::string name = E::kName;
  if (data == nullptr || size < 8) {
    error = name + ": truncated (" + std::to_string(size) + " bytes)";
    return false;
  }
  if (size > static_cast<std::size_t>(INT32_MAX)) {
    error = name + ": message too large";
    return false;
  }
  if (wire::read_be(p, 8) != T::getHash()) {
    error = name + ": fingerprint does not match (another type or version)";
    return false;
  }
  if (std::string why = wire::check(E::steps, p + 8, size - 8); !why.empty()) {
    error = name + ": " + why;
    return false;
  }
  E::clear_arrays(out);
  if (out.decode(data, 0, static_cast<int>(size)) != static_cast<int>(size)) {
    error = name + ": does not decode";
    return false;
  }
  return true;
}

// Whether a decoded preview holds what it says: a width x height grid (sides 1..16384) of
// num_pixels values. A log can hold anything; only such a preview is drawn or compared.
inline bool consistent_preview(const ::dco::depth_preview_t& p) {
  constexpr std::int32_t kMaxSide = 16384;
  return p.width >= 1 && p.height >= 1 && p.width <= kMaxSide && p.height <= kMaxSide &&
         std::int64_t{p.width} * p.height == p.num_pixels &&
         static_cast<std::size_t>(p.num_pixels) == p.depth_mm.size();
}

}  // namespace dco::ipc
