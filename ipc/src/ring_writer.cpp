#include "dco/ipc/ring_writer.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <new>
#include <string>

#include <fmt/format.h>

#include "dco/core/error.hpp"
#include "dco/ipc/ring_layout.hpp"
#include "dco/ipc/ring_wake.hpp"

namespace dco::ipc {
namespace {

namespace layout = dco::ipc::layout;

std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

std::uint64_t random_session_id() {
  std::uint64_t id = 0;
  while (id == 0) {
    const ssize_t got = getrandom(&id, sizeof(id), 0);
    if (got == -1 && errno == EINTR) continue;  // a signal while the pool was not yet ready
    if (got != static_cast<ssize_t>(sizeof(id)))
      throw Error(fmt::format("getrandom: {}", std::strerror(errno)));
  }
  return id;
}

[[noreturn]] void fail_errno(const std::filesystem::path& path, const char* what) {
  throw Error(fmt::format("{}: {}: {}", path.string(), what, std::strerror(errno)));
}

std::filesystem::path directory_of(const std::filesystem::path& file) {
  return file.parent_path().empty() ? "." : file.parent_path();
}

// Held while a writer creates its temporary ring, moves a ring into place or removes one: the
// check that the ring at the path is still a writer's own and its removal are then one step for
// every other writer in the directory. A writer holds it for microseconds; whoever else can read
// the directory (a client's group) can lock it too, so it is waited for a second at most and the
// steps then go unguarded, as they do without a readable directory.
class DirectoryLock {
 public:
  explicit DirectoryLock(const std::filesystem::path& file) {
    fd_ = open(directory_of(file).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd_ < 0) return;
    constexpr int kTries = 1000;
    for (int i = 0; i < kTries; ++i) {
      if (flock(fd_, LOCK_EX | LOCK_NB) == 0) return;
      if (errno != EWOULDBLOCK && errno != EINTR) break;
      const timespec ms{0, 1'000'000};
      nanosleep(&ms, nullptr);
    }
    close(fd_);
    fd_ = -1;
  }
  DirectoryLock(const DirectoryLock&) = delete;
  DirectoryLock& operator=(const DirectoryLock&) = delete;
  ~DirectoryLock() {
    if (fd_ >= 0) close(fd_);  // drops the lock
  }

 private:
  int fd_ = -1;
};

// Opens a file of the ring's directory to look at it: never a FIFO's wait for a writer, never a
// link's target. -1 for anything that is not a regular file.
int open_regular(const std::filesystem::path& file) {
  const int fd = open(file.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return -1;
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    close(fd);
    return -1;
  }
  return fd;
}

// Temporary rings of writers killed while they built them (each holds a whole ring's memory, in
// RAM under /run): a live writer's is locked. Called under the DirectoryLock, which every writer
// holds from creating its temporary ring to locking it.
void remove_abandoned_rings(const std::filesystem::path& path) {
  const std::string prefix = path.filename().string() + ".tmp.";
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(directory_of(path), ec)) {
    if (!entry.path().filename().string().starts_with(prefix)) continue;
    const int fd = open_regular(entry.path());
    if (fd < 0) continue;
    if (flock(fd, LOCK_EX | LOCK_NB) == 0) unlink(entry.path().c_str());
    close(fd);
  }
}

// One writer per ring: a ring at the path whose writer still holds its lock is a live writer's
// (a second dcod started by hand beside the service), and replacing it would leave that writer
// publishing into a file no client can find while it still tells its watchdog all is well.
// Readers only ever take the lock shared, so a shared probe fails on the writer alone.
void refuse_live_writer(const std::filesystem::path& path) {
  const int fd = open_regular(path);
  if (fd < 0) return;
  const bool live = flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  std::uint64_t magic = 0;
  std::int64_t pid = 0;
  const bool has_pid = pread(fd, &magic, sizeof(magic), 0) == static_cast<ssize_t>(sizeof(magic)) &&
                       magic == layout::kMagic &&
                       pread(fd, &pid, sizeof(pid), offsetof(layout::RingHeader, writer_pid)) ==
                           static_cast<ssize_t>(sizeof(pid));
  close(fd);
  if (!live) return;
  throw Error(fmt::format("{}: another writer{} publishes depth there; stop it first",
                          path.string(), has_pid ? fmt::format(" (pid {})", pid) : std::string()));
}

}  // namespace

