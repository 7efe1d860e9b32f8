// libdco-client: the reader side of the depth ring (layout in dco/ipc/ring_layout.hpp).

#include "dco/client.h"

#include <fcntl.h>
#include <pthread.h>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <sched.h>

#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <memory>
#include <string>

#include "dco/core/time_slice.hpp"
#include "dco/ipc/ring_layout.hpp"
#include "dco/ipc/ring_wake.hpp"

namespace {

namespace layout = dco::ipc::layout;

constexpr std::uint32_t kDefaultAttempts = 8;
// How often a waiting client looks for a replaced segment or a dead writer.
constexpr std::int64_t kPathCheckNs = 20'000'000;
constexpr std::uint32_t kMaxPollUs = 100'000;
// Options structs of callers built before poll_us end here; they get the default.
constexpr std::uint32_t kOptionsSizeV1 = offsetof(dco_client_options, poll_us);

// A plain array, not a std::string: a thread-local with a destructor registers it with the C++
// runtime (__cxa_thread_atexit), which keeps the library loaded until the thread exits, so an app
// that dlclose()s it after a failed call would keep it mapped. Messages longer than the array
// (a path near PATH_MAX) are cut.
thread_local char t_last_error[1024];

void set_last_error(const char* message) noexcept {
  std::snprintf(t_last_error, sizeof t_last_error, "%s", message);
}

dco_status fail(dco_status status, const std::string& message) {
  set_last_error(message.c_str());
  return status;
}

// What a C function returns when an exception reaches it (out of memory building a message or a
// client): it must not unwind into a C caller, which has no unwind tables.
dco_status out_of_memory() noexcept {
  set_last_error("out of memory");
  return DCO_E_IO;
}

std::string errno_text(int err) {
  return std::strerror(err);
}

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

struct Mapping {
  int fd = -1;
  const unsigned char* base = nullptr;
  std::size_t size = 0;
  dev_t dev = 0;
  ino_t ino = 0;
  layout::Geometry geometry;
  layout::Sizes sizes{};
  std::uint64_t session_id = 0;

  const layout::RingHeader* header() const {
    return reinterpret_cast<const layout::RingHeader*>(base);
  }
  const unsigned char* slot(std::uint32_t i) const {
    return base + sizes.slots_offset + sizes.slot_stride * i;
  }
  const layout::SlotHeader* slot_header(std::uint32_t i) const {
    return reinterpret_cast<const layout::SlotHeader*>(slot(i));
  }

