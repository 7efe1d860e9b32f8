#include "indemind_sim.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>

#include "dco/indemind/frame_metadata.hpp"
#include "dco/indemind/imu_report.hpp"
#include "dco/indemind/uvc_payload.hpp"
#include "dco/indemind/xu_task.hpp"
#include "scene_render.hpp"

namespace dco::testing {

using drivers::TransferStatus;
using drivers::UsbError;
using indemind::StreamMode;

namespace {

std::int64_t monotonic_now() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// One scheduled transfer completion.
struct Completion {
  std::int64_t at = 0;
  std::uint8_t endpoint = 0;
  int generation = 0;  // of the stream it belongs to; stale ones are dropped
  TransferStatus status = TransferStatus::kCompleted;
  std::vector<std::uint8_t> bytes;
  bool unplug = false;            // not a completion: the module goes away at this time
  bool completes_intact = false;  // the last payload of a sound frame
  std::uint64_t counter = 0;      // of the frame it belongs to
  std::int64_t replug_after_ns = 0;
};

}  // namespace

const char* SimulatedIndemind::name(Fault f) {
  static const char* const names[kFaultKinds] = {
      "short transfer",  "lost payload",      "extra payload",   "error bit",     "bad header",
      "torn metadata",   "duplicate counter", "skipped counter", "stall",         "silence",
      "imu short",       "imu duplicate",     "control busy",    "unplug",        "counter restart",
      "corrupt counter", "empty payload",     "imu bad ticks",   "imu tick race", "imu stall",
      "imu silence"};
  return names[static_cast<int>(f)];
}

struct SimulatedIndemind::Stream {
  bool active = false;
  int generation = 0;
  std::size_t size = 0;
  int transfers = 0;
  drivers::TransferCallback callback;
};

struct SimulatedIndemind::State {
  Options opt;
  mutable std::mutex mu;
  std::mt19937 rng;
  std::int64_t now = 1'000'000'000;  // virtual clock
  bool present = true;
  std::int64_t replug_at = -1;
  bool hotplug_note = false;
  std::function<void()> hotplug;
  int session = 0;  // bumps at each plug-in: old device handles die
  bool opened = false;

  indemind::StreamControl probe;
  bool committed = false;
  StreamMode mode;

  std::vector<std::uint8_t> flash_header, blob, xu_reply;
  int busy_left = 0;
  int hotplugs_in_control = 0;
  int unplug_in_control = -1;  // control transfers before the one that meets an unplug
  std::int64_t unplug_in_control_replug_ns = 0;

  Stream video, imu;
  int generation = 0;
  bool halted = false, imu_halted = false;
  std::int64_t imu_silent_until = 0;
  std::int64_t silence_until = 0;

  std::map<int, std::vector<std::uint8_t>> rendered;
  std::vector<std::uint8_t> frame;
  std::uint64_t counter = 0;       // extended: low 16 bits go on the wire
  std::uint64_t last_intact = 0;   // counter of the last intact frame this plug-in session
  std::int64_t last_video_at = 0;  // bulk data arrives in order
  int hide_frames = 0;
  std::int64_t replugged_at = -1;
  bool has_intact = false;
  std::int64_t next_frame = -1, frame_start = 0;
  std::int64_t next_imu = -1;
  int imu_hz = 1000;
  std::deque<Completion> pending;  // sorted by time
  std::deque<std::pair<Fault, int>> frame_faults;
  int imu_short = 0, imu_duplicate = 0, imu_bad_ticks = 0, imu_race = 0, imu_stall = 0;
  std::uint32_t imu_bad_ticks_value = 0xFFFFFFFFu;
  int imu_silence_ms = 0;
  std::uint16_t last_imu_counter = 0;
  std::uint32_t last_imu_ticks = 0;
  std::map<std::uint64_t, std::int64_t> starts;
  Record rec;

  explicit State(Options o) : opt(std::move(o)), rng(opt.seed) {
    if (opt.calibration.left.width == 0) opt.calibration = sim_calibration();
    blob = indemind::encode_calibration_blob(opt.calibration);
    flash_header.assign(indemind::kFlashHeaderSize, 0);
    const auto n = static_cast<std::uint32_t>(blob.size());
    for (int i = 0; i < 4; ++i) flash_header[i] = static_cast<std::uint8_t>(n >> (8 * i));
    counter = opt.first_counter;
    frame_start = now;
  }

  std::int64_t period_ns() const {
    return static_cast<std::int64_t>(1e9 / mode.fps * (1.0 + opt.clock_skew_ppm * 1e-6));
  }