RingWriter::RingWriter(const std::filesystem::path& path, const RingOptions& options)
    : path_(path), options_(options) {
  const layout::Geometry g{static_cast<std::uint32_t>(std::max(options.width, 0)),
                           static_cast<std::uint32_t>(std::max(options.height, 0)),
                           static_cast<std::uint32_t>(std::max(options.image_channels, 0)),
                           static_cast<std::uint32_t>(std::max(options.slot_count, 0))};
  const auto sizes = layout::compute_sizes(g);
  if (!sizes || options.image_channels < 0)
    throw Error(fmt::format(
        "{}: ring geometry {}x{}, {} image channels, {} slots out of range (1..{} px, 0/1/3 "
        "channels, {}..{} slots)",
        path.string(), options.width, options.height, options.image_channels, options.slot_count,
        layout::kMaxDimension, layout::kMinSlots, layout::kMaxSlots));

  session_id_ = random_session_id();

  // Built under a temporary name and renamed into place, so a reader never maps a half-made ring.
  // The name holds the random session id: writers in other pid namespaces may share a pid and
  // the directory.
  const std::filesystem::path tmp = fmt::format("{}.tmp.{:016x}", path.string(), session_id_);
  size_ = sizes->file_size;
  const auto cleanup = [&](const char* what) {
    const int err = errno;
    if (base_ != nullptr) munmap(base_, size_);
    base_ = nullptr;
    if (fd_ >= 0) close(fd_);
    fd_ = -1;
    unlink(tmp.c_str());
    errno = err;
    fail_errno(path, what);
  };
  {
    const DirectoryLock lock(path);
    refuse_live_writer(path);
    remove_abandoned_rings(path);
    fd_ = open(tmp.c_str(), O_CREAT | O_EXCL | O_RDWR | O_CLOEXEC, 0640);
    if (fd_ < 0) fail_errno(tmp, "cannot create the depth ring");
    // Readers take a shared lock to learn whether the writer died; the kernel drops ours with us.
    if (flock(fd_, LOCK_EX | LOCK_NB) != 0) cleanup("flock");
  }
  // The umask may have dropped bits of 0640; the mode is part of the contract with readers.
  if (fchmod(fd_, 0640) != 0) cleanup("fchmod");
  if (ftruncate(fd_, static_cast<off_t>(size_)) != 0) cleanup("ftruncate");
  // ftruncate reserves nothing on tmpfs: a full /run would fault (SIGBUS) on the first touch of
  // a page below. Reserving the pages now turns that into an error here.
  if (const int err = posix_fallocate(fd_, 0, static_cast<off_t>(size_)); err != 0) {
    errno = err;
    cleanup("cannot reserve the depth ring's memory");
  }
  void* p = mmap(nullptr, size_, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, 0);
  if (p == MAP_FAILED) cleanup("mmap");
  base_ = static_cast<unsigned char*>(p);

  auto* h = new (base_) layout::RingHeader{};
  h->magic = layout::kMagic;
  h->version = layout::kVersion;
  h->header_size = sizeof(layout::RingHeader);
  h->width = g.width;
  h->height = g.height;
  h->depth_format = layout::kDepthFormatFloat32Metres;
  h->image_format = g.image_channels ? layout::kImageFormatU8 : layout::kImageFormatNone;
  h->image_channels = g.image_channels;
  h->slot_count = g.slot_count;
  h->depth_stride = sizes->depth_stride;
  h->image_stride = sizes->image_stride;
  h->slot_header_size = sizeof(layout::SlotHeader);
  h->depth_offset = sizes->depth_offset;
  h->image_offset = sizes->image_offset;
  h->slot_stride = sizes->slot_stride;
  h->slots_offset = sizes->slots_offset;
  h->file_size = sizes->file_size;
  h->session_id = session_id_;
  h->writer_pid = getpid();
  h->created_ns = monotonic_ns();
  h->state.store(layout::kStateLive, std::memory_order_relaxed);
  // Touching every page now keeps page faults out of the first frames' publish times.
  std::memset(base_ + sizes->slots_offset, 0, size_ - sizes->slots_offset);
  for (std::uint32_t i = 0; i < g.slot_count; ++i) new (slot_base(i)) layout::SlotHeader{};
  // The first slot written is 0, so "newest" starts at the last one.
  writing_ = g.slot_count - 1;
  h->newest_slot.store(writing_, std::memory_order_relaxed);

  const DirectoryLock lock(path);
  try {
    refuse_live_writer(path);  // one may have moved its ring into place while this one was built
  } catch (const Error&) {
    munmap(base_, size_);
    close(fd_);
    unlink(tmp.c_str());
    throw;
  }
  if (rename(tmp.c_str(), path.c_str()) != 0) cleanup("cannot move the depth ring into place");
}

