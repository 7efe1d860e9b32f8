#pragma once

// Thin C++ layer over dco/client.h: RAII ownership and exceptions for failures a caller cannot
// route around; "no new frame yet" and "overwritten" are ordinary results, not exceptions.

#if __cplusplus < 201703L
#error "dco/client.hpp needs C++17 or later (std::optional); C programs include dco/client.h"
#endif

#include <dco/client.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace dco::client {

class Error : public std::runtime_error {
 public:
  explicit Error(dco_status status)
      : std::runtime_error(std::string(dco_client_strerror(status)) + ": " +
                           dco_client_last_error()),
        status_(status) {}
  dco_status status() const { return status_; }

 private:
  dco_status status_;
};

struct Options {
  std::string path;
  std::optional<std::uint32_t> expected_uid;  // default: the caller's uid
  std::uint32_t expected_width = 0;           // 0 = any
  std::uint32_t expected_height = 0;
  std::uint32_t max_attempts = 0;  // 0 = library default
  std::uint32_t poll_us = 0;       // see dco_client_options::poll_us
};

// A zero-copy frame; check Client::still_valid after reading the pixels.
struct FrameView {
  dco_frame_view raw;
  const dco_frame_info& info() const { return raw.info; }
  const float* depth_row(std::uint32_t y) const {
    return reinterpret_cast<const float*>(reinterpret_cast<const unsigned char*>(raw.depth) +
                                          y * raw.info.depth_stride);
  }
  const std::uint8_t* image_row(std::uint32_t y) const {
    return raw.image ? raw.image + y * raw.info.image_stride : nullptr;
  }
};

class Client {
 public:
  explicit Client(const Options& options) {
    dco_client_options o;
    dco_client_options_init(&o);
    o.path = options.path.c_str();
    if (options.expected_uid) o.expected_uid = *options.expected_uid;
    o.expected_width = options.expected_width;
    o.expected_height = options.expected_height;
    if (options.max_attempts) o.max_attempts = options.max_attempts;
    o.poll_us = options.poll_us;
    check(dco_client_open(&o, &handle_));
  }
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;
  Client(Client&& o) noexcept : handle_(std::exchange(o.handle_, nullptr)) {}
  Client& operator=(Client&& o) noexcept {
    std::swap(handle_, o.handle_);
    return *this;
  }
  ~Client() { dco_client_close(handle_); }

  // The newest frame; empty when none is published yet or it was overwritten on every attempt.
  std::optional<FrameView> latest() {
    FrameView v = blank_view();
    const dco_status s = dco_client_latest(handle_, &v.raw);
    if (s == DCO_E_NO_FRAME || s == DCO_E_OVERTAKEN) return std::nullopt;
    check(s);
    return v;
  }

  bool still_valid(const FrameView& view) const {
    return dco_client_still_valid(handle_, &view.raw) != 0;
  }

  // The next frame, empty on timeout or overtaken; throws when the writer is gone.
  std::optional<FrameView> wait_next(std::chrono::milliseconds timeout) {
    FrameView v = blank_view();
    // The C call takes 32-bit milliseconds: longer waits are cut to about 24 days, not wrapped.
    const auto ms = std::clamp<std::chrono::milliseconds::rep>(
        timeout.count(), 0, std::numeric_limits<std::int32_t>::max());
    const dco_status s = dco_client_wait_next(handle_, static_cast<std::int32_t>(ms), &v.raw);
    if (s == DCO_E_TIMEOUT || s == DCO_E_OVERTAKEN) return std::nullopt;
    check(s);
    return v;
  }

  // Copies a view into dst; false when the slot was overwritten meanwhile (dst may then hold
  // part of a newer frame: keep a frame to draw in another buffer, see dco_client_copy).
  bool copy(const FrameView& view, dco_frame_buffer& dst) const {
    const dco_status s = dco_client_copy(handle_, &view.raw, &dst);
    if (s == DCO_E_OVERTAKEN) return false;
    check(s);
    return true;
  }

  // An untorn copy of the newest frame, or empty when none could be had (dst may then hold a
  // torn one).
  std::optional<dco_frame_info> read_latest(dco_frame_buffer& dst) {
    dco_frame_info info;
    dco_frame_info_init(&info);
    const dco_status s = dco_client_read_latest(handle_, &dst, &info);
    if (s == DCO_E_NO_FRAME || s == DCO_E_OVERTAKEN) return std::nullopt;
    check(s);
    return info;
  }

  // The frame an announcement names, only when the ring really holds it (see
  // dco_client_view_announced); empty when it does not or no longer does.
  std::optional<FrameView> view_announced(std::uint64_t session_id, std::uint32_t slot,
                                          std::uint64_t publish_index) {
    FrameView v = blank_view();
    const dco_status s =
        dco_client_view_announced(handle_, session_id, slot, publish_index, &v.raw);
    if (s == DCO_E_NOT_PUBLISHED || s == DCO_E_OVERTAKEN) return std::nullopt;
    check(s);
    return v;
  }

  // An untorn copy of exactly the announced frame, or empty (dst as for read_latest).
  std::optional<dco_frame_info> read_announced(std::uint64_t session_id, std::uint32_t slot,
                                               std::uint64_t publish_index, dco_frame_buffer& dst) {
    dco_frame_info info;
    dco_frame_info_init(&info);
    const dco_status s =
        dco_client_read_announced(handle_, session_id, slot, publish_index, &dst, &info);
    if (s == DCO_E_NOT_PUBLISHED || s == DCO_E_OVERTAKEN) return std::nullopt;
    check(s);
    return info;
  }

  std::uint64_t session_id() const { return dco_client_session_id(handle_); }
  dco_client* handle() const { return handle_; }

 private:
  static FrameView blank_view() {
    FrameView v;
    dco_frame_view_init(&v.raw);
    return v;
  }
  static void check(dco_status s) {
    if (s != DCO_OK) throw Error(s);
  }

  dco_client* handle_ = nullptr;
};

}  // namespace dco::client
