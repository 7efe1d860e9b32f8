#include <sys/stat.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <random>
#include <thread>

#include "dco/core/error.hpp"
#include "dco/drivers/indemind_source.hpp"
#include "dco/drivers/usb_capture.hpp"
#include "indemind_sim.hpp"
#include "support/error_of.hpp"

namespace dco::drivers {
namespace {

using testing::SimulatedIndemind;
using Fault = SimulatedIndemind::Fault;
using Kind = UsbCaptureRecord::Kind;

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("dco-usbcap-" + std::to_string(::getpid()) + "-" + name))
      .string();
}

std::vector<std::uint8_t> read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_all(const std::string& path, std::span<const std::uint8_t> bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

std::uint64_t fnv1a(const ImageView<const std::uint8_t>& v) {
  std::uint64_t h = 1469598103934665603ull;
  for (int y = 0; y < v.height; ++y)
    for (int x = 0; x < v.width; ++x) h = (h ^ v.row(y)[x]) * 1099511628211ull;
  return h;
}

struct Seen {
  std::int64_t capture_ns;
  std::uint64_t left, right;
  std::size_t imu;
  bool operator==(const Seen&) const = default;
};

class Recorder final : public FrameSink {
 public:
  void on_frame(const StereoFrame& f) override {
    std::lock_guard lock(mutex);
    frames.push_back({f.capture_ns, fnv1a(f.left), fnv1a(f.right), f.imu.size()});
  }
  void on_end() override {
    std::lock_guard lock(mutex);
    ended = true;
  }
  void on_error(const std::string& m) override {
    std::lock_guard lock(mutex);
    error = m;
    ended = true;
  }
  std::size_t count() {
    std::lock_guard lock(mutex);
    return frames.size();
  }
  bool wait_end(double seconds = 60) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < until) {
      {
        std::lock_guard lock(mutex);
        if (ended) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return false;
  }
  std::mutex mutex;
  std::vector<Seen> frames;
  bool ended = false;
  std::string error;
};

std::map<std::string, std::uint64_t> counters_of(const FrameSource& s) {
  std::map<std::string, std::uint64_t> m;
  for (const auto& [k, v] : s.status().counters) m[k] = v;
  // How many frames reached a consumer depends on its pace, not on the bus.
  m.erase("delivered");
  m.erase("delivery_drops");
  return m;
}

IndemindOptions fast_mode() {
  IndemindOptions io;
  io.width = 640;
  io.height = 400;
  io.fps = 200;
  io.stall_ms = 300;
  return io;
}

// The driver on a simulated module (seeded with `seed`) through a recording transport that
// writes `path`; `sim` is the module, owned by the source.
std::unique_ptr<FrameSource> recorded_source(const std::string& path,
                                             const SimulatedIndemind::Options& o,
                                             SimulatedIndemind*& sim,
                                             std::uint64_t max_bytes = kDefaultCaptureMaxBytes) {
  auto sim_owned = std::make_unique<SimulatedIndemind>(o);
  SimulatedIndemind* module = sim_owned.get();
  sim = module;
  IndemindOptions io = fast_mode();
  io.clock = [module] { return module->now_ns(); };
  return open_indemind(
      make_recording_transport(
          std::move(sim_owned), path, [module] { return module->now_ns(); }, max_bytes),
      io, "indemind://");
}

std::unique_ptr<FrameSource> recorded_source(const std::string& path, std::uint32_t seed,
                                             SimulatedIndemind*& sim,
                                             std::uint64_t max_bytes = kDefaultCaptureMaxBytes) {
  SimulatedIndemind::Options o;
  o.seed = seed;
  return recorded_source(path, o, sim, max_bytes);
}

// Streams from a simulated module through a recording transport, injecting a mix of faults (an
// unplug and replug among them); returns the driver's counters.
std::map<std::string, std::uint64_t> record_session(const std::string& path, Recorder& sink,
                                                    int faults) {
  SimulatedIndemind* sim = nullptr;
  auto source = recorded_source(path, 3, sim);
  source->start(sink);
  std::mt19937 rng(9);
  const Fault kinds[] = {Fault::kShortTransfer,    Fault::kLostPayload, Fault::kExtraPayload,
                         Fault::kErrorBit,         Fault::kBadHeader,   Fault::kTornMetadata,
                         Fault::kDuplicateCounter, Fault::kSkipCounter, Fault::kStall,
                         Fault::kSilence,          Fault::kImuShort,    Fault::kImuDuplicate,
                         Fault::kControlBusy,      Fault::kUnplug};
  for (int i = 0; i < faults; ++i) {
    const Fault f = kinds[i % std::size(kinds)];
    int param = 0;
    if (f == Fault::kSkipCounter) param = 1 + static_cast<int>(rng() % 4);
    if (f == Fault::kSilence) param = 500;
    if (f == Fault::kControlBusy) param = 2;
    if (f == Fault::kUnplug) param = 200;
    if (!sim->inject_and_settle(f, param)) {
      ADD_FAILURE() << "stuck after fault " << i;
      break;
    }
  }
  source->stop();
  return counters_of(*source);
}

std::unique_ptr<FrameSource> open_replay(const std::string& path, IndemindOptions io) {
  auto replay = open_usb_replay(path);
  io.clock = [t = replay.get()] { return t->now_ns(); };
  io.lossless = true;
  return open_indemind(std::move(replay), io, "indemind://?replay");
}

// Replays `path` and checks that it gives what the live run gave: every frame the driver
// accepted, in order, each one the live consumer saw byte for byte and with the same capture
// time, and every counter equal. `replayed` gets the replayed frames.
void replay_and_compare(const std::string& path, Recorder& live,
                        const std::map<std::string, std::uint64_t>& live_counters,
                        std::vector<Seen>& replayed) {
  Recorder sink;
  auto source = open_replay(path, fast_mode());
  source->start(sink);
  ASSERT_TRUE(sink.wait_end());
  source->stop();
  EXPECT_EQ(sink.error, "");
  EXPECT_EQ(sink.frames.size(), live_counters.at("frames"));
  EXPECT_EQ(counters_of(*source), live_counters);
  std::size_t j = 0, matched = 0;
  for (const Seen& s : live.frames) {
    while (j < sink.frames.size() && sink.frames[j].capture_ns < s.capture_ns) ++j;
    ASSERT_LT(j, sink.frames.size());
    EXPECT_EQ(sink.frames[j].left, s.left);
    EXPECT_EQ(sink.frames[j].right, s.right);
    EXPECT_EQ(sink.frames[j].capture_ns, s.capture_ns);
    // IMU samples of a frame the live consumer never took went out with the next one it took.
    matched += sink.frames[j].left == s.left && sink.frames[j].right == s.right &&
               sink.frames[j].capture_ns == s.capture_ns;
  }
  EXPECT_EQ(matched, live.frames.size());
  replayed = std::move(sink.frames);
}

TEST(UsbCapture, EveryRecordKindSurvivesTheFile) {
  std::vector<UsbCaptureRecord> in(9);
  in[0].kind = Kind::kList;
  in[0].vendor = 0x05a9;
  in[0].product = 0xf581;
  in[0].devices = {{2, 7, "2-1.4", 5000, "SN1"}, {1, 3, "1-2", 480, ""}};
  in[1].kind = Kind::kOpen;
  in[1].port_path = "2-1.4";
  in[1].outcome = UsbCaptureRecord::Outcome::kFailed;
  in[1].message = "LIBUSB_ERROR_ACCESS";
  in[2].kind = Kind::kClaim;
  in[2].interface = 2;
  in[3].kind = Kind::kControl;
  in[3].request_type = 0xa1;
  in[3].request = 0x81;
  in[3].value = 0x0100;
  in[3].index = 1;
  in[3].length = 34;
  in[3].data = {1, 2, 3};
  in[4].kind = Kind::kClearHalt;
  in[4].endpoint = 0x81;
  in[5].kind = Kind::kStartStream;
  in[5].endpoint = 0x89;
  in[5].type = EndpointType::kInterrupt;
  in[5].size = 64;
  in[5].transfers = 4;
  in[6].kind = Kind::kStopStreams;
  in[6].outcome = UsbCaptureRecord::Outcome::kNoDevice;
  in[6].message = "gone";
  in[7].kind = Kind::kTransfer;
  in[7].flags = UsbCaptureRecord::kInCall;
  in[7].endpoint = 0x81;
  in[7].status = TransferStatus::kOverflow;
  in[7].data = std::vector<std::uint8_t>(1000, 7);
  in[8].kind = Kind::kHotplug;
  std::vector<std::uint8_t> bytes(std::begin(kUsbCaptureMagic), std::end(kUsbCaptureMagic));
  for (std::size_t i = 0; i < in.size(); ++i) {
    in[i].device = static_cast<std::uint16_t>(i);
    in[i].t_ns = 1000 + static_cast<std::int64_t>(i);
    encode_usb_capture_record(in[i], bytes);
  }
  const UsbCapture c = parse_usb_capture(bytes);
  EXPECT_EQ(c.problem, "");
  EXPECT_EQ(c.bytes_read, bytes.size());
  ASSERT_EQ(c.records.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    SCOPED_TRACE(to_string(in[i].kind));
    const UsbCaptureRecord& a = in[i];
    const UsbCaptureRecord& b = c.records[i];
    EXPECT_EQ(b.kind, a.kind);
    EXPECT_EQ(b.flags, a.flags);
    EXPECT_EQ(b.device, a.device);
    EXPECT_EQ(b.t_ns, a.t_ns);
    EXPECT_EQ(b.outcome, a.outcome);
    EXPECT_EQ(b.message, a.message);
    EXPECT_EQ(b.port_path, a.port_path);
    EXPECT_EQ(b.interface, a.interface);
    EXPECT_EQ(b.request_type, a.request_type);
    EXPECT_EQ(b.value, a.value);
    EXPECT_EQ(b.length, a.length);
    EXPECT_EQ(b.endpoint, a.endpoint);
    EXPECT_EQ(b.type, a.type);
    EXPECT_EQ(b.size, a.size);
    EXPECT_EQ(b.transfers, a.transfers);
    EXPECT_EQ(b.status, a.status);
    EXPECT_EQ(b.data, a.data);
    ASSERT_EQ(b.devices.size(), a.devices.size());
    for (std::size_t d = 0; d < a.devices.size(); ++d) {
      EXPECT_EQ(b.devices[d].port_path, a.devices[d].port_path);
      EXPECT_EQ(b.devices[d].serial, a.devices[d].serial);
      EXPECT_EQ(b.devices[d].speed_mbps, a.devices[d].speed_mbps);
      EXPECT_EQ(b.devices[d].bus, a.devices[d].bus);
    }
  }

  // Cut anywhere: the whole records before the cut come back, and the problem says where.
  for (std::size_t cut = sizeof kUsbCaptureMagic; cut < bytes.size(); ++cut) {
    const UsbCapture t = parse_usb_capture(std::span(bytes).first(cut));
    EXPECT_LE(t.bytes_read, cut);
    if (t.bytes_read < cut) {
      EXPECT_NE(t.problem.find("ends inside"), std::string::npos) << cut;
    }
    for (std::size_t i = 0; i < t.records.size(); ++i) EXPECT_EQ(t.records[i].kind, in[i].kind);
  }
  // The file reader, which a replay uses, reads the same records and stops at the same damage.
  const std::string file = temp_path("kinds.usbcap");
  write_all(file, bytes);
  {
    UsbCaptureReader reader(file);
    for (const UsbCaptureRecord& want : in) {
      const auto got = reader.next();
      ASSERT_TRUE(got);
      EXPECT_EQ(got->kind, want.kind);
      EXPECT_EQ(got->data, want.data);
      EXPECT_EQ(got->t_ns, want.t_ns);
    }
    EXPECT_FALSE(reader.next());
    EXPECT_EQ(reader.problem(), "");
  }
  for (const std::size_t cut : {std::size_t{20}, bytes.size() - 5}) {
    write_all(file, std::span(bytes).first(cut));
    UsbCaptureReader reader(file);
    std::size_t n = 0;
    while (reader.next()) ++n;
    const UsbCapture whole = parse_usb_capture(std::span(bytes).first(cut));
    EXPECT_EQ(n, whole.records.size());
    EXPECT_EQ(reader.problem(), whole.problem);
    EXPECT_NE(reader.problem(), "");
  }
  std::remove(file.c_str());

  std::vector<std::uint8_t> damaged = bytes;
  damaged[sizeof kUsbCaptureMagic] = 42;  // no such kind
  EXPECT_NE(parse_usb_capture(damaged).problem.find("record 0 at byte 8 is damaged"),
            std::string::npos);
  const std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', 13, 10, 26, 10, 0};
  EXPECT_NE(testing::error_of([&] { parse_usb_capture(png); }).find("not a dco USB capture"),
            std::string::npos);
}

TEST(UsbCapture, ReplayReproducesARecordedSessionWithFaultsFrameForFrame) {
  const std::string path = temp_path("session.usbcap");
  Recorder live;
  const auto live_counters = record_session(path, live, 42);
  // Virtual time outruns a loaded machine's consumer, which then sees only some of the frames
  // the driver accepted; the replay must still give every accepted one.
  ASSERT_GT(live_counters.at("frames"), 100u);
  ASSERT_GT(live.frames.size(), 10u);
  ASSERT_GE(live_counters.at("reconnects"), 1u);

  std::vector<Seen> replayed;
  ASSERT_NO_FATAL_FAILURE(replay_and_compare(path, live, live_counters, replayed));

  // Cut the file in the middle: the frames before the cut, then an error that says where.
  std::vector<std::uint8_t> bytes = read_all(path);
  const std::string cut_path = temp_path("cut.usbcap");
  write_all(cut_path, std::span(bytes).first(bytes.size() / 2));
  Recorder partial;
  auto cut = open_replay(cut_path, fast_mode());
  cut->start(partial);
  ASSERT_TRUE(partial.wait_end());
  cut->stop();
  EXPECT_NE(partial.error.find("capture ends inside record"), std::string::npos) << partial.error;
  EXPECT_GT(partial.frames.size(), 10u);
  ASSERT_LT(partial.frames.size(), replayed.size());
  for (std::size_t i = 0; i < partial.frames.size(); ++i)
    EXPECT_EQ(partial.frames[i], replayed[i]) << i;

  // Cut during the driver's first calls: the error still says where the capture ends.
  write_all(cut_path, std::span(bytes).first(100));
  const std::string early = testing::error_of([&] { open_replay(cut_path, fast_mode()); });
  EXPECT_NE(early.find("capture ends inside the head of record 3 at byte 94"), std::string::npos)
      << early;

  // A driver asked for another mode leaves the recording at the first control that differs.
  IndemindOptions other = fast_mode();
  other.fps = 100;
  Recorder diverged;
  auto wrong = open_replay(path, other);
  wrong->start(diverged);
  ASSERT_TRUE(diverged.wait_end());
  wrong->stop();
  EXPECT_NE(diverged.error.find("left the capture at record"), std::string::npos) << diverged.error;
  EXPECT_EQ(diverged.frames.size(), 0u);
  std::remove(path.c_str());
  std::remove(cut_path.c_str());
}

// A bridge takes a while to answer each control transfer, and a busy one is asked again 10 ms
// later: the driver's clock moves on through the calls that start a stream, more than stall_ms
// here. A replay whose clock stood still through them judged the first frame after each start
// late and restarted a stream the recording kept.
TEST(UsbCapture, ControlTransfersThatTakeTimeReplayOnTheRecordedClock) {
  const std::string path = temp_path("slow-controls.usbcap");
  Recorder live;
  std::map<std::string, std::uint64_t> live_counters;
  {
    SimulatedIndemind::Options o;
    o.seed = 11;
    o.control_ns = 40'000'000;
    SimulatedIndemind* sim = nullptr;
    auto source = recorded_source(path, o, sim);
    ASSERT_GT(9 * o.control_ns, std::int64_t{fast_mode().stall_ms} * 1'000'000);
    source->start(live);
    ASSERT_TRUE(sim->inject_and_settle(Fault::kStall, 0));
    ASSERT_TRUE(sim->inject_and_settle(Fault::kControlBusy, 2));
    ASSERT_TRUE(sim->inject_and_settle(Fault::kSilence, 500));
    ASSERT_TRUE(sim->inject_and_settle(Fault::kUnplug, 200));
    // Frames a consumer saw after the last reopen, however busy the machine: the replay must
    // give them too.
    const std::size_t before = live.count();
    for (int i = 0; i < 1000 && live.count() < before + 10; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    source->stop();
    live_counters = counters_of(*source);
  }
  // One restart after the stall and one after the silence: none for slow answers.
  EXPECT_EQ(live_counters.at("stream_restarts"), 2u);
  EXPECT_EQ(live_counters.at("reconnects"), 1u);
  ASSERT_GE(live.frames.size(), 10u);

  std::vector<Seen> replayed;
  ASSERT_NO_FATAL_FAILURE(replay_and_compare(path, live, live_counters, replayed));
  std::remove(path.c_str());
}

// Completions flagged as arriving inside a call that never comes: the replay reads ahead only so
// far for the call, then says the capture is damaged, instead of loading the rest of the file and
// ending as if the driver had been stopped.
TEST(UsbCapture, CompletionsWithoutTheirCallAreDamageNotAnEnd) {
  const std::string path = temp_path("plain.usbcap");
  {
    SimulatedIndemind* sim = nullptr;
    Recorder live;
    auto source = recorded_source(path, 5, sim);
    source->start(live);
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (live.count() < 120 && std::chrono::steady_clock::now() < until)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    source->stop();
    ASSERT_GE(live.count(), 120u);
  }
  UsbCapture parsed = parse_usb_capture(read_all(path));
  ASSERT_EQ(parsed.problem, "");
  const std::size_t from = parsed.records.size() / 10;
  std::size_t flagged_bytes = 0;
  for (std::size_t i = from; i < parsed.records.size(); ++i)
    if (parsed.records[i].kind == Kind::kTransfer) {
      parsed.records[i].flags |= UsbCaptureRecord::kInNextCall;
      flagged_bytes += parsed.records[i].data.size();
    }
  ASSERT_GT(flagged_bytes, std::size_t{33} << 20);
  std::vector<std::uint8_t> flagged(kUsbCaptureMagic, kUsbCaptureMagic + sizeof kUsbCaptureMagic);
  for (const UsbCaptureRecord& r : parsed.records) encode_usb_capture_record(r, flagged);
  write_all(path, flagged);
  Recorder replayed;
  auto damaged = open_replay(path, fast_mode());
  damaged->start(replayed);
  ASSERT_TRUE(replayed.wait_end());
  damaged->stop();
  EXPECT_NE(replayed.error.find("is damaged: more than 32 MiB of completions"), std::string::npos)
      << replayed.error;
  std::remove(path.c_str());
}

// How many hotplug notes the capture has inside a control transfer: flagged, and followed by a
// control record after at most more flagged completions.
std::size_t hotplugs_inside_controls(const std::string& path) {
  const std::vector<std::uint8_t> bytes = read_all(path);
  const UsbCapture c = parse_usb_capture(bytes);
  EXPECT_EQ(c.problem, "");
  std::size_t n = 0;
  for (std::size_t i = 0; i < c.records.size(); ++i) {
    if (c.records[i].kind != Kind::kHotplug ||
        !(c.records[i].flags & UsbCaptureRecord::kInNextCall))
      continue;
    std::size_t k = i + 1;
    while (k < c.records.size() && (c.records[k].flags & UsbCaptureRecord::kInNextCall)) ++k;
    n += k < c.records.size() && c.records[k].kind == Kind::kControl;
  }
  return n;
}

TEST(UsbCapture, HotplugNotesInsideControlTransfersReplayInsideThem) {
  const std::string path = temp_path("hotplug-in-control.usbcap");
  Recorder live;
  std::map<std::string, std::uint64_t> live_counters;
  {
    SimulatedIndemind* sim = nullptr;
    auto source = recorded_source(path, 5, sim);
    source->start(live);
    // A second module plugged in while the driver reads the flash of the one it reopens...
    sim->hotplug_in_control(3);
    ASSERT_TRUE(sim->inject_and_settle(Fault::kUnplug, 200));
    // ...and a flaky cable that drops the module while the driver reads its flash: that reopen
    // fails, the next one (after the note) finds it back.
    sim->unplug_in_control(4, 100);
    ASSERT_TRUE(sim->inject_and_settle(Fault::kUnplug, 200));
    ASSERT_TRUE(sim->inject_and_settle(Fault::kControlBusy, 2));
    // Frames after the last reopen, however busy the machine: the replay must give them too.
    const std::size_t before = live.count();
    for (int i = 0; i < 1000 && live.count() < before + 10; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    source->stop();
    live_counters = counters_of(*source);
    EXPECT_EQ(sim->record().control_hotplugs, 4u);
  }
  EXPECT_EQ(live_counters.at("reconnects"), 2u);
  EXPECT_EQ(live_counters.at("disconnects"), 2u);
  ASSERT_GE(live.frames.size(), 10u);
  EXPECT_EQ(hotplugs_inside_controls(path), 4u);

  std::vector<Seen> replayed;
  ASSERT_NO_FATAL_FAILURE(replay_and_compare(path, live, live_counters, replayed));
  std::remove(path.c_str());
}

// A bus whose synchronous calls handle events, as libusb's do: each control transfer and
// clear_halt() completes a transfer of the running stream and raises the hotplug note before it
// answers, and so does each handle_events(). Its clock moves 1 ms per round of events.
class EventfulBus final : public UsbTransport {
 public:
  std::vector<UsbDeviceInfo> list(std::uint16_t, std::uint16_t) override {
    return {{1, 4, "1-2", 480, "EV1"}};
  }
  std::unique_ptr<UsbDevice> open(const UsbDeviceInfo& d) override {
    return std::make_unique<Device>(*this, d);
  }
  void watch_hotplug(std::uint16_t, std::uint16_t, std::function<void()> on_change) override {
    hotplug_ = std::move(on_change);
  }
  void handle_events(std::chrono::milliseconds) override { run_events(); }
  std::int64_t now_ns() const { return now_; }

 private:
  class Device final : public UsbDevice {
   public:
    Device(EventfulBus& bus, UsbDeviceInfo info) : bus_(bus), info_(std::move(info)) {}
    const UsbDeviceInfo& info() const override { return info_; }
    void claim_interface(int) override {}
    std::size_t control(std::uint8_t, std::uint8_t, std::uint16_t, std::uint16_t,
                        std::span<std::uint8_t> data, std::chrono::milliseconds) override {
      bus_.run_events();
      std::fill(data.begin(), data.end(), std::uint8_t{0x5a});
      return data.size();
    }
    void clear_halt(std::uint8_t) override {
      bus_.run_events();
      throw UsbError("clear_halt: the device is gone", true);
    }
    void start_in_stream(std::uint8_t, EndpointType, std::size_t, int,
                         TransferCallback on_complete) override {
      bus_.stream_ = std::move(on_complete);
    }
    void stop_streams() override { bus_.stream_ = nullptr; }
    int transfers_in_flight() const override { return bus_.stream_ ? 1 : 0; }

   private:
    EventfulBus& bus_;
    UsbDeviceInfo info_;
  };

  void run_events() {
    now_ += 1'000'000;
    if (stream_) {
      const std::uint8_t b = next_byte_++;
      const std::array<std::uint8_t, 3> bytes = {b, b, b};
      stream_(TransferStatus::kCompleted, bytes);
    }
    if (hotplug_) hotplug_();
  }

  TransferCallback stream_;
  std::function<void()> hotplug_;
  std::int64_t now_ = 1'000'000'000;
  std::uint8_t next_byte_ = 1;
};

// Makes the same calls on any bus; returns what reached the caller, and inside which call.
std::vector<std::string> drive(UsbTransport& bus) {
  std::vector<std::string> seen;
  std::string inside;
  bus.watch_hotplug(1, 2, [&] { seen.push_back(inside + "hotplug"); });
  const std::vector<UsbDeviceInfo> found = bus.list(1, 2);
  std::unique_ptr<UsbDevice> device = bus.open(found.at(0));
  device->start_in_stream(0x81, EndpointType::kBulk, 64, 1,
                          [&](TransferStatus status, std::span<const std::uint8_t> data) {
                            seen.push_back(inside + "transfer " + to_string(status) + " " +
                                           std::to_string(data.size()) + "x" +
                                           std::to_string(data.empty() ? 0 : data[0]));
                          });
  bus.handle_events(std::chrono::milliseconds(20));
  std::array<std::uint8_t, 4> reply{};
  inside = "in control: ";
  const std::size_t n = device->control(0xc0, 1, 2, 3, reply, std::chrono::milliseconds(100));
  inside.clear();
  seen.push_back("control " + std::to_string(n) + "x" + std::to_string(reply[3]));
  inside = "in clear_halt: ";
  try {
    device->clear_halt(0x81);
    seen.push_back("clear_halt");
  } catch (const UsbError& e) {
    seen.push_back(std::string("clear_halt failed, gone: ") + (e.no_device() ? "yes" : "no"));
  }
  inside.clear();
  bus.handle_events(std::chrono::milliseconds(20));
  device->stop_streams();
  return seen;
}

TEST(UsbCapture, CompletionsInsideACallReachTheDriverInsideItOnReplay) {
  const std::string path = temp_path("events-in-calls.usbcap");
  auto bus = std::make_unique<EventfulBus>();
  EventfulBus* clock = bus.get();
  std::vector<std::string> live;
  {
    auto recording =
        make_recording_transport(std::move(bus), path, [clock] { return clock->now_ns(); });
    live = drive(*recording);
  }
  const std::vector<std::string> want = {"transfer completed 3x1",
                                         "hotplug",
                                         "in control: transfer completed 3x2",
                                         "in control: hotplug",
                                         "control 4x90",
                                         "in clear_halt: transfer completed 3x3",
                                         "in clear_halt: hotplug",
                                         "clear_halt failed, gone: yes",
                                         "transfer completed 3x4",
                                         "hotplug"};
  ASSERT_EQ(live, want);

  auto replay = open_usb_replay(path);
  std::vector<std::string> replayed;
  try {
    replayed = drive(*replay);
  } catch (const UsbError& e) {
    ADD_FAILURE() << e.what();
  }
  EXPECT_EQ(replayed, live);
  EXPECT_TRUE(replay->finished());
  EXPECT_EQ(replay->finish_error(), "");
  std::remove(path.c_str());
}

TEST(UsbCapture, UriRefusesBadCapturesWithOneLine) {
  const std::string missing = temp_path("missing.usbcap");
  auto open = [](const std::string& text) { return open_source(text); };
  EXPECT_NE(testing::error_of([&] { open("indemind://?replay=" + missing); }).find("cannot open"),
            std::string::npos);
  const std::string junk = temp_path("junk.usbcap");
  write_all(junk, std::vector<std::uint8_t>{'h', 'e', 'l', 'l', 'o'});
  EXPECT_NE(
      testing::error_of([&] { open("indemind://?replay=" + junk); }).find("not a dco USB capture"),
      std::string::npos);
  EXPECT_NE(testing::error_of([&] {
              open("indemind://?replay=a&record=b");
            }).find("record and replay exclude each other"),
            std::string::npos);
  const std::string empty = temp_path("empty.usbcap");
  write_all(empty, std::span(reinterpret_cast<const std::uint8_t*>(kUsbCaptureMagic), 8));
  EXPECT_NE(
      testing::error_of([&] { open("indemind://?replay=" + empty); }).find("holds no records"),
      std::string::npos);
  EXPECT_NE(testing::error_of([] {
              make_recording_transport(std::make_unique<SimulatedIndemind>(),
                                       "/nonexistent-dir/x.usbcap");
            }).find("'/nonexistent-dir/x.usbcap': cannot create"),
            std::string::npos);
  // A pipe would block the open (until a writer or reader comes), with the service starting.
  const std::string fifo = temp_path("capture.fifo");
  std::remove(fifo.c_str());
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_NE(testing::error_of([&] { open("indemind://?replay=" + fifo); }).find("a pipe"),
            std::string::npos);
  EXPECT_NE(testing::error_of([&] {
              make_recording_transport(std::make_unique<SimulatedIndemind>(), fifo);
            }).find("a pipe"),
            std::string::npos);
  std::remove(fifo.c_str());
  std::remove(junk.c_str());
  std::remove(empty.c_str());
}

// record= in a service's configuration: each restart records anew. The session that recorded a
// fault (a capture that streamed) is kept as FILE.1; the short captures of restarts that found no
// module are written over and never push it out.
TEST(UsbCapture, ARecordingKeepsTheLastCaptureThatStreamed) {
  const std::string path = temp_path("kept.usbcap"), kept = path + ".1";
  std::remove(kept.c_str());
  const std::vector<char> streamed(kKeptCaptureBytes + 1, 'x');
  std::ofstream(path, std::ios::binary).write(streamed.data(), std::streamsize(streamed.size()));
  for (int restart = 0; restart < 3; ++restart)
    make_recording_transport(std::make_unique<SimulatedIndemind>(), path);
  EXPECT_EQ(read_all(kept).size(), streamed.size()) << "the capture that streamed";
  EXPECT_LT(read_all(path).size(), 1024u) << "the last restart's";
  std::remove(path.c_str());
  std::remove(kept.c_str());
}

// A capture runs at tens of megabytes a second: at its size limit it stops after a whole record
// while the camera streams on, and what it holds replays to a clean end.
TEST(UsbCapture, ARecordingStopsAtItsSizeLimitAndReplaysAsFarAsItGoes) {
  const std::string path = temp_path("limited.usbcap");
  constexpr std::uint64_t kLimit = 3u << 20;  // six 640x400 frames
  Recorder live;
  SimulatedIndemind* sim = nullptr;
  auto source = recorded_source(path, 5, sim, kLimit);
  source->start(live);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (live.count() < 40 && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  source->stop();
  ASSERT_GE(live.count(), 40u) << "the camera streams on past the limit";
  const std::uint64_t size = read_all(path).size();
  EXPECT_LE(size, kLimit);
  EXPECT_GT(size, kLimit - (1u << 20));
  Recorder replayed;
  auto replay = open_replay(path, fast_mode());
  replay->start(replayed);
  ASSERT_TRUE(replayed.wait_end());
  replay->stop();
  EXPECT_EQ(replayed.error, "");
  EXPECT_GE(replayed.frames.size(), 2u);
  EXPECT_LT(replayed.frames.size(), 10u);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace dco::drivers
