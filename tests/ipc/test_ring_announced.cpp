// dco_client_view_announced / read_announced: an announcement (an LCM descriptor, in dcod) names
// a frame, and the client accepts it only when the ring holds exactly that frame.

#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "dco/client.h"
#include "dco/client.hpp"
#include "ipc_test_support.hpp"

namespace dco::ipc::testing {
namespace {

constexpr int kW = 24;
constexpr int kH = 6;

struct Announced {
  std::uint64_t index;
  std::uint32_t slot;
};

class Announcements : public ::testing::Test {
 protected:
  Announcements() : writer_(std::make_unique<RingWriter>(dir_.path() / "depth.shm", options())) {
    dco_client_options o;
    dco_client_options_init(&o);
    const std::string path = writer_->path().string();
    o.path = path.c_str();
    EXPECT_EQ(dco_client_open(&o, &client_), DCO_OK) << dco_client_last_error();
    depth_.resize(kW * kH);
    dco_frame_buffer_init(&buffer_);
    buffer_.depth = depth_.data();
    buffer_.depth_stride = kW * sizeof(float);
    buffer_.depth_capacity = depth_.size() * sizeof(float);
  }
  ~Announcements() override { dco_client_close(client_); }

  static RingOptions options() {
    RingOptions o;
    o.width = kW;
    o.height = kH;
    o.image_channels = 0;
    o.slot_count = 4;
    return o;
  }

  Announced publish(std::uint64_t seq) {
    const std::uint64_t index = publish_pattern(*writer_, seq);
    return {index, writer_->current_slot()};
  }

  dco_status read(std::uint64_t session, std::uint32_t slot, std::uint64_t index,
                  dco_frame_info* info = nullptr) {
    return dco_client_read_announced(client_, session, slot, index, &buffer_, info);
  }

  TempDir dir_;
  std::unique_ptr<RingWriter> writer_;
  dco_client* client_ = nullptr;
  std::vector<float> depth_;
  dco_frame_buffer buffer_;
};

TEST_F(Announcements, AcceptsTheFrameTheRingHolds) {
  const Announced a = publish(41);
  dco_frame_info info;
  dco_frame_info_init(&info);
  ASSERT_EQ(read(writer_->session_id(), a.slot, a.index, &info), DCO_OK) << dco_client_last_error();
  EXPECT_EQ(info.publish_index, a.index);
  EXPECT_EQ(info.slot, a.slot);
  EXPECT_EQ(info.frame_seq, 41u);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x)
      ASSERT_EQ(depth_[static_cast<std::size_t>(y * kW + x)],
                pattern_depth(41, static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y)));
  // Older frames stay readable while their slot is not reused.
  const Announced b = publish(42);
  EXPECT_EQ(read(writer_->session_id(), a.slot, a.index), DCO_OK);
  EXPECT_EQ(read(writer_->session_id(), b.slot, b.index), DCO_OK);
}

// An announced frame counts as returned: wait_next waits for a newer one, as after latest.
TEST_F(Announcements, WaitNextWaitsForAFrameNewerThanTheAnnouncedOne) {
  publish(1);
  const Announced a = publish(2);
  ASSERT_EQ(read(writer_->session_id(), a.slot, a.index), DCO_OK) << dco_client_last_error();
  dco_frame_view view;
  dco_frame_view_init(&view);
  EXPECT_EQ(dco_client_wait_next(client_, 50, &view), DCO_E_TIMEOUT);
  const Announced b = publish(3);
  ASSERT_EQ(dco_client_wait_next(client_, 1000, &view), DCO_OK) << dco_client_last_error();
  EXPECT_EQ(view.info.publish_index, b.index);
}

TEST_F(Announcements, RejectsFramesTheRingNeverHeld) {
  const Announced a = publish(1);
  publish(2);
  const std::uint64_t s = writer_->session_id();
  EXPECT_EQ(read(s ^ 1, a.slot, a.index), DCO_E_NOT_PUBLISHED);
  EXPECT_NE(std::string(dco_client_last_error()).find("session"), std::string::npos);
  EXPECT_EQ(read(s, 4, a.index), DCO_E_NOT_PUBLISHED);
  EXPECT_EQ(read(s, 0xffffffffu, a.index), DCO_E_NOT_PUBLISHED);
  EXPECT_EQ(read(s, a.slot, 0), DCO_E_NOT_PUBLISHED);
  EXPECT_EQ(read(s, a.slot, 3), DCO_E_NOT_PUBLISHED);  // not yet published
  EXPECT_EQ(read(s, a.slot, ~0ull), DCO_E_NOT_PUBLISHED);
  EXPECT_EQ(read(s, (a.slot + 2) % 4, a.index), DCO_E_NOT_PUBLISHED);  // published elsewhere
  // That slot holds the newer index 2: refused as overwritten, since the reader cannot tell
  // where index 1 went.
  EXPECT_EQ(read(s, (a.slot + 1) % 4, a.index), DCO_E_OVERTAKEN);
}