RingWriter::~RingWriter() {
  auto* h = reinterpret_cast<layout::RingHeader*>(base_);
  h->state.store(layout::kStateClosed, std::memory_order_release);
  layout::change_and_wake(h->wake);
  layout::change_and_wake(h->writes_begun);
  // Only remove the file while it is still ours: a newer writer may have replaced it, and none
  // can between the check and the removal.
  const DirectoryLock lock(path_);
  struct stat mine {};
  struct stat there {};
  if (fstat(fd_, &mine) == 0 && stat(path_.c_str(), &there) == 0 && mine.st_dev == there.st_dev &&
      mine.st_ino == there.st_ino)
    unlink(path_.c_str());
  munmap(base_, size_);
  close(fd_);
}

unsigned char* RingWriter::slot_base(std::uint32_t index) const {
  const auto* h = reinterpret_cast<const layout::RingHeader*>(base_);
  return base_ + h->slots_offset + h->slot_stride * index;
}

RingWriter::Slot RingWriter::begin_write() {
  auto* h = reinterpret_cast<layout::RingHeader*>(base_);
  // A slot still open is one whose write was never published (its frame failed half-way): its
  // counter is odd, so readers keep away from it, and it is written again. Opening the next one
  // would leave it odd, and flip it back to even on a half-filled slot when its turn came.
  if (!open_slot_) {
    // Readers that poll through a write get up now, while the slot fills, so they are running
    // when it is published.
    layout::change_and_wake(h->writes_begun);
    writing_ = (writing_ + 1) % h->slot_count;
    auto* s = reinterpret_cast<layout::SlotHeader*>(slot_base(writing_));
    const std::uint64_t c = s->seqlock.load(std::memory_order_relaxed);
    s->seqlock.store(c + 1, std::memory_order_relaxed);
    layout::fence_release();
    open_slot_ = true;
  }
  unsigned char* base = slot_base(writing_);
  Slot slot;
  slot.index = writing_;
  slot.depth = ImageView<float>(reinterpret_cast<float*>(base + h->depth_offset), options_.width,
                                options_.height, 1,
                                static_cast<std::ptrdiff_t>(h->depth_stride / sizeof(float)));
  if (h->image_channels != 0)
    slot.image = ImageView<std::uint8_t>(base + h->image_offset, options_.width, options_.height,
                                         options_.image_channels,
                                         static_cast<std::ptrdiff_t>(h->image_stride));
  return slot;
}

