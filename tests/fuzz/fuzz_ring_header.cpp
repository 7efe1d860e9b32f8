// libFuzzer entry point: arbitrary bytes as a depth ring file, opened and read through
// libdco-client like a renderer would. The client must refuse every inconsistent header with a
// status and never read outside the file, whatever the header, slot headers or counters say.

#include <fcntl.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "dco/client.h"
#include "fuzz_target.hpp"

namespace {

std::string g_dir;

void remove_dir() {
  unlink((g_dir + "/depth.shm").c_str());
  rmdir(g_dir.c_str());
}

// One scratch file per process, removed at exit.
const std::string& ring_path() {
  static const std::string path = [] {
    g_dir = "/tmp/dco_fuzz_ring.XXXXXX";
    if (const char* tmp = std::getenv("TMPDIR"); tmp != nullptr && *tmp)
      g_dir = std::string(tmp) + "/dco_fuzz_ring.XXXXXX";
    if (mkdtemp(g_dir.data()) == nullptr) std::abort();
    std::atexit(remove_dir);
    return g_dir + "/depth.shm";
  }();
  return path;
}

void write_file(const std::uint8_t* data, std::size_t size) {
  const int fd = open(ring_path().c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
  if (fd < 0) std::abort();
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = write(fd, data + done, size - done);
    if (n <= 0) std::abort();
    done += static_cast<std::size_t>(n);
  }
  close(fd);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  write_file(data, size);
  dco_client_options o;
  dco_client_options_init(&o);
  o.path = ring_path().c_str();
  o.max_attempts = 2;
  dco_client* client = nullptr;
  const dco_status status = dco_client_open(&o, &client);
  if (status != DCO_OK) {
    if (client != nullptr || dco_client_last_error()[0] == '\0') std::abort();
    return 0;
  }
  dco_frame_view view;
  dco_frame_view_init(&view);
  if (dco_client_latest(client, &view) == DCO_OK) {
    std::vector<float> depth(std::size_t{view.info.width} * view.info.height);
    std::vector<std::uint8_t> image(view.info.image_stride * view.info.height);
    dco_frame_buffer buffer;
    dco_frame_buffer_init(&buffer);
    buffer.depth = depth.data();
    buffer.depth_stride = std::size_t{view.info.width} * sizeof(float);
    buffer.depth_capacity = depth.size() * sizeof(float);
    buffer.image = image.empty() ? nullptr : image.data();
    buffer.image_stride = view.info.image_stride;
    buffer.image_capacity = image.size();
    dco_client_copy(client, &view, &buffer);
    // Announcements naming every slot with the index the slot header claims, and its neighbours.
    for (std::uint32_t slot = 0; slot < 70; ++slot)
      for (std::uint64_t index : {std::uint64_t{0}, std::uint64_t{1}, view.info.publish_index,
                                  view.info.publish_index + 1})
        dco_client_read_announced(client, view.info.session_id, slot, index, &buffer, nullptr);
  }
  dco_client_close(client);
  return 0;
}