  void schedule(Completion c) {
    auto it = std::upper_bound(pending.begin(), pending.end(), c.at,
                               [](std::int64_t t, const Completion& x) { return t < x.at; });
    pending.insert(it, std::move(c));
  }

  std::int64_t delay() {
    std::uniform_int_distribution<std::int64_t> j(0, opt.jitter_ns);
    return opt.latency_ns + j(rng);
  }

  const std::vector<std::uint8_t>& image(int width, int height) {
    auto& r = rendered[width];
    if (r.empty()) r = render_side_by_side(opt.calibration, width, height, kBoxDepthM, kWallDepthM);
    return r;
  }

  void generate_frame();
  void emit(std::int64_t start, bool has_fault, Fault fault, int param, bool sound);
  void generate_imu();
  void unplug_now(std::int64_t replug_after_ns, std::vector<Completion>& out);
};

void SimulatedIndemind::State::generate_frame() {
  const std::int64_t start = next_frame;
  next_frame += period_ns();
  Fault fault{};
  int param = 0;
  bool has_fault = false;
  if (!frame_faults.empty()) {
    std::tie(fault, param) = frame_faults.front();
    frame_faults.pop_front();
    has_fault = true;
    ++rec.injected[static_cast<int>(fault)];
  }
  if (has_fault && fault == Fault::kDuplicateCounter) {
    // The previous frame goes out again, squeezed in before this slot's own frame.
    emit(start, false, {}, 0, false);
    has_fault = false;
  }
  ++counter;
  if (has_fault && fault == Fault::kCounterRestart) {
    // Extended values keep rising (they key the frame starts); the wire goes `back` back.
    const int back = param != 0 ? param : 1000;
    counter += static_cast<std::uint64_t>(65536 - back);
    has_intact = false;  // frames lost across a restart are not counted
  }
  if (has_fault && fault == Fault::kSkipCounter) hide_frames += param;  // captured, never sent
  if (has_fault && fault == Fault::kSilence)
    silence_until = start + std::int64_t{param} * 1'000'000;
  if (start < silence_until && !opt.counter_counts_unsent_frames) {
    --counter;  // not counted: the next frame sent takes this number
    return;
  }
  frame_start = start;
  starts[counter] = start;
  if (starts.size() > 8192) starts.erase(starts.begin());
  if (halted || start < silence_until || hide_frames > 0) {
    if (hide_frames > 0) --hide_frames;
    ++rec.frames_hidden;
    return;
  }
  const bool harmless = !has_fault || fault == Fault::kSkipCounter || fault == Fault::kSilence ||
                        fault == Fault::kCounterRestart || fault == Fault::kEmptyPayload;
  emit(start, has_fault, fault, param, harmless);
}

void SimulatedIndemind::State::emit(std::int64_t start, bool has_fault, Fault fault, int param,
                                    bool sound) {
  const int w = mode.width, h = mode.height;
  frame = image(w, h);
  indemind::FrameMetadata meta;
  const int off = has_fault && fault == Fault::kCorruptCounter ? (param != 0 ? param : 50) : 0;
  meta.counter = static_cast<std::uint16_t>(counter + static_cast<std::uint64_t>(off));
  meta.exposure_raw = 549;  // 5 ms
  meta.timer_raw = static_cast<std::uint32_t>(start / 125'000);
  meta.torn = has_fault && fault == Fault::kTornMetadata;
  indemind::write_frame_metadata(
      std::span(frame).subspan(std::size_t(h - 1) * 2 * w, std::size_t(2) * w), meta);

  // Cut into payloads: header + as many image bytes as fit in one transfer.
  const bool fid = (counter & 1) != 0;
  const std::size_t room = probe.max_payload_transfer_size - 2;
  const std::size_t n = (frame.size() + room - 1) / room;
  const std::size_t victim = n / 2;
  const std::int64_t readout = period_ns() / 2;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t begin = i * room, len = std::min(room, frame.size() - begin);
    Completion c;
    c.at =
        start + readout * static_cast<std::int64_t>(i + 1) / static_cast<std::int64_t>(n) + delay();
    c.at = std::max(c.at, last_video_at + 1);
    last_video_at = c.at;
    c.endpoint = indemind::kVideoEndpoint;
    c.generation = video.generation;
    const bool last = i + 1 == n;
    c.bytes =
        indemind::make_uvc_header(fid, last, has_fault && fault == Fault::kErrorBit && i == victim);
    c.bytes.insert(c.bytes.end(), frame.begin() + static_cast<std::ptrdiff_t>(begin),
                   frame.begin() + static_cast<std::ptrdiff_t>(begin + len));
    if (has_fault && i == victim) {
      switch (fault) {
        case Fault::kShortTransfer:
          c.bytes.resize(c.bytes.size() / 2);
          break;
        case Fault::kLostPayload:
          continue;
        case Fault::kBadHeader:
          c.bytes[0] = 0xff;
          break;
        case Fault::kStall:
          c.status = TransferStatus::kStall;
          c.bytes.clear();
          break;
        case Fault::kUnplug: {
          Completion u;
          u.at = c.at;
          u.unplug = true;
          u.replug_after_ns = std::int64_t{param} * 1'000'000;
          schedule(std::move(u));
          continue;
        }
        case Fault::kExtraPayload: {
          Completion extra = c;
          schedule(std::move(extra));
          c.at = last_video_at = c.at + 1;
          break;
        }
        case Fault::kEmptyPayload: {
          Completion empty = c;
          empty.bytes.clear();
          empty.at = last_video_at = c.at + 1;
          schedule(std::move(c));
          c = std::move(empty);
          break;
        }
        default:
          break;
      }
    }
    c.completes_intact = last && sound;
    c.counter = counter;
    schedule(std::move(c));
  }
  ++rec.frames_sent;
}

void SimulatedIndemind::State::generate_imu() {
  const std::int64_t t = next_imu;
  next_imu += 1'000'000'000 / imu_hz;
  indemind::ImuReport r;
  r.frame_counter = static_cast<std::uint16_t>(counter);
  const double since = static_cast<double>(t - frame_start) / (1.0 + opt.clock_skew_ppm * 1e-6);
  r.ticks = static_cast<std::uint32_t>(std::max(0.0, since) * indemind::kImuTicksPerSecond / 1e9);
  // Read and never sent; the IMU faults wait for a report that goes out.
  if (t < imu_silent_until) return;
  if (imu_silence_ms > 0) {
    ++rec.injected[static_cast<int>(Fault::kImuSilence)];
    imu_silent_until = t + std::int64_t{imu_silence_ms} * 1'000'000;
    imu_silence_ms = 0;
    return;
  }
  if (imu_race > 0 && r.frame_counter != last_imu_counter) {
    // The counter is the new frame's, the ticks run on from the last report of the old one.
    --imu_race;
    ++rec.injected[static_cast<int>(Fault::kImuTickRace)];
    r.ticks = last_imu_ticks + static_cast<std::uint32_t>(indemind::kImuTicksPerSecond / imu_hz);
  }
  last_imu_counter = r.frame_counter;
  last_imu_ticks = r.ticks;
  if (imu_bad_ticks > 0) {
    --imu_bad_ticks;
    ++rec.injected[static_cast<int>(Fault::kImuBadTicks)];
    r.ticks = imu_bad_ticks_value;
  }
  r.accel_raw = {20, -41, 2048};  // ±16 g range: 2048 LSB/g
  r.gyro_raw = {8, -4, 2};        // ±2000 °/s: 16.4 LSB/(°/s)
  r.temperature_raw = 3268;       // 35 °C
  const auto bytes = indemind::encode_imu_report(r);
  Completion c;
  c.at = t + (opt.imu_latency_ns >= 0 ? opt.imu_latency_ns : opt.latency_ns / 4);
  c.endpoint = indemind::kImuEndpoint;
  c.generation = imu.generation;
  c.bytes.assign(bytes.begin(), bytes.end());
  ++rec.imu_reports;
  if (imu_stall > 0) {
    --imu_stall;
    ++rec.injected[static_cast<int>(Fault::kImuStall)];
    c.status = TransferStatus::kStall;
    c.bytes.clear();
  } else if (imu_short > 0) {
    --imu_short;
    ++rec.injected[static_cast<int>(Fault::kImuShort)];
    c.bytes.resize(20);
  } else if (imu_duplicate > 0) {
    --imu_duplicate;
    ++rec.injected[static_cast<int>(Fault::kImuDuplicate)];
    Completion again = c;
    again.at += 1;
    schedule(std::move(again));
  }
  schedule(std::move(c));
}

void SimulatedIndemind::State::unplug_now(std::int64_t replug_after_ns,
                                          std::vector<Completion>& out) {
  present = false;
  ++session;
  hotplug_note = true;
  replug_at = replug_after_ns > 0 ? now + replug_after_ns : -1;
  for (Stream* s : {&video, &imu}) {
    if (!s->active) continue;
    for (int i = 0; i < s->transfers; ++i) {
      Completion c;
      c.endpoint = s == &video ? indemind::kVideoEndpoint : indemind::kImuEndpoint;
      c.generation = s->generation;
      c.status = TransferStatus::kNoDevice;
      out.push_back(std::move(c));
    }
  }
  pending.clear();
  next_frame = next_imu = -1;
  halted = imu_halted = false;
  imu_silent_until = 0;
  committed = false;
  has_intact = false;
}

// An opened module. Every call checks that the module is still the one that was opened.
class SimulatedIndemind::Device final : public drivers::UsbDevice {
 public:
  Device(std::shared_ptr<State> s, drivers::UsbDeviceInfo info, int session)
      : s_(std::move(s)), info_(std::move(info)), session_(session) {}
  ~Device() override {
    stop_streams();
    std::lock_guard lock(s_->mu);
    s_->opened = false;
  }