TEST_F(Announcements, RejectsASlotBeingWritten) {
  std::vector<Announced> published;
  for (std::uint64_t seq = 1; seq <= 4; ++seq) published.push_back(publish(seq));
  // The next write reuses the slot of index 1; while it is open neither that index nor the one
  // about to be published may be read from it.
  RingWriter::Slot open = writer_->begin_write();
  ASSERT_EQ(open.index, published[0].slot);
  const std::uint64_t s = writer_->session_id();
  EXPECT_EQ(read(s, open.index, 1), DCO_E_OVERTAKEN);
  EXPECT_EQ(read(s, open.index, 5), DCO_E_NOT_PUBLISHED);
  dco_frame_view view;
  dco_frame_view_init(&view);
  EXPECT_EQ(dco_client_view_announced(client_, s, open.index, 1, &view), DCO_E_OVERTAKEN);
  writer_->publish(FrameMeta{});
  EXPECT_EQ(read(s, open.index, 5), DCO_OK);
  EXPECT_EQ(read(s, open.index, 1), DCO_E_OVERTAKEN);
}

TEST_F(Announcements, AViewStopsBeingValidWhenTheSlotIsReused) {
  const Announced a = publish(9);
  dco_frame_view view;
  dco_frame_view_init(&view);
  ASSERT_EQ(dco_client_view_announced(client_, writer_->session_id(), a.slot, a.index, &view),
            DCO_OK);
  EXPECT_EQ(view.info.frame_seq, 9u);
  for (std::uint64_t seq = 10; seq < 13; ++seq) publish(seq);
  EXPECT_EQ(dco_client_still_valid(client_, &view), 1);
  publish(13);
  EXPECT_EQ(dco_client_still_valid(client_, &view), 0);
  EXPECT_EQ(read(writer_->session_id(), a.slot, a.index), DCO_E_OVERTAKEN);
}

TEST_F(Announcements, BadArgumentsAreRejected) {
  const Announced a = publish(3);
  EXPECT_EQ(dco_client_read_announced(nullptr, 1, 0, 1, &buffer_, nullptr), DCO_E_INVALID_ARGUMENT);
  EXPECT_EQ(dco_client_view_announced(client_, writer_->session_id(), a.slot, a.index, nullptr),
            DCO_E_INVALID_ARGUMENT);
  dco_frame_buffer small = buffer_;
  small.depth_capacity = 4;
  EXPECT_EQ(
      dco_client_read_announced(client_, writer_->session_id(), a.slot, a.index, &small, nullptr),
      DCO_E_BUFFER_TOO_SMALL);
  EXPECT_STREQ(dco_client_strerror(DCO_E_NOT_PUBLISHED), "the ring holds no such frame");
}

// An announcement from a restarted daemon makes the client follow it to the new ring.
TEST_F(Announcements, FollowsANewSession) {
  publish(1);
  const std::uint64_t old_session = writer_->session_id();
  const std::filesystem::path path = writer_->path();
  writer_.reset();  // the daemon stops, then starts again
  RingWriter restarted(path, options());
  const std::uint64_t index = publish_pattern(restarted, 100);
  EXPECT_EQ(read(restarted.session_id(), restarted.current_slot(), index), DCO_OK)
      << dco_client_last_error();
  EXPECT_EQ(dco_client_session_id(client_), restarted.session_id());
  EXPECT_EQ(read(old_session, 0, 1), DCO_E_NOT_PUBLISHED);
}

TEST_F(Announcements, CppLayer) {
  const Announced a = publish(5);
  dco::client::Options o;
  o.path = writer_->path().string();
  dco::client::Client c(o);
  const auto info = c.read_announced(writer_->session_id(), a.slot, a.index, buffer_);
  ASSERT_TRUE(info.has_value());
  EXPECT_EQ(info->frame_seq, 5u);
  EXPECT_FALSE(c.read_announced(writer_->session_id(), a.slot, a.index + 1, buffer_).has_value());
  const auto view = c.view_announced(writer_->session_id(), a.slot, a.index);
  ASSERT_TRUE(view.has_value());
  EXPECT_TRUE(c.still_valid(*view));
  EXPECT_FALSE(c.view_announced(writer_->session_id() + 1, a.slot, a.index).has_value());
}

}  // namespace
}  // namespace dco::ipc::testing
