#include <pthread.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "c_abi_smoke.h"
#include "dco/client.h"
#include "ipc_test_support.hpp"

namespace dco::ipc::testing {
namespace {

TEST(ClientCAbi, ACProgramReadsAFrame) {
  TempDir dir;
  const RingOptions o{32, 8};
  RingWriter writer(dir.path() / "depth.shm", o);
  std::uint64_t seq = 0;
  float first = 0;
  EXPECT_EQ(dco_test_c_read(writer.path().c_str(), &seq, &first), DCO_E_NO_FRAME);
  publish_pattern(writer, 77);
  ASSERT_EQ(dco_test_c_read(writer.path().c_str(), &seq, &first), DCO_OK);
  EXPECT_EQ(seq, 77u);
  EXPECT_FLOAT_EQ(first, pattern_depth(77, 0, 0));
  EXPECT_EQ(dco_test_c_read((dir.path() / "none").c_str(), &seq, &first), DCO_E_NO_SEGMENT);
}

// Appending fields must not move the ones callers compiled against.
TEST(ClientCAbi, StructsStartWithTheirSize) {
  dco_frame_view v;
  dco_frame_view_init(&v);
  EXPECT_EQ(v.struct_size, sizeof(dco_frame_view));
  EXPECT_EQ(v.info.struct_size, sizeof(dco_frame_info));
  dco_client_options o;
  dco_client_options_init(&o);
  EXPECT_EQ(o.struct_size, sizeof(dco_client_options));
  EXPECT_EQ(o.expected_uid, getuid());
  EXPECT_EQ(offsetof(dco_frame_view, struct_size), 0u);
  EXPECT_EQ(offsetof(dco_frame_buffer, struct_size), 0u);
}

dco_client* open_client(const std::filesystem::path& path) {
  dco_client_options o;
  dco_client_options_init(&o);
  const std::string p = path.string();
  o.path = p.c_str();
  dco_client* c = nullptr;
  EXPECT_EQ(dco_client_open(&o, &c), DCO_OK) << dco_client_last_error();
  return c;
}

// A view belongs to the handle that returned it: its pixels go when that handle closes, so
// another handle of the same ring must not call it valid.
TEST(ClientCAbi, AViewIsValidOnlyWithTheHandleThatReturnedIt) {
  TempDir dir;
  const RingOptions o{32, 8};
  RingWriter writer(dir.path() / "depth.shm", o);
  publish_pattern(writer, 5);
  dco_client* a = open_client(writer.path());
  dco_client* b = open_client(writer.path());
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  dco_frame_view v;
  dco_frame_view_init(&v);
  ASSERT_EQ(dco_client_latest(a, &v), DCO_OK);
  EXPECT_EQ(dco_client_still_valid(a, &v), 1);
  EXPECT_EQ(dco_client_still_valid(b, &v), 0);
  dco_frame_view mine;
  dco_frame_view_init(&mine);
  ASSERT_EQ(dco_client_latest(b, &mine), DCO_OK);
  EXPECT_EQ(dco_client_still_valid(b, &mine), 1);
  dco_client_close(a);
  EXPECT_EQ(dco_client_still_valid(b, &v), 0) << "the view's pixels were a's, unmapped now";
  dco_client_close(b);
}

// A C program that cancels a reader thread (pthread_cancel): a cancel pending when the thread
// enters a call that reaches a cancellation point (open, close) must not unwind through the
// library's handlers (the process would abort); the thread ends at its next cancellation point
// after the calls.
TEST(ClientCAbi, AThreadCancelledInACallEndsAfterItAndTheProcessGoesOn) {
  TempDir dir;
  const RingOptions o{32, 8};
  RingWriter writer(dir.path() / "depth.shm", o);
  publish_pattern(writer, 3);
  struct Reader {
    std::string path;
    std::atomic<bool> ready{false}, cancelled{false};
    std::atomic<int> calls{0};
  } reader{writer.path().string()};
  const auto body = [](void* arg) -> void* {
    auto* r = static_cast<Reader*>(arg);
    int old = 0;
    pthread_setcancelstate(PTHREAD_CANCEL_DISABLE, &old);
    r->ready = true;
    while (!r->cancelled) std::this_thread::yield();
    pthread_setcancelstate(PTHREAD_CANCEL_ENABLE, &old);  // the cancel is pending from here on
    dco_client_options opt;
    dco_client_options_init(&opt);
    opt.path = r->path.c_str();
    dco_client* c = nullptr;
    if (dco_client_open(&opt, &c) != DCO_OK) return nullptr;
    ++r->calls;
    dco_frame_view v;
    dco_frame_view_init(&v);
    if (dco_client_latest(c, &v) == DCO_OK) ++r->calls;
    if (dco_client_wait_next(c, 30, &v) == DCO_E_TIMEOUT) ++r->calls;
    dco_client_close(c);
    ++r->calls;
    pthread_testcancel();
    return nullptr;
  };
  pthread_t thread;
  ASSERT_EQ(pthread_create(&thread, nullptr, body, &reader), 0);
  while (!reader.ready) std::this_thread::yield();
  ASSERT_EQ(pthread_cancel(thread), 0);
  reader.cancelled = true;
  void* result = nullptr;
  ASSERT_EQ(pthread_join(thread, &result), 0);
  EXPECT_EQ(result, PTHREAD_CANCELED);
  EXPECT_EQ(reader.calls, 4) << "every call ran to its end first";
}

// After a clean stop, a loop that calls wait_next again (as the header invites, to pick up a
// daemon that comes back) waits out each call's timeout instead of spinning, then finds the new
// daemon.
TEST(ClientCAbi, WaitNextAfterTheWriterStoppedWaitsOutItsTimeout) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  const RingOptions o{32, 8};
  auto writer = std::make_unique<RingWriter>(path, o);
  dco_client* c = open_client(path);
  ASSERT_NE(c, nullptr);
  writer.reset();
  dco_frame_view v;
  dco_frame_view_init(&v);
  EXPECT_EQ(dco_client_wait_next(c, 100, &v), DCO_E_WRITER_GONE) << "said at once";
  int calls = 0;
  const auto start = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - start < std::chrono::milliseconds(300)) {
    EXPECT_EQ(dco_client_wait_next(c, 100, &v), DCO_E_WRITER_GONE);
    ++calls;
  }
  EXPECT_LE(calls, 4) << "each call waits its 100 ms";
  // A render loop's short timeouts, most of which end before the call's next look at the
  // writer: every one says the writer is gone, none that it merely timed out.
  for (const int timeout_ms : {0, 1, 5, 11, 16})
    for (int i = 0; i < 8; ++i)
      EXPECT_EQ(dco_client_wait_next(c, timeout_ms, &v), DCO_E_WRITER_GONE) << timeout_ms;
  RingWriter back(path, o);
  publish_pattern(back, 9);
  ASSERT_EQ(dco_client_wait_next(c, 1000, &v), DCO_OK) << dco_client_last_error();
  EXPECT_EQ(v.info.frame_seq, 9u);
  dco_client_close(c);
}