std::uint64_t RingWriter::publish(const FrameMeta& meta) {
  // Without an open slot the counter below would turn odd on a published frame.
  if (!open_slot_) throw Error(path_.string() + ": publish() without begin_write()");
  auto* h = reinterpret_cast<layout::RingHeader*>(base_);
  auto* s = reinterpret_cast<layout::SlotHeader*>(slot_base(writing_));
  const std::uint64_t index = published_ + 1;
  s->publish_index = index;
  s->frame_seq = meta.frame_seq;
  s->capture_ns = meta.capture_ns;
  s->publish_ns = monotonic_ns();
  s->fx = meta.fx;
  s->fy = meta.fy;
  s->cx = meta.cx;
  s->cy = meta.cy;
  s->baseline_m = meta.baseline_m;
  s->seqlock.store(s->seqlock.load(std::memory_order_relaxed) + 1, std::memory_order_release);
  h->newest_slot.store(writing_, std::memory_order_release);
  h->publish_count.store(index, std::memory_order_release);
  layout::change_and_wake(h->wake);
  published_ = index;
  open_slot_ = false;
  return index;
}

std::uint64_t RingWriter::write(ImageView<const float> depth, ImageView<const std::uint8_t> image,
                                const FrameMeta& meta) {
  if (depth.empty() || !depth.same_size(options_.width, options_.height) || depth.channels != 1)
    throw Error(fmt::format("{}: depth is {}x{}x{}, the ring holds {}x{}x1", path_.string(),
                            depth.width, depth.height, depth.channels, options_.width,
                            options_.height));
  // A slot's depth and image are one frame: an image ring never gets depth without its image.
  const bool image_ok = options_.image_channels == 0
                            ? image.empty()
                            : !image.empty() && image.same_size(options_.width, options_.height) &&
                                  image.channels == options_.image_channels;
  if (!image_ok)
    throw Error(fmt::format("{}: image is {}x{}x{}, the ring holds {}x{}x{}", path_.string(),
                            image.width, image.height, image.channels, options_.width,
                            options_.height, options_.image_channels));
  const Slot slot = begin_write();
  const std::size_t depth_row = static_cast<std::size_t>(options_.width) * sizeof(float);
  for (int y = 0; y < options_.height; ++y) std::memcpy(slot.depth.row(y), depth.row(y), depth_row);
  if (options_.image_channels != 0) {
    const std::size_t image_row = static_cast<std::size_t>(options_.width) * image.channels;
    for (int y = 0; y < options_.height; ++y)
      std::memcpy(slot.image.row(y), image.row(y), image_row);
  }
  return publish(meta);
}

std::filesystem::path RingWriter::default_directory() {
  if (const char* runtime = std::getenv("RUNTIME_DIRECTORY"); runtime != nullptr && *runtime) {
    // systemd may list several directories separated by ':'; the first is ours.
    const std::string dirs(runtime);
    return dirs.substr(0, dirs.find(':'));
  }
  if (access("/run/dcod", W_OK | X_OK) == 0) return "/run/dcod";
  // Run by hand: a directory of the user's own, the same at every start, so that a client
  // follows a restarted daemon to its new ring.
  const char* xdg = std::getenv("XDG_RUNTIME_DIR");
  const std::filesystem::path dir =
      xdg != nullptr && *xdg == '/'
          ? std::filesystem::path(xdg) / "dcod"
          : std::filesystem::temp_directory_path() / fmt::format("dcod-{}", getuid());
  if (mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST)
    throw Error(fmt::format("{}: cannot create a runtime directory: {}", dir.string(),
                            std::strerror(errno)));
  struct stat st {};
  if (lstat(dir.c_str(), &st) != 0)
    throw Error(fmt::format("{}: {}", dir.string(), std::strerror(errno)));
  // Anyone else able to write there could put their own file where clients look for depth.
  if (!S_ISDIR(st.st_mode) || st.st_uid != getuid() || (st.st_mode & (S_IWGRP | S_IWOTH)) != 0)
    throw Error(fmt::format(
        "{}: not a directory of uid {} that only it can write to; set ring.path elsewhere",
        dir.string(), getuid()));
  return dir;
}

}  // namespace dco::ipc