  const drivers::UsbDeviceInfo& info() const override { return info_; }

  void claim_interface(int number) override {
    std::lock_guard lock(s_->mu);
    check_alive();
    if (number < 0 || number > 2)
      throw UsbError("claim: no interface " + std::to_string(number), false);
  }

  std::size_t control(std::uint8_t type, std::uint8_t request, std::uint16_t value,
                      std::uint16_t index, std::span<std::uint8_t> data,
                      std::chrono::milliseconds) override {
    events_inside_control();
    std::lock_guard lock(s_->mu);
    State& s = *s_;
    // The bridge answers after a while; the module's clock runs on meanwhile.
    if (!s.opt.pace_real_time) s.now += s.opt.control_ns;
    check_alive();
    const bool in = type & 0x80;
    if (index == indemind::kVideoStreamingInterface &&
        (value >> 8 == indemind::kVsProbeControl || value >> 8 == indemind::kVsCommitControl)) {
      if (!in && request == indemind::kUvcSetCur) {
        auto c = indemind::decode_stream_control(data);
        if (!c) throw UsbError("probe: short control", false);
        if (value >> 8 == indemind::kVsProbeControl) {
          s.probe = negotiate(*c);
        } else {
          if (c->frame_index != s.probe.frame_index || c->frame_interval != s.probe.frame_interval)
            throw UsbError("commit does not match probe (stall)", false);
          s.mode = mode_of(s.probe);
          s.committed = true;
          ++s.rec.commits;
        }
        return data.size();
      }
      if (in && request == indemind::kUvcGetCur) {
        const auto bytes = indemind::encode_stream_control(s.probe);
        const std::size_t n = std::min(data.size(), bytes.size());
        std::copy_n(bytes.begin(), n, data.begin());
        return n;
      }
    }
    if (index == (indemind::kXuUnit << 8) && value == (indemind::kXuSelector << 8)) {
      if (!in && request == indemind::kUvcSetCur) return xu_set(data);
      if (in && request == indemind::kUvcGetCur) return xu_get(data);
    }
    throw UsbError("control transfer stalled", false);
  }