// A daemon stopped and came back at another size, which this client refuses: said at once, then
// at the end of each wait (not in a loop that spins), by latest() every time, until a ring the
// client takes is there.
TEST(ClientCAbi, ARestartedRingTheClientRefusesIsSaidWithoutSpinning) {
  TempDir dir;
  const auto path = dir.path() / "depth.shm";
  const RingOptions o{32, 8};
  auto writer = std::make_unique<RingWriter>(path, o);
  publish_pattern(*writer, 1);
  dco_client_options opt;
  dco_client_options_init(&opt);
  const std::string p = path.string();
  opt.path = p.c_str();
  opt.expected_width = 32;
  opt.expected_height = 8;
  dco_client* c = nullptr;
  ASSERT_EQ(dco_client_open(&opt, &c), DCO_OK) << dco_client_last_error();
  dco_frame_view v;
  dco_frame_view_init(&v);
  ASSERT_EQ(dco_client_wait_next(c, 100, &v), DCO_OK);
  writer.reset();
  writer = std::make_unique<RingWriter>(path, RingOptions{16, 8});
  EXPECT_EQ(dco_client_wait_next(c, 1000, &v), DCO_E_GEOMETRY) << "said at once";
  EXPECT_NE(std::string(dco_client_last_error()).find("16"), std::string::npos)
      << dco_client_last_error();
  int calls = 0;
  const auto start = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - start < std::chrono::milliseconds(300)) {
    EXPECT_EQ(dco_client_wait_next(c, 100, &v), DCO_E_GEOMETRY);
    ++calls;
  }
  EXPECT_LE(calls, 4) << "each call waits its 100 ms";
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(dco_client_latest(c, &v), DCO_E_GEOMETRY) << i;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  // The daemon back at the size asked for, found by latest(): a short wait after it has no
  // newer frame (and no refusal left to say), a longer one the next frame.
  writer.reset();
  RingWriter back(path, o);
  publish_pattern(back, 9);
  std::this_thread::sleep_for(std::chrono::milliseconds(25));
  ASSERT_EQ(dco_client_latest(c, &v), DCO_OK) << dco_client_last_error();
  EXPECT_EQ(v.info.frame_seq, 9u);
  EXPECT_EQ(dco_client_wait_next(c, 0, &v), DCO_E_TIMEOUT) << dco_client_last_error();
  publish_pattern(back, 10);
  ASSERT_EQ(dco_client_wait_next(c, 1000, &v), DCO_OK) << dco_client_last_error();
  EXPECT_EQ(v.info.frame_seq, 10u);
  dco_client_close(c);
}

}  // namespace
}  // namespace dco::ipc::testing