  void release() {
    if (base != nullptr) munmap(const_cast<unsigned char*>(base), size);
    if (fd >= 0) close(fd);
    *this = Mapping{};
  }
};

struct Expectations {
  std::string path;
  std::uint32_t uid = 0;
  std::uint32_t width = 0;
  std::uint32_t height = 0;
};

// Checks the header and hands back the geometry and sizes it validated. Each field is read from
// the mapping once: the file is shared, and what is used must be what was checked.
dco_status check_header(const Mapping& m, const Expectations& e, std::uint64_t file_size,
                        layout::Geometry& geometry, layout::Sizes& sizes) {
  const layout::RingHeader& h = *m.header();
  const std::string& p = e.path;
  if (h.magic != layout::kMagic) return fail(DCO_E_BAD_FORMAT, p + ": not a dco depth ring");
  if (h.version != layout::kVersion)
    return fail(DCO_E_BAD_FORMAT, p + ": ring version " + std::to_string(h.version) +
                                      ", this client reads version " +
                                      std::to_string(layout::kVersion));
  if (h.header_size != sizeof(layout::RingHeader) ||
      h.depth_format != layout::kDepthFormatFloat32Metres)
    return fail(DCO_E_BAD_FORMAT, p + ": unknown header size or depth format");
  // A writer never draws 0, which names a view that holds no frame.
  if (h.session_id == 0) return fail(DCO_E_BAD_FORMAT, p + ": session id 0");
  const bool has_image = h.image_format == layout::kImageFormatU8;
  if ((h.image_format != layout::kImageFormatNone && !has_image) ||
      has_image != (h.image_channels != 0))
    return fail(DCO_E_BAD_FORMAT, p + ": inconsistent image format");
  const layout::Geometry g{h.width, h.height, h.image_channels, h.slot_count};
  const auto s = layout::compute_sizes(g);
  if (!s) return fail(DCO_E_BAD_FORMAT, p + ": geometry or slot count out of range");
  if (h.depth_stride != s->depth_stride || h.image_stride != s->image_stride ||
      h.slot_header_size != sizeof(layout::SlotHeader) || h.depth_offset != s->depth_offset ||
      h.image_offset != s->image_offset || h.slot_stride != s->slot_stride ||
      h.slots_offset != s->slots_offset || h.file_size != s->file_size)
    return fail(DCO_E_BAD_FORMAT, p + ": sizes in the header do not match its geometry");
  if (file_size < s->file_size)
    return fail(DCO_E_BAD_FORMAT, p + ": truncated (" + std::to_string(file_size) + " of " +
                                      std::to_string(s->file_size) + " bytes)");
  if ((e.width != 0 && e.width != g.width) || (e.height != 0 && e.height != g.height)) {
    const auto expected = [](std::uint32_t v) { return v != 0 ? std::to_string(v) : "any"; };
    return fail(DCO_E_GEOMETRY, p + ": ring is " + std::to_string(g.width) + "x" +
                                    std::to_string(g.height) + ", expected " + expected(e.width) +
                                    "x" + expected(e.height));
  }
  geometry = g;
  sizes = *s;
  return DCO_OK;
}

dco_status map_segment(const Expectations& e, Mapping& out) {
  Mapping m;
  // O_NONBLOCK: a FIFO or device left at the path must not block the open; it is refused below.
  m.fd = open(e.path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
  if (m.fd < 0) {
    const int err = errno;
    if (err == ENOENT) return fail(DCO_E_NO_SEGMENT, e.path + ": no depth ring (is dcod running?)");
    if (err == ELOOP) return fail(DCO_E_PERMISSION, e.path + ": is a symbolic link");
    // The likeliest setup fault: the ring is mode 0640, readable by its group only.
    if (err == EACCES || err == EPERM)
      return fail(DCO_E_PERMISSION, e.path + ": " + errno_text(err) +
                                        " (readers of dcod's ring need its group, dcod)");
    return fail(DCO_E_IO, e.path + ": " + errno_text(err));
  }
  struct stat st {};
  if (fstat(m.fd, &st) != 0) {
    const int err = errno;
    m.release();
    return fail(DCO_E_IO, e.path + ": " + errno_text(err));
  }
  dco_status status = DCO_OK;
  if (!S_ISREG(st.st_mode)) {
    status = fail(DCO_E_PERMISSION, e.path + ": not a regular file");
  } else if (st.st_uid != e.uid) {
    status = fail(DCO_E_PERMISSION, e.path + ": owned by uid " + std::to_string(st.st_uid) +
                                        ", expected uid " + std::to_string(e.uid));
  } else if ((st.st_mode & S_IWOTH) != 0) {
    status = fail(DCO_E_PERMISSION, e.path + ": world-writable, refusing to trust it");
  } else if (static_cast<std::uint64_t>(st.st_size) < sizeof(layout::RingHeader)) {
    status = fail(DCO_E_BAD_FORMAT, e.path + ": truncated (" + std::to_string(st.st_size) +
                                        " bytes, smaller than the ring header)");
  }
  if (status != DCO_OK) {
    m.release();
    return status;
  }
  m.size = static_cast<std::size_t>(st.st_size);
  void* p = mmap(nullptr, m.size, PROT_READ, MAP_SHARED, m.fd, 0);
  if (p == MAP_FAILED) {
    const int err = errno;
    m.size = 0;
    m.release();
    return fail(DCO_E_IO, e.path + ": mmap: " + errno_text(err));
  }
  m.base = static_cast<const unsigned char*>(p);
  m.dev = st.st_dev;
  m.ino = st.st_ino;
  status = check_header(m, e, m.size, m.geometry, m.sizes);
  if (status != DCO_OK) {
    m.release();
    return status;
  }
  m.session_id = m.header()->session_id;
  out = m;
  return DCO_OK;
}

bool struct_ok(const void* p, std::uint32_t size, std::uint32_t expected) {
  return p != nullptr && size >= expected;
}

// Whether `rows` rows of `row_bytes` at `stride` fit in `capacity` bytes. Divides instead of
// multiplying: a caller's huge stride must not wrap the product round to a small size.
bool rows_fit(std::size_t capacity, std::size_t stride, std::size_t rows, std::size_t row_bytes) {
  if (stride < row_bytes || capacity < row_bytes) return false;
  return rows <= 1 || stride <= (capacity - row_bytes) / (rows - 1);
}

// Asks, once per thread, for a 0.1 ms time slice, which the thread keeps: a polling reader then
// gets its turn sooner among the others that poll and yield on its CPU (8 clients on 2 vCPUs at
// 30 Hz: p99 about 107 -> 86 us). Restoring the slice on return would reschedule the thread
// between the publish and the return.
void request_polling_slice() {
  thread_local bool requested = false;
  if (requested) return;
  requested = true;
  dco::request_time_slice(100'000);
}

// Polls `word` until it changes or the clock reaches `until_ns`, giving the CPU to anything else
// runnable between looks (other readers on a busy machine, the writer itself).
void poll_for_change(const std::atomic<std::uint32_t>& word, std::uint32_t seen,
                     std::int64_t until_ns) {
  while (word.load(std::memory_order_acquire) == seen && now_ns() < until_ns) sched_yield();
}

// Held through every call that can reach a cancellation point (open, stat, futex waits, munmap):
// a thread cancelled there would unwind through the catch-all handlers that keep C++ exceptions
// from reaching a C caller, or out of the noexcept destructor dco_client_close runs, and the
// process would abort. A cancel that arrives meanwhile takes effect at the caller's next
// cancellation point after the call returns (wait_next within its timeout).
class NoCancel {
 public:
  NoCancel() { pthread_setcancelstate(PTHREAD_CANCEL_DISABLE, &old_); }
  NoCancel(const NoCancel&) = delete;
  NoCancel& operator=(const NoCancel&) = delete;
  ~NoCancel() { pthread_setcancelstate(old_, nullptr); }

 private:
  int old_ = PTHREAD_CANCEL_ENABLE;
};

}  // namespace

struct dco_client {
  Expectations expect;
  std::uint32_t max_attempts = kDefaultAttempts;
  Mapping map;
  // The ring a restarted daemon left behind, still mapped while the caller may hold views into
  // it: until the next call that returns a frame (dco_frame_view promises that much).
  Mapping retired;
  std::uint64_t last_index = 0;  // publish_index of the last frame returned
  std::int64_t last_path_check_ns = 0;
  std::int64_t poll_ns = 0;
  std::uint32_t polled_write = 0;  // writes_begun value of the write polled through last
  std::int64_t poll_end_ns = 0;    // when polling through that write stops
  // wait_next said DCO_E_WRITER_GONE for this ring: later calls wait out their timeout (a
  // restarted daemon still found within it) rather than return at once, which would spin a
  // caller that simply calls again.
  bool gone_reported = false;
  // A ring at the path that this client refuses (another size, format or owner: a daemon
  // restarted otherwise), while it stays there; DCO_OK when none. wait_next says it at once the
  // first time and then at the end of each wait, as the writer's going.
  dco_status refused = DCO_OK;
  std::string refused_message;
  bool refusal_reported = false;

  ~dco_client() {
    map.release();
    retired.release();
  }

  // Every call that returns a frame passes its status through here: views of an older ring are
  // no longer the caller's after it.
  dco_status returned(dco_status status) {
    if (status == DCO_OK) retired.release();
    return status;
  }
  // The calls that copy a frame pass their copy's status through here with what had been
  // returned before they took it: a frame taken but not copied (the caller's buffer too small,
  // the slot overtaken) was not returned, so wait_next may still return it, unless the ring has
  // since changed session.
  struct Returned {
    std::uint64_t session_id, last_index;
  };
  Returned last_returned() const { return {map.session_id, last_index}; }
  dco_status copied(dco_status status, const Returned& before) {
    if (status != DCO_OK && map.session_id == before.session_id) last_index = before.last_index;
    return returned(status);
  }

  // Reads slot `slot`'s metadata under its seqlock into a view (pixels are left in place).
  // False when the slot was being written or changed during the read.
  bool read_slot(std::uint32_t slot, dco_frame_view* view) const {
    const layout::SlotHeader& s = *map.slot_header(slot);
    const std::uint64_t before = s.seqlock.load(std::memory_order_acquire);
    if (before % 2 != 0) return false;
    dco_frame_info info;
    dco_frame_info_init(&info);
    info.slot = slot;
    info.session_id = map.session_id;
    info.publish_index = s.publish_index;
    info.frame_seq = s.frame_seq;
    info.capture_ns = s.capture_ns;
    info.publish_ns = s.publish_ns;
    info.fx = s.fx;
    info.fy = s.fy;
    info.cx = s.cx;
    info.cy = s.cy;
    info.baseline_m = s.baseline_m;
    layout::fence_acquire();
    if (s.seqlock.load(std::memory_order_relaxed) != before) return false;
    info.width = map.geometry.width;
    info.height = map.geometry.height;
    info.image_channels = map.geometry.image_channels;
    info.depth_stride = map.sizes.depth_stride;
    info.image_stride = map.sizes.image_stride;
    const unsigned char* base = map.slot(slot);
    view->info = info;
    view->depth = reinterpret_cast<const float*>(base + map.sizes.depth_offset);
    view->image = map.geometry.image_channels ? base + map.sizes.image_offset : nullptr;
    view->token = before;
    return true;
  }

  // Takes the newest slot's metadata under the seqlock; pixels are left in place.
  dco_status take_latest(dco_frame_view* view) {
    const layout::RingHeader& h = *map.header();
    for (std::uint32_t attempt = 0; attempt < max_attempts; ++attempt) {
      if (h.publish_count.load(std::memory_order_acquire) == 0)
        return fail(DCO_E_NO_FRAME, expect.path + ": no frame published yet");
      const std::uint32_t slot = h.newest_slot.load(std::memory_order_acquire);
      if (slot >= map.geometry.slot_count)
        return fail(DCO_E_BAD_FORMAT, expect.path + ": newest slot index out of range");
      if (!read_slot(slot, view)) continue;
      if (view->info.publish_index > last_index) last_index = view->info.publish_index;
      return DCO_OK;
    }
    return fail(DCO_E_OVERTAKEN, expect.path + ": slot overwritten during " +
                                     std::to_string(max_attempts) + " attempts");
  }

  // take_latest, after following a restarted daemon when a path check is due. A refused ring
  // at the path is said until the check finds it gone or replaced, not only when it runs.
  dco_status checked_latest(dco_frame_view* view) {
    if (now_ns() - last_path_check_ns >= kPathCheckNs) {
      bool remapped = false;
      const dco_status status = follow_path(&remapped);
      if (status != DCO_OK) return status;
    }
    if (refused != DCO_OK) return repeat_refusal();
    return take_latest(view);
  }

  dco_status repeat_refusal() { return fail(refused, refused_message); }

  // The frame an announcement names, only if the slot holds it (see dco_client_view_announced).
  dco_status take_announced(std::uint64_t session_id, std::uint32_t slot,
                            std::uint64_t publish_index, dco_frame_view* view) {
    if (session_id != map.session_id) {
      bool remapped = false;
      const dco_status status = follow_path(&remapped);
      if (status != DCO_OK) return status;
      if (session_id != map.session_id)
        return fail(DCO_E_NOT_PUBLISHED, expect.path + ": session " + std::to_string(session_id) +
                                             " is not the ring's session " +
                                             std::to_string(map.session_id));
    }
    if (slot >= map.geometry.slot_count)
      return fail(DCO_E_NOT_PUBLISHED, expect.path + ": slot " + std::to_string(slot) +
                                           " out of range (" +
                                           std::to_string(map.geometry.slot_count) + " slots)");
    const std::uint64_t published = map.header()->publish_count.load(std::memory_order_acquire);
    if (publish_index == 0 || publish_index > published)
      return fail(DCO_E_NOT_PUBLISHED, expect.path + ": publish index " +
                                           std::to_string(publish_index) + " not published (" +
                                           std::to_string(published) + " so far)");
    for (std::uint32_t attempt = 0; attempt < max_attempts; ++attempt) {
      dco_frame_view taken = *view;
      if (!read_slot(slot, &taken)) continue;
      const std::uint64_t held = taken.info.publish_index;
      // The writer fills slots with rising indices: a larger one overwrote the announced frame,
      // a smaller one means the announced index never went into this slot.
      if (held > publish_index)
        return fail(DCO_E_OVERTAKEN, expect.path + ": slot " + std::to_string(slot) +
                                         " was rewritten after publish index " +
                                         std::to_string(publish_index));
      if (held < publish_index)
        return fail(DCO_E_NOT_PUBLISHED, expect.path + ": publish index " +
                                             std::to_string(publish_index) +
                                             " was never written to slot " + std::to_string(slot));
      *view = taken;
      if (held > last_index) last_index = held;  // wait_next then waits for a newer one
      return DCO_OK;
    }
    return fail(DCO_E_OVERTAKEN, expect.path + ": slot " + std::to_string(slot) +
                                     " being written during " + std::to_string(max_attempts) +
                                     " attempts");
  }

  // Whether the view's pixels are in this handle's current mapping: a view another handle of the
  // same ring returned names the same slot and token, but its pixels go with that handle.
  bool owns(const dco_frame_view* view) const {
    if (view->info.slot >= map.geometry.slot_count) return false;
    const unsigned char* base = map.slot(view->info.slot);
    return reinterpret_cast<const unsigned char*>(view->depth) == base + map.sizes.depth_offset &&
           view->image == (map.geometry.image_channels ? base + map.sizes.image_offset : nullptr);
  }

  bool valid(const dco_frame_view* view) const {
    if (view->info.session_id != map.session_id || view->info.slot >= map.geometry.slot_count)
      return false;
    layout::fence_acquire();
    return map.slot_header(view->info.slot)->seqlock.load(std::memory_order_relaxed) == view->token;
  }

  // Follows a daemon restart: a different file at the path is a new ring. Returns true when it
  // remapped. A ring it refuses stays `refused` until a check finds the path without it.
  dco_status follow_path(bool* remapped) {
    const dco_status status = look_at_path(remapped);
    if (status == DCO_OK) {
      refused = DCO_OK;
      refusal_reported = false;
    } else {
      refused = status;
      refused_message = t_last_error;
    }
    return status;
  }

  dco_status look_at_path(bool* remapped) {
    *remapped = false;
    last_path_check_ns = now_ns();
    struct stat st {};
    if (stat(expect.path.c_str(), &st) != 0) return DCO_OK;  // gone: keep the old ring
    if (st.st_dev == map.dev && st.st_ino == map.ino) return DCO_OK;
    Mapping fresh;
    const dco_status status = map_segment(expect, fresh);
    // Gone again between the stat and the open (a daemon that stopped as it started): as when
    // the stat finds nothing, the old ring stays.
    if (status == DCO_E_NO_SEGMENT) return DCO_OK;
    if (status != DCO_OK) return status;
    // The caller's views point into `retired` when it is set (no frame was returned since), so
    // the current ring has none and can go.
    if (retired.base == nullptr)
      retired = map;
    else
      map.release();
    map = fresh;
    last_index = 0;
    polled_write = 0;
    gone_reported = false;
    skip_dead_writers_frames();
    *remapped = true;
    return DCO_OK;
  }

  // A ring found with its writer already gone (a daemon killed, its file left behind) holds no
  // new frame: wait_next reports the writer gone instead of handing on its last, stale one.
  // latest() still returns it, as the newest there is.
  void skip_dead_writers_frames() {
    if (writer_gone()) last_index = map.header()->publish_count.load(std::memory_order_acquire);
  }

  bool writer_gone() const {
    if (map.header()->state.load(std::memory_order_acquire) == layout::kStateClosed) return true;
    // The writer holds an exclusive lock for its lifetime; the kernel drops it when it dies.
    if (flock(map.fd, LOCK_SH | LOCK_NB) != 0) return false;
    flock(map.fd, LOCK_UN);
    return true;
  }
};

extern "C" {

void dco_client_options_init(dco_client_options* options) {
  if (options == nullptr) return;
  *options = dco_client_options{};
  options->struct_size = sizeof(dco_client_options);
  options->expected_uid = static_cast<std::uint32_t>(getuid());
  options->max_attempts = kDefaultAttempts;
}

void dco_frame_view_init(dco_frame_view* view) {
  if (view == nullptr) return;
  *view = dco_frame_view{};
  view->struct_size = sizeof(dco_frame_view);
  dco_frame_info_init(&view->info);
}

void dco_frame_buffer_init(dco_frame_buffer* buffer) {
  if (buffer == nullptr) return;
  *buffer = dco_frame_buffer{};
  buffer->struct_size = sizeof(dco_frame_buffer);
}

void dco_frame_info_init(dco_frame_info* info) {
  if (info == nullptr) return;
  *info = dco_frame_info{};
  info->struct_size = sizeof(dco_frame_info);
}

dco_status dco_client_open(const dco_client_options* options, dco_client** out) try {
  const NoCancel no_cancel;
  if (out == nullptr) return fail(DCO_E_INVALID_ARGUMENT, "dco_client_open: out is NULL");
  *out = nullptr;
  if (!struct_ok(options, options ? options->struct_size : 0, kOptionsSizeV1))
    return fail(DCO_E_INVALID_ARGUMENT,
                "dco_client_open: options missing or not set up by dco_client_options_init");
  if (options->path == nullptr || options->path[0] == '\0')
    return fail(DCO_E_INVALID_ARGUMENT, "dco_client_open: no segment path");
  const std::uint32_t poll_us =
      options->struct_size >= sizeof(dco_client_options) ? options->poll_us : 0;
  if (poll_us > kMaxPollUs)
    return fail(DCO_E_INVALID_ARGUMENT, "dco_client_open: poll_us " + std::to_string(poll_us) +
                                            " above " + std::to_string(kMaxPollUs));
  auto client = std::make_unique<dco_client>();
  client->expect = {options->path, options->expected_uid, options->expected_width,
                    options->expected_height};
  client->max_attempts = options->max_attempts ? options->max_attempts : kDefaultAttempts;
  client->poll_ns = std::int64_t{poll_us} * 1000;
  const dco_status status = map_segment(client->expect, client->map);
  if (status != DCO_OK) return status;
  client->skip_dead_writers_frames();
  client->last_path_check_ns = now_ns();
  *out = client.release();
  return DCO_OK;
} catch (...) {
  return out_of_memory();
}

void dco_client_close(dco_client* client) {
  const NoCancel no_cancel;
  delete client;
}

dco_status dco_client_latest(dco_client* client, dco_frame_view* view) try {
  const NoCancel no_cancel;
  if (client == nullptr || !struct_ok(view, view ? view->struct_size : 0, sizeof(dco_frame_view)))
    return fail(DCO_E_INVALID_ARGUMENT, "dco_client_latest: bad client or view");
  return client->returned(client->checked_latest(view));
} catch (...) {
  return out_of_memory();
}

int dco_client_still_valid(const dco_client* client, const dco_frame_view* view) {
  if (client == nullptr || !struct_ok(view, view ? view->struct_size : 0, sizeof(dco_frame_view)))
    return 0;
  return client->owns(view) && client->valid(view) ? 1 : 0;
}

dco_status dco_client_wait_next(dco_client* client, int32_t timeout_ms, dco_frame_view* view) try {
  const NoCancel no_cancel;
  if (client == nullptr || !struct_ok(view, view ? view->struct_size : 0, sizeof(dco_frame_view)) ||
      timeout_ms < 0)
    return fail(DCO_E_INVALID_ARGUMENT, "dco_client_wait_next: bad client, view or timeout");
  const std::int64_t deadline = now_ns() + std::int64_t{timeout_ms} * 1'000'000;
  if (client->poll_ns != 0) request_polling_slice();
  for (;;) {
    const auto* h = client->map.header();
    // Read the wake word before looking for a frame: a publish after the look changes it, so the
    // sleep below returns at once instead of missing that frame.
    const std::uint32_t seen = h->wake.load(std::memory_order_acquire);
    const std::uint64_t published = h->publish_count.load(std::memory_order_acquire);
    if (published > client->last_index) {
      const dco_status status = client->take_latest(view);
      if (status != DCO_E_NO_FRAME) return client->returned(status);
    }
    const std::int64_t now = now_ns();
    const bool closed = h->state.load(std::memory_order_acquire) == layout::kStateClosed;
    const bool gone_or_refused = client->gone_reported || client->refusal_reported;
    if ((closed && !gone_or_refused) || now - client->last_path_check_ns >= kPathCheckNs) {
      bool remapped = false;
      const dco_status status = client->follow_path(&remapped);
      // A refusal is said at once the first time; later calls wait out their timeout (checking
      // again meanwhile), which a caller that simply calls again would otherwise spin through.
      if (status != DCO_OK && !client->refusal_reported) {
        client->refusal_reported = true;
        return status;
      }
      if (remapped) continue;
      if (client->refused == DCO_OK && client->writer_gone()) {
        // A frame published between the look above and the close is still the client's: the
        // writer publishes before it closes, so a count read after seeing it gone has it.
        if (h->publish_count.load(std::memory_order_acquire) > client->last_index) continue;
        if (!client->gone_reported) {
          client->gone_reported = true;
          return fail(DCO_E_WRITER_GONE, client->expect.path + ": the writer stopped");
        }
      }
    }
    if (now >= deadline) {
      // Said again by every call until a new ring replaces this one (a remap clears it), also
      // by one whose timeout ends before its next look at the writer.
      if (client->refused != DCO_OK) return client->repeat_refusal();
      if (client->gone_reported)
        return fail(DCO_E_WRITER_GONE, client->expect.path + ": the writer stopped");
      return fail(DCO_E_TIMEOUT, client->expect.path + ": no new frame within " +
                                     std::to_string(timeout_ms) + " ms");
    }
    // A writer that dies never wakes us, and a restarted one writes a new file: wake up for the
    // path check at the latest.
    const std::int64_t until = std::min(deadline, client->last_path_check_ns + kPathCheckNs);
    if (client->poll_ns == 0) {
      layout::wait_for_change(h->wake, seen, until - now);
      continue;
    }
    // Compared with the count read before the look for a frame: equal means no write began
    // since, and the next one changes the word this sleeps on.
    const std::uint32_t begun = h->writes_begun.load(std::memory_order_acquire);
    if (begun == static_cast<std::uint32_t>(published)) {
      layout::wait_for_change(h->writes_begun, begun, until - now);
    } else {
      if (begun != client->polled_write) {
        client->polled_write = begun;
        client->poll_end_ns = now + client->poll_ns;
      }
      // A path check falling due ends a poll early; the poll resumes after it.
      if (now < client->poll_end_ns)
        poll_for_change(h->wake, seen, std::min(until, client->poll_end_ns));
      else  // this write outlasted the polling: sleep until it is published
        layout::wait_for_change(h->wake, seen, until - now);
    }
  }
} catch (...) {
  return out_of_memory();
}

}  // extern "C"

namespace {

bool buffer_ok(const dco_frame_buffer* dst) {
  return struct_ok(dst, dst ? dst->struct_size : 0, sizeof(dco_frame_buffer)) &&
         dst->depth != nullptr;
}

// Copies the frame `view` names into dst; `caller` names the public function in messages.
dco_status copy_view(const dco_client* client, const dco_frame_view* view, dco_frame_buffer* dst,
                     const char* caller) {
  // Sizes and addresses come from the mapping; the view only names the slot and its token.
  const Mapping& m = client->map;
  // A writer's session id is never 0: this view was initialised and never given a frame (a
  // latest() whose DCO_E_NO_FRAME went unchecked), which is no daemon restart.
  if (view->info.session_id == 0)
    return fail(DCO_E_INVALID_ARGUMENT,
                std::string(caller) + ": the view holds no frame (no call returned one into it)");
  // A view of the ring a restarted daemon left: its frame is not in the ring now mapped, whose
  // sizes say nothing of it.
  if (view->info.session_id != m.session_id)
    return fail(DCO_E_OVERTAKEN, client->expect.path +
                                     ": the view is of an earlier ring (dcod "
                                     "restarted since); its frame is gone");
  const std::size_t depth_row = std::size_t{m.geometry.width} * sizeof(float);
  const std::size_t rows = m.geometry.height;
  if (!rows_fit(dst->depth_capacity, dst->depth_stride, rows, depth_row))
    return fail(DCO_E_BUFFER_TOO_SMALL,
                std::string(caller) + ": depth buffer too small for " +
                    std::to_string(m.geometry.width) + "x" + std::to_string(rows) +
                    " (rows of at least " + std::to_string(depth_row) + " bytes, " +
                    std::to_string(rows * depth_row) + " bytes when packed)");
  const bool copy_image = dst->image != nullptr && m.geometry.image_channels != 0;
  const std::size_t image_row = std::size_t{m.geometry.width} * m.geometry.image_channels;
  if (copy_image && !rows_fit(dst->image_capacity, dst->image_stride, rows, image_row))
    return fail(DCO_E_BUFFER_TOO_SMALL,
                std::string(caller) + ": image buffer too small for " +
                    std::to_string(m.geometry.width) + "x" + std::to_string(rows) + "x" +
                    std::to_string(m.geometry.image_channels) + " (rows of at least " +
                    std::to_string(image_row) + " bytes, " + std::to_string(rows * image_row) +
                    " bytes when packed)");
  if (!client->valid(view))
    return fail(DCO_E_OVERTAKEN, client->expect.path + ": slot overwritten before the copy");
  const unsigned char* slot = m.slot(view->info.slot);
  const unsigned char* depth = slot + m.sizes.depth_offset;
  auto* out = reinterpret_cast<unsigned char*>(dst->depth);
  for (std::size_t y = 0; y < rows; ++y)
    std::memcpy(out + y * dst->depth_stride, depth + y * m.sizes.depth_stride, depth_row);
  if (copy_image) {
    const unsigned char* image = slot + m.sizes.image_offset;
    for (std::size_t y = 0; y < rows; ++y)
      std::memcpy(dst->image + y * dst->image_stride, image + y * m.sizes.image_stride, image_row);
  }
  if (!client->valid(view))
    return fail(DCO_E_OVERTAKEN, client->expect.path + ": slot overwritten during the copy");
  return DCO_OK;
}

}  // namespace

extern "C" {

dco_status dco_client_copy(const dco_client* client, const dco_frame_view* view,
                           dco_frame_buffer* dst) try {
  const NoCancel no_cancel;
  if (client == nullptr || !struct_ok(view, view ? view->struct_size : 0, sizeof(dco_frame_view)) ||
      !buffer_ok(dst))
    return fail(DCO_E_INVALID_ARGUMENT, "dco_client_copy: bad client, view or buffer");
  return copy_view(client, view, dst, "dco_client_copy");
} catch (...) {
  return out_of_memory();
}

dco_status dco_client_read_latest(dco_client* client, dco_frame_buffer* dst,
                                  dco_frame_info* info) try {
  const NoCancel no_cancel;
  if (client == nullptr || !buffer_ok(dst) ||
      (info != nullptr && info->struct_size < sizeof(dco_frame_info)))
    return fail(DCO_E_INVALID_ARGUMENT, "dco_client_read_latest: bad client, buffer or info");
  dco_frame_view view;
  dco_frame_view_init(&view);
  const dco_client::Returned before = client->last_returned();
  for (std::uint32_t attempt = 0; attempt < client->max_attempts; ++attempt) {
    dco_status status = client->checked_latest(&view);
    if (status != DCO_OK) return status;
    status = copy_view(client, &view, dst, "dco_client_read_latest");
    if (status == DCO_E_OVERTAKEN) continue;
    if (status == DCO_OK && info != nullptr) *info = view.info;
    return client->copied(status, before);
  }
  return fail(DCO_E_OVERTAKEN, client->expect.path + ": every copy was overtaken (" +
                                   std::to_string(client->max_attempts) + " attempts)");
} catch (...) {
  return out_of_memory();
}

dco_status dco_client_view_announced(dco_client* client, uint64_t session_id, uint32_t slot,
                                     uint64_t publish_index, dco_frame_view* view) try {
  const NoCancel no_cancel;
  if (client == nullptr || !struct_ok(view, view ? view->struct_size : 0, sizeof(dco_frame_view)))
    return fail(DCO_E_INVALID_ARGUMENT, "dco_client_view_announced: bad client or view");
  return client->returned(client->take_announced(session_id, slot, publish_index, view));
} catch (...) {
  return out_of_memory();
}

dco_status dco_client_read_announced(dco_client* client, uint64_t session_id, uint32_t slot,
                                     uint64_t publish_index, dco_frame_buffer* dst,
                                     dco_frame_info* info) try {
  const NoCancel no_cancel;
  if (client == nullptr || !buffer_ok(dst) ||
      (info != nullptr && info->struct_size < sizeof(dco_frame_info)))
    return fail(DCO_E_INVALID_ARGUMENT, "dco_client_read_announced: bad client, buffer or info");
  dco_frame_view view;
  dco_frame_view_init(&view);
  const dco_client::Returned before = client->last_returned();
  dco_status status = client->take_announced(session_id, slot, publish_index, &view);
  if (status != DCO_OK) return status;
  status = copy_view(client, &view, dst, "dco_client_read_announced");
  if (status == DCO_OK && info != nullptr) *info = view.info;
  return client->copied(status, before);
} catch (...) {
  return out_of_memory();
}

uint64_t dco_client_session_id(const dco_client* client) {
  return client != nullptr ? client->map.session_id : 0;
}

const char* dco_client_strerror(dco_status status) {
  switch (status) {
    case DCO_OK:
      return "success";
    case DCO_E_INVALID_ARGUMENT:
      return "invalid argument";
    case DCO_E_NO_SEGMENT:
      return "no depth ring at the path";
    case DCO_E_IO:
      return "I/O error";
    case DCO_E_BAD_FORMAT:
      return "not a valid depth ring";
    case DCO_E_PERMISSION:
      return "depth ring has the wrong owner or permissions";
    case DCO_E_GEOMETRY:
      return "depth ring has another geometry";
    case DCO_E_NO_FRAME:
      return "no frame published yet";
    case DCO_E_OVERTAKEN:
      return "frame overwritten while reading";
    case DCO_E_TIMEOUT:
      return "timed out";
    case DCO_E_WRITER_GONE:
      return "writer stopped";
    case DCO_E_BUFFER_TOO_SMALL:
      return "buffer too small";
    case DCO_E_NOT_PUBLISHED:
      return "the ring holds no such frame";
  }
  return "unknown status";
}

const char* dco_client_last_error(void) {
  return t_last_error;
}

}  // extern "C"