  void clear_halt(std::uint8_t endpoint) override {
    std::lock_guard lock(s_->mu);
    check_alive();
    if (endpoint == indemind::kVideoEndpoint) s_->halted = false;
    if (endpoint == indemind::kImuEndpoint) s_->imu_halted = false;
  }

  void start_in_stream(std::uint8_t endpoint, drivers::EndpointType, std::size_t size,
                       int transfers, drivers::TransferCallback on_complete) override {
    std::lock_guard lock(s_->mu);
    check_alive();
    State& s = *s_;
    Stream& st = endpoint == indemind::kVideoEndpoint ? s.video : s.imu;
    if (st.active) throw UsbError("stream already running", false);
    if (endpoint == indemind::kVideoEndpoint && !s.committed)
      throw UsbError("bulk read before commit", false);
    st.active = true;
    st.generation = ++s.generation;
    st.size = size;
    st.transfers = transfers;
    st.callback = std::move(on_complete);
    s.rec.transfers_submitted += static_cast<std::uint64_t>(transfers);
    if (endpoint == indemind::kVideoEndpoint) {
      // The sensor runs whether or not anyone reads: frames missed while the stream was off
      // still moved the counter.
      const std::int64_t p = s.period_ns();
      const std::int64_t k = s.now > s.frame_start ? (s.now - s.frame_start) / p : 0;
      if (s.opt.counter_counts_unsent_frames) {
        s.counter += static_cast<std::uint64_t>(k);
        s.rec.frames_hidden += static_cast<std::uint64_t>(k);
      }
      s.frame_start += k * p;
      s.next_frame = s.frame_start + p;
      if (s.opt.counter_restarts_with_stream) {
        // Above every value so far on the extended scale; the wire starts again.
        s.counter = ((s.counter >> 16) + 1) << 16 | s.opt.first_counter;
      }
      // The driver starts a new time line with each stream: frames missed across a restart are
      // not counted as lost.
      s.has_intact = false;
    } else {
      s.next_imu = s.now + 1'000'000'000 / s.imu_hz;
    }
  }

