// Everything a client can meet at the ring's path that is not a healthy ring gets its own status
// and a message naming the file, never a crash.

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstddef>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dco/client.hpp"
#include "dco/ipc/ring_layout.hpp"
#include "ipc_test_support.hpp"

namespace dco::ipc::testing {
namespace {

struct Opened {
  dco_status status;
  std::string message;
};

Opened open_with(const dco_client_options& o) {
  dco_client* c = nullptr;
  const dco_status s = dco_client_open(&o, &c);
  Opened r{s, dco_client_last_error()};
  if (s == DCO_OK) {
    EXPECT_NE(c, nullptr);
    dco_client_close(c);
  } else {
    EXPECT_EQ(c, nullptr);
  }
  return r;
}

Opened open_path(const std::filesystem::path& path) {
  dco_client_options o;
  dco_client_options_init(&o);
  const std::string p = path.string();
  o.path = p.c_str();
  return open_with(o);
}

class RingErrors : public ::testing::Test {
 protected:
  void SetUp() override {
    RingOptions o;
    o.width = 64;
    o.height = 32;
    o.image_channels = 3;
    writer_ = std::make_unique<RingWriter>(dir_.path() / "depth.shm", o);
  }

  // A copy of the live ring with `edit` applied to its bytes, mode 0640.
  std::filesystem::path patched(const std::string& name,
                                const std::function<void(std::string&)>& edit) {
    std::ifstream in(writer_->path(), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    edit(bytes);
    const auto p = dir_.path() / name;
    std::ofstream(p, std::ios::binary) << bytes;
    std::filesystem::permissions(p, std::filesystem::perms(0640));
    return p;
  }

  template <typename T>
  static void poke(std::string& bytes, std::size_t offset, T value) {
    std::memcpy(bytes.data() + offset, &value, sizeof(T));
  }

  TempDir dir_;
  std::unique_ptr<RingWriter> writer_;
};

using layout::RingHeader;

TEST_F(RingErrors, HealthyRingOpens) {
  EXPECT_EQ(open_path(writer_->path()).status, DCO_OK);
}

TEST_F(RingErrors, MissingSegment) {
  const auto r = open_path(dir_.path() / "nothing.shm");
  EXPECT_EQ(r.status, DCO_E_NO_SEGMENT);
  EXPECT_NE(r.message.find("nothing.shm"), std::string::npos) << r.message;
}

TEST_F(RingErrors, ForeignFile) {
  const auto p = patched("foreign.shm", [](std::string& b) { b.replace(0, 8, "NOTARING"); });
  const auto r = open_path(p);
  EXPECT_EQ(r.status, DCO_E_BAD_FORMAT);
  EXPECT_NE(r.message.find("not a dco depth ring"), std::string::npos) << r.message;
}

TEST_F(RingErrors, OtherVersion) {
  const auto p = patched(
      "v9.shm", [](std::string& b) { poke<std::uint32_t>(b, offsetof(RingHeader, version), 9); });
  const auto r = open_path(p);
  EXPECT_EQ(r.status, DCO_E_BAD_FORMAT);
  EXPECT_NE(r.message.find("version 9"), std::string::npos) << r.message;
}

TEST_F(RingErrors, TruncatedFiles) {
  const auto half = patched("half.shm", [](std::string& b) { b.resize(b.size() / 2); });
  auto r = open_path(half);
  EXPECT_EQ(r.status, DCO_E_BAD_FORMAT);
  EXPECT_NE(r.message.find("truncated"), std::string::npos) << r.message;
  const auto tiny = patched("tiny.shm", [](std::string& b) { b.resize(10); });
  r = open_path(tiny);
  EXPECT_EQ(r.status, DCO_E_BAD_FORMAT);
  EXPECT_NE(r.message.find("truncated"), std::string::npos) << r.message;
  const auto empty = patched("empty.shm", [](std::string& b) { b.clear(); });
  EXPECT_EQ(open_path(empty).status, DCO_E_BAD_FORMAT);
}

TEST_F(RingErrors, HeaderThatContradictsItself) {
  // A larger width with the old strides and size: trusting it would read past the mapping.
  const auto wide = patched("wide.shm", [](std::string& b) {
    poke<std::uint32_t>(b, offsetof(RingHeader, width), 4096);
  });
  EXPECT_EQ(open_path(wide).status, DCO_E_BAD_FORMAT);
  const auto slots = patched("slots.shm", [](std::string& b) {
    poke<std::uint32_t>(b, offsetof(RingHeader, slot_count), 1000);
  });
  EXPECT_EQ(open_path(slots).status, DCO_E_BAD_FORMAT);
  const auto stride = patched("stride.shm", [](std::string& b) {
    poke<std::uint64_t>(b, offsetof(RingHeader, slot_stride), 1ull << 40);
  });
  EXPECT_EQ(open_path(stride).status, DCO_E_BAD_FORMAT);
  const auto channels = patched("channels.shm", [](std::string& b) {
    poke<std::uint32_t>(b, offsetof(RingHeader, image_channels), 0);
  });
  EXPECT_EQ(open_path(channels).status, DCO_E_BAD_FORMAT);
  const auto session = patched("session.shm", [](std::string& b) {
    poke<std::uint64_t>(b, offsetof(RingHeader, session_id), 0);
  });
  const Opened zero = open_path(session);
  EXPECT_EQ(zero.status, DCO_E_BAD_FORMAT);
  EXPECT_NE(zero.message.find("session id 0"), std::string::npos) << zero.message;
}

TEST_F(RingErrors, CorruptNewestSlotIndex) {
  const auto p = patched("newest.shm", [](std::string& b) {
    poke<std::uint64_t>(b, offsetof(RingHeader, publish_count), 1);
    poke<std::uint32_t>(b, offsetof(RingHeader, newest_slot), 77);
  });
  dco_client_options o;
  dco_client_options_init(&o);
  const std::string path = p.string();
  o.path = path.c_str();
  dco_client* c = nullptr;
  ASSERT_EQ(dco_client_open(&o, &c), DCO_OK);
  dco_frame_view v;
  dco_frame_view_init(&v);
  EXPECT_EQ(dco_client_latest(c, &v), DCO_E_BAD_FORMAT);
  dco_client_close(c);
}

TEST_F(RingErrors, WrongOwner) {
  dco_client_options o;
  dco_client_options_init(&o);
  const std::string p = writer_->path().string();
  o.path = p.c_str();
  o.expected_uid = getuid() + 1;
  const auto r = open_with(o);
  EXPECT_EQ(r.status, DCO_E_PERMISSION);
  EXPECT_NE(r.message.find("owned by uid"), std::string::npos) << r.message;
}

TEST_F(RingErrors, WorldWritable) {
  const auto p = patched("open.shm", [](std::string&) {});
  std::filesystem::permissions(p, std::filesystem::perms(0646));
  const auto r = open_path(p);
  EXPECT_EQ(r.status, DCO_E_PERMISSION);
  EXPECT_NE(r.message.find("world-writable"), std::string::npos) << r.message;
}

TEST_F(RingErrors, NotARegularFileOrASymlink) {
  std::filesystem::create_directory(dir_.path() / "dir.shm");
  EXPECT_EQ(open_path(dir_.path() / "dir.shm").status, DCO_E_PERMISSION);
  std::filesystem::create_symlink(writer_->path(), dir_.path() / "link.shm");
  EXPECT_EQ(open_path(dir_.path() / "link.shm").status, DCO_E_PERMISSION);
  // A FIFO would block a plain open until a writer came: refused at once instead.
  ASSERT_EQ(mkfifo((dir_.path() / "fifo.shm").c_str(), 0640), 0);
  EXPECT_EQ(open_path(dir_.path() / "fifo.shm").status, DCO_E_PERMISSION);
}

TEST_F(RingErrors, GeometryMismatch) {
  dco_client_options o;
  dco_client_options_init(&o);
  const std::string p = writer_->path().string();
  o.path = p.c_str();
  o.expected_width = 64;
  o.expected_height = 32;
  EXPECT_EQ(open_with(o).status, DCO_OK);
  o.expected_height = 48;
  const auto r = open_with(o);
  EXPECT_EQ(r.status, DCO_E_GEOMETRY);
  EXPECT_NE(r.message.find("64x32"), std::string::npos) << r.message;
  // Only a width asked for: the height is any, not 0.
  o.expected_width = 80;
  o.expected_height = 0;
  const auto w = open_with(o);
  EXPECT_EQ(w.status, DCO_E_GEOMETRY);
  EXPECT_NE(w.message.find("expected 80xany"), std::string::npos) << w.message;
}

TEST_F(RingErrors, InvalidArguments) {
  dco_client* c = nullptr;
  EXPECT_EQ(dco_client_open(nullptr, &c), DCO_E_INVALID_ARGUMENT);
  dco_client_options o;
  dco_client_options_init(&o);
  EXPECT_EQ(dco_client_open(&o, &c), DCO_E_INVALID_ARGUMENT) << "no path";
  EXPECT_EQ(dco_client_open(&o, nullptr), DCO_E_INVALID_ARGUMENT);
  const std::string p = writer_->path().string();
  o.path = p.c_str();
  o.struct_size = 4;
  EXPECT_EQ(dco_client_open(&o, &c), DCO_E_INVALID_ARGUMENT) << "options not initialised";
  dco_frame_view v;
  dco_frame_view_init(&v);
  EXPECT_EQ(dco_client_latest(nullptr, &v), DCO_E_INVALID_ARGUMENT);
  EXPECT_EQ(dco_client_wait_next(nullptr, 0, &v), DCO_E_INVALID_ARGUMENT);
  EXPECT_EQ(dco_client_still_valid(nullptr, &v), 0);
  EXPECT_EQ(dco_client_read_latest(nullptr, nullptr, nullptr), DCO_E_INVALID_ARGUMENT);
  // A view no call filled (a DCO_E_NO_FRAME gone unchecked) is the caller's mistake, not a
  // daemon restart.
  dco_client_options ok;
  dco_client_options_init(&ok);
  ok.path = p.c_str();
  ASSERT_EQ(dco_client_open(&ok, &c), DCO_OK) << dco_client_last_error();
  EXPECT_EQ(dco_client_latest(c, &v), DCO_E_NO_FRAME);
  std::vector<float> depth(64 * 32);
  dco_frame_buffer buffer;
  dco_frame_buffer_init(&buffer);
  buffer.depth = depth.data();
  buffer.depth_capacity = depth.size() * sizeof(float);
  buffer.depth_stride = 64 * sizeof(float);
  EXPECT_EQ(dco_client_copy(c, &v, &buffer), DCO_E_INVALID_ARGUMENT);
  EXPECT_NE(std::string(dco_client_last_error()).find("holds no frame"), std::string::npos)
      << dco_client_last_error();
  dco_client_close(c);
  EXPECT_STREQ(dco_client_strerror(DCO_E_OVERTAKEN), "frame overwritten while reading");
  EXPECT_STREQ(dco_client_strerror(static_cast<dco_status>(99)), "unknown status");
  dco_client_close(nullptr);
}

TEST_F(RingErrors, CppLayerThrowsWithTheStatus) {
  client::Options o;
  o.path = (dir_.path() / "nothing.shm").string();
  try {
    client::Client c(o);
    FAIL() << "opened a missing ring";
  } catch (const client::Error& e) {
    EXPECT_EQ(e.status(), DCO_E_NO_SEGMENT);
    EXPECT_NE(std::string(e.what()).find("nothing.shm"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dco::ipc::testing