  void stop_streams() override {
    std::vector<std::pair<drivers::TransferCallback, int>> cancelled;
    {
      std::lock_guard lock(s_->mu);
      for (Stream* st : {&s_->video, &s_->imu}) {
        if (!st->active) continue;
        st->active = false;
        // Transfers of a stream whose module vanished already completed with kNoDevice.
        if (session_ == s_->session) cancelled.emplace_back(st->callback, st->transfers);
        s_->rec.transfers_completed += static_cast<std::uint64_t>(st->transfers);
        st->transfers = 0;
      }
      if (session_ == s_->session) {
        s_->next_frame = s_->next_imu = -1;
        s_->committed = false;
      }
    }
    for (auto& [cb, n] : cancelled)
      for (int i = 0; i < n; ++i) cb(TransferStatus::kCancelled, {});
  }

  int transfers_in_flight() const override {
    std::lock_guard lock(s_->mu);
    return (s_->video.active ? s_->video.transfers : 0) + (s_->imu.active ? s_->imu.transfers : 0);
  }

 private:
  void check_alive() const {
    if (!s_->present || session_ != s_->session)
      throw UsbError("the device is gone (LIBUSB_ERROR_NO_DEVICE)", true);
  }

  // The hotplug notes hotplug_in_control() and unplug_in_control() asked for, raised while the
  // transfer runs, as libusb does; outside the lock, as handle_events() runs callbacks.
  void events_inside_control() {
    std::function<void()> note;
    {
      std::lock_guard lock(s_->mu);
      State& s = *s_;
      bool raise = false;
      if (s.hotplugs_in_control > 0) {
        --s.hotplugs_in_control;
        raise = true;
      }
      if (s.unplug_in_control >= 0 && s.unplug_in_control-- == 0 && s.present &&
          session_ == s.session) {
        const bool note_pending = s.hotplug_note;
        std::vector<Completion> out;
        s.unplug_now(s.unplug_in_control_replug_ns, out);
        // Transfers in flight complete with the next handle_events(); the note goes out here.
        for (Completion& c : out) {
          c.at = s.now;
          s.pending.push_front(std::move(c));
        }
        s.hotplug_note = note_pending;
        raise = true;
      }
      if (raise && s.hotplug) {
        ++s.rec.control_hotplugs;
        note = s.hotplug;
      }
    }
    if (note) note();
  }

  indemind::StreamControl negotiate(const indemind::StreamControl& asked) const {
    int width = asked.frame_index == 1 ? 1280 : 640;
    int fps = static_cast<int>(std::lround(1e7 / std::max<std::uint32_t>(asked.frame_interval, 1)));
    std::string why;
    auto m = indemind::find_stream_mode(width, width == 1280 ? 800 : 400, fps,
                                        s_->opt.usb_speed_mbps, why);
    // Like a real device: an impossible request gets the nearest mode it can do.
    const StreamMode mode = m ? *m : indemind::default_stream_mode(s_->opt.usb_speed_mbps);
    indemind::StreamControl c = asked;
    c.frame_index = mode.frame_index;
    c.frame_interval = mode.interval_100ns();
    c.max_video_frame_size = static_cast<std::uint32_t>(mode.frame_bytes());
    c.max_payload_transfer_size = s_->opt.payload_bytes;
    c.clock_frequency = 150'000'000;
    return c;
  }

  static StreamMode mode_of(const indemind::StreamControl& c) {
    StreamMode m;
    m.frame_index = c.frame_index;
    m.width = c.frame_index == 1 ? 1280 : 640;
    m.height = c.frame_index == 1 ? 800 : 400;
    m.fps = static_cast<int>(std::lround(1e7 / c.frame_interval));
    return m;
  }

  std::size_t xu_set(std::span<std::uint8_t> data) {
    State& s = *s_;
    indemind::XuCommand cmd;
    if (!indemind::decode_xu_command(data, cmd)) throw UsbError("xu: malformed command", false);
    s.xu_reply.assign(indemind::kXuReplyDataOffset, 0);
    s.xu_reply[0] = 0x56;
    if (cmd.target == static_cast<std::uint8_t>(indemind::XuTarget::kFlash)) {
      if (!cmd.read) {
        ++s.rec.flash_writes;
        return data.size();
      }
      for (std::uint32_t i = 0; i < cmd.length; ++i) {
        const std::uint32_t a = cmd.address + i;
        std::uint8_t b = 0xff;
        if (a >= indemind::kFlashHeaderAddress &&
            a < indemind::kFlashHeaderAddress + s.flash_header.size())
          b = s.flash_header[a - indemind::kFlashHeaderAddress];
        else if (a >= indemind::kFlashBlobAddress &&
                 a < indemind::kFlashBlobAddress + s.blob.size())
          b = s.blob[a - indemind::kFlashBlobAddress];
        s.xu_reply.push_back(b);
      }
    } else if (!cmd.read && cmd.address >= indemind::kImuRegisterBase && !cmd.payload.empty()) {
      const int reg = static_cast<int>(cmd.address - indemind::kImuRegisterBase);
      s.rec.imu_registers[reg] = cmd.payload[0];
      if (reg == 0x19) s.imu_hz = 1000 / (cmd.payload[0] + 1);
    }
    return data.size();
  }

  std::size_t xu_get(std::span<std::uint8_t> data) {
    State& s = *s_;
    if (s.busy_left > 0) {
      --s.busy_left;
      ++s.rec.busy_answers;
      if (!data.empty()) data[0] = 0x55;
      return std::min<std::size_t>(data.size(), indemind::kXuReplyDataOffset);
    }
    const std::size_t n = std::min(data.size(), s.xu_reply.size());
    std::copy_n(s.xu_reply.begin(), n, data.begin());
    return n;
  }

  std::shared_ptr<State> s_;
  drivers::UsbDeviceInfo info_;
  int session_;
};

SimulatedIndemind::SimulatedIndemind(Options options)
    : state_(std::make_shared<State>(std::move(options))) {
  if (state_->opt.pace_real_time) state_->now = monotonic_now();
}

SimulatedIndemind::SimulatedIndemind() : SimulatedIndemind(Options{}) {}

SimulatedIndemind::~SimulatedIndemind() = default;

indemind::ModuleCalibration SimulatedIndemind::sim_calibration() {
  indemind::ModuleCalibration m;
  m.version = 2;
  const double f = 697, cx = 639.5, cy = 399.5, baseline = 0.12;
  for (indemind::CameraParameter* c : {&m.left, &m.right}) {
    c->width = 1280;
    c->height = 800;
    c->fx = c->fy = f;
    c->cx = cx;
    c->cy = cy;
    c->k = {f, 0, cx, 0, f, cy, 0, 0, 1};
    c->d = {0.03, -0.01, 0.002, -0.0005};
    c->r = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    // Rectified views keep a pinhole of 500 px: enough for the central 104° of the fisheye.
    c->p = {500, 0, cx, 0, 0, 500, cy, 0, 0, 0, 1, 0};
    c->t_sc = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  }
  m.right.p[3] = -500 * baseline;
  m.right.t_sc[3] = baseline;  // right camera -> IMU (= left camera) frame
  m.imu.g = 9.81;
  m.imu.t_bs = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  m.info.id = "SIM-0042";
  m.info.designer = "dco";
  m.info.firmware_version = "1.1_5ms";
  m.info.hardware_version = "H2";
  m.info.baseline = "120mm";
  m.img_frequency = 50;
  m.img_resolution = 640;
  m.imu_frequency = 1000;
  m.module_type = indemind::ModuleType::kNormal;
  return m;
}

std::vector<drivers::UsbDeviceInfo> SimulatedIndemind::list(std::uint16_t vendor,
                                                            std::uint16_t product) {
  std::lock_guard lock(state_->mu);
  if (!state_->present || vendor != indemind::kVendorId || product != indemind::kProductId)
    return {};
  drivers::UsbDeviceInfo d;
  d.bus = 2;
  d.address = 10 + state_->session;
  d.port_path = "2-1";
  d.speed_mbps = state_->opt.usb_speed_mbps;
  d.serial = state_->opt.serial;
  return {d};
}

std::unique_ptr<drivers::UsbDevice> SimulatedIndemind::open(const drivers::UsbDeviceInfo& device) {
  std::lock_guard lock(state_->mu);
  if (!state_->present || device.address != 10 + state_->session)
    throw UsbError("open: the device is gone", true);
  if (state_->opened) throw UsbError("open: the device is busy", false);
  state_->opened = true;
  ++state_->rec.opens;
  return std::make_unique<Device>(state_, device, state_->session);
}

void SimulatedIndemind::watch_hotplug(std::uint16_t, std::uint16_t, std::function<void()> cb) {
  std::lock_guard lock(state_->mu);
  state_->hotplug = std::move(cb);
}

void SimulatedIndemind::handle_events(std::chrono::milliseconds timeout) {
  State& s = *state_;
  std::vector<Completion> out;
  bool note = false;
  std::function<void()> hotplug;
  std::int64_t sleep_until = 0;
  {
    std::lock_guard lock(s.mu);
    if (s.opt.pace_real_time) s.now = std::max(s.now, monotonic_now());
    const std::int64_t deadline = s.now + timeout.count() * 1'000'000;
    while (out.empty() && !s.hotplug_note) {
      std::int64_t next = deadline + 1;
      int kind = -1;
      if (!s.pending.empty() && s.pending.front().at < next) next = s.pending.front().at, kind = 0;
      if (s.next_frame >= 0 && s.video.active && s.next_frame < next) next = s.next_frame, kind = 1;
      if (s.next_imu >= 0 && s.imu.active && s.next_imu < next) next = s.next_imu, kind = 2;
      if (s.replug_at >= 0 && s.replug_at < next) next = s.replug_at, kind = 3;
      if (kind < 0) {
        s.now = deadline;
        break;
      }
      s.now = std::max(s.now, next);
      if (kind == 1) {
        s.generate_frame();
      } else if (kind == 2) {
        s.generate_imu();
      } else if (kind == 3) {
        s.present = true;
        s.replug_at = -1;
        ++s.session;
        s.hotplug_note = true;
        // A replugged module starts counting anywhere, on a new time line.
        s.counter = std::uniform_int_distribution<int>(0, 65535)(s.rng);
        s.frame_start = s.now;
        s.replugged_at = s.now;
      } else {
        Completion c = std::move(s.pending.front());
        s.pending.pop_front();
        if (c.unplug) {
          s.unplug_now(c.replug_after_ns, out);
          continue;
        }
        Stream& st = c.endpoint == indemind::kVideoEndpoint ? s.video : s.imu;
        if (!st.active || st.generation != c.generation) continue;
        if (c.endpoint == indemind::kVideoEndpoint ? s.halted : s.imu_halted) continue;
        if (c.status == TransferStatus::kStall)
          (c.endpoint == indemind::kVideoEndpoint ? s.halted : s.imu_halted) = true;
        if (c.completes_intact) {
          // Counted when its last byte is on the wire, as the driver counts it.
          const std::uint64_t counter = c.counter;
          ++s.rec.frames_intact;
          if (s.has_intact) s.rec.expected_lost += counter - s.last_intact - 1;
          s.last_intact = counter;
          s.has_intact = true;
          if (s.replugged_at >= 0) {
            ++s.rec.recoveries;
            s.rec.worst_recovery_ns = std::max(s.rec.worst_recovery_ns, s.now - s.replugged_at);
            s.replugged_at = -1;
          }
        }
        if (c.bytes.size() > st.size) {
          c.status = TransferStatus::kOverflow;
          c.bytes.resize(st.size);
        }
        out.push_back(std::move(c));
      }
    }
    if (s.hotplug_note) {
      note = true;
      s.hotplug_note = false;
      hotplug = s.hotplug;
    }
    for (const Completion& c : out) {
      // kNoDevice and kStall completions end their transfer; the others are resubmitted.
      if (c.status == TransferStatus::kNoDevice || c.status == TransferStatus::kStall) {
        Stream& st = c.endpoint == indemind::kVideoEndpoint ? s.video : s.imu;
        ++s.rec.transfers_completed;
        if (--st.transfers == 0) st.active = false;
      }
    }
    if (s.opt.pace_real_time) sleep_until = s.now;
  }
  if (sleep_until > 0) {
    const std::int64_t wait = sleep_until - monotonic_now();
    if (wait > 0) std::this_thread::sleep_for(std::chrono::nanoseconds(wait));
  }
  for (Completion& c : out) {
    drivers::TransferCallback cb;
    {
      std::lock_guard lock(s.mu);
      Stream& st = c.endpoint == indemind::kVideoEndpoint ? s.video : s.imu;
      cb = st.callback;
    }
    if (cb) cb(c.status, c.bytes);
  }
  if (note && hotplug) hotplug();
}

void SimulatedIndemind::inject(Fault fault, int param) {
  State& s = *state_;
  std::lock_guard lock(s.mu);
  switch (fault) {
    case Fault::kImuShort:
      ++s.imu_short;
      break;
    case Fault::kImuDuplicate:
      ++s.imu_duplicate;
      break;
    case Fault::kImuBadTicks:
      ++s.imu_bad_ticks;
      s.imu_bad_ticks_value = param > 0 ? static_cast<std::uint32_t>(param) : 0xFFFFFFFFu;
      break;
    case Fault::kImuTickRace:
      ++s.imu_race;
      break;
    case Fault::kImuStall:
      ++s.imu_stall;
      break;
    case Fault::kImuSilence:
      s.imu_silence_ms = param;
      break;
    case Fault::kControlBusy:
      s.busy_left += param;
      ++s.rec.injected[static_cast<int>(fault)];
      break;
    default:
      s.frame_faults.emplace_back(fault, param);
      break;
  }
}

bool SimulatedIndemind::inject_and_settle(Fault fault, int param,
                                          std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  auto wait_for = [&](auto done) {
    while (!done(record())) {
      if (std::chrono::steady_clock::now() > until) return false;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    return true;
  };
  const std::uint64_t before = record().faults_applied();
  inject(fault, param);
  // Counting frames from before the fault was applied could count frames sent while the caller
  // was descheduled, and a next fault would land on a frame that a silence or a skip hides.
  if (!wait_for([&](const Record& r) { return r.faults_applied() > before; })) return false;
  const Record at = record();
  // An IMU fault has settled once reports flow again (a silence is over).
  const bool imu = fault == Fault::kImuShort || fault == Fault::kImuDuplicate ||
                   fault == Fault::kImuBadTicks || fault == Fault::kImuTickRace ||
                   fault == Fault::kImuStall || fault == Fault::kImuSilence;
  return wait_for([&](const Record& r) {
    return r.frames_sent >= at.frames_sent + 4 && r.frames_intact >= at.frames_intact + 3 &&
           (!imu || r.imu_reports >= at.imu_reports + 3);
  });
}

void SimulatedIndemind::set_usb_speed(int mbps) {
  std::lock_guard lock(state_->mu);
  state_->opt.usb_speed_mbps = mbps;
}

void SimulatedIndemind::set_present(bool present) {
  State& s = *state_;
  std::lock_guard lock(s.mu);
  if (present == s.present) return;
  if (present) {
    s.replug_at = s.now;
  } else {
    std::vector<Completion> out;
    s.unplug_now(0, out);
    // Completions for the transfers in flight go out with the next handle_events().
    for (Completion& c : out) {
      c.at = s.now;
      s.pending.push_front(std::move(c));
    }
  }
}

void SimulatedIndemind::hotplug_in_control(int count) {
  std::lock_guard lock(state_->mu);
  state_->hotplugs_in_control += count;
}

void SimulatedIndemind::unplug_in_control(int nth, int replug_ms) {
  std::lock_guard lock(state_->mu);
  state_->unplug_in_control = nth;
  state_->unplug_in_control_replug_ns = std::int64_t{replug_ms} * 1'000'000;
}

std::int64_t SimulatedIndemind::now_ns() const {
  std::lock_guard lock(state_->mu);
  return state_->opt.pace_real_time ? std::max(state_->now, monotonic_now()) : state_->now;
}

SimulatedIndemind::Record SimulatedIndemind::record() const {
  std::lock_guard lock(state_->mu);
  Record r = state_->rec;
  return r;
}

int SimulatedIndemind::transfers_in_flight() const {
  std::lock_guard lock(state_->mu);
  const State& s = *state_;
  return (s.video.active ? s.video.transfers : 0) + (s.imu.active ? s.imu.transfers : 0);
}

std::int64_t SimulatedIndemind::frame_start_ns(std::uint64_t counter) const {
  std::lock_guard lock(state_->mu);
  const auto it = state_->starts.find(counter);
  return it == state_->starts.end() ? -1 : it->second;
}

std::int64_t SimulatedIndemind::nearest_frame_start_ns(std::int64_t host_ns) const {
  std::lock_guard lock(state_->mu);
  std::int64_t best = -1;
  for (const auto& [counter, start] : state_->starts)
    if (best < 0 || std::llabs(start - host_ns) < std::llabs(best - host_ns)) best = start;
  return best;
}

}  // namespace dco::testing
