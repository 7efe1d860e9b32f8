#include <gtest/gtest.h>

#include <numeric>

#include "dco/indemind/frame_assembler.hpp"
#include "dco/indemind/frame_metadata.hpp"
#include "dco/indemind/imu_report.hpp"
#include "dco/indemind/stream_control.hpp"
#include "dco/indemind/uvc_payload.hpp"
#include "dco/indemind/xu_task.hpp"

namespace dco::indemind {
namespace {

std::vector<std::uint8_t> payload(bool fid, bool eof, std::size_t n, std::uint8_t fill,
                                  bool error = false) {
  auto p = make_uvc_header(fid, eof, error);
  p.insert(p.end(), n, fill);
  return p;
}

TEST(UvcPayload, ParsesFlagsPtsAndRejectsBrokenHeaders) {
  auto p = make_uvc_header(true, true, false, 0x01020304u);
  p.push_back(7);
  const ParsedPayload ok = parse_uvc_payload(p);
  ASSERT_EQ(ok.fault, PayloadFault::kNone);
  EXPECT_TRUE(ok.header.fid);
  EXPECT_TRUE(ok.header.eof);
  EXPECT_FALSE(ok.header.error);
  EXPECT_EQ(ok.header.pts, 0x01020304u);
  ASSERT_EQ(ok.data.size(), 1u);
  EXPECT_EQ(ok.data[0], 7);

  EXPECT_EQ(parse_uvc_payload({}).fault, PayloadFault::kEmpty);
  std::vector<std::uint8_t> too_long = {12, 0x80, 1, 2};
  EXPECT_EQ(parse_uvc_payload(too_long).fault, PayloadFault::kBadHeaderLength);
  std::vector<std::uint8_t> flags_disagree = {2, 0x80 | 0x04, 0, 0};  // PTS flag, no room
  EXPECT_EQ(parse_uvc_payload(flags_disagree).fault, PayloadFault::kBadHeaderLength);
  // A header longer than its flags need, within the standard's 12 bytes: its data starts after it.
  std::vector<std::uint8_t> padded = {12, 0x80 | 0x02, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 9, 8};
  const ParsedPayload taken = parse_uvc_payload(padded);
  ASSERT_EQ(taken.fault, PayloadFault::kNone);
  EXPECT_TRUE(taken.header.eof);
  ASSERT_EQ(taken.data.size(), 2u);
  EXPECT_EQ(taken.data[0], 9);
  std::vector<std::uint8_t> past_standard(20, 0);
  past_standard[0] = 13;
  past_standard[1] = 0x80;
  EXPECT_EQ(parse_uvc_payload(past_standard).fault, PayloadFault::kBadHeaderLength);
  std::vector<std::uint8_t> no_eoh = {2, 0x01, 5};
  EXPECT_EQ(parse_uvc_payload(no_eoh).fault, PayloadFault::kNoEndOfHeader);
}

TEST(FrameAssembler, JoinsPayloadsIntoExactlySizedFrames) {
  FrameAssembler a(10);
  std::vector<std::uint8_t> out(10);
  EXPECT_FALSE(a.feed(payload(false, false, 4, 1), 100));
  EXPECT_FALSE(a.feed(payload(false, false, 4, 2), 200));
  EXPECT_TRUE(a.feed(payload(false, true, 2, 3), 300));
  std::int64_t first = 0;
  ASSERT_TRUE(a.take_frame(out, &first));
  EXPECT_EQ(out, (std::vector<std::uint8_t>{1, 1, 1, 1, 2, 2, 2, 2, 3, 3}));
  EXPECT_EQ(first, 100) << "the first payload's arrival";
  EXPECT_FALSE(a.take_frame(out));
  EXPECT_EQ(a.counters().frames, 1u);

  // A frame id toggle ends one frame and starts the next in the same payload.
  a.feed(payload(true, false, 5, 4), 400);
  a.feed(payload(false, false, 5, 5), 500);
  EXPECT_TRUE(a.feed(payload(false, true, 5, 5), 600));
  ASSERT_TRUE(a.take_frame(out, &first));
  EXPECT_EQ(out, std::vector<std::uint8_t>(10, 5));
  EXPECT_EQ(first, 500);
}

TEST(FrameAssembler, ZeroLengthTransfersAreSkipped) {
  FrameAssembler a(10);
  std::vector<std::uint8_t> out(10);
  EXPECT_FALSE(a.feed({}));
  a.feed(payload(false, false, 4, 1));
  EXPECT_FALSE(a.feed({}));  // after a full-sized transfer, in the middle of a frame
  a.feed(payload(false, false, 4, 1));
  EXPECT_TRUE(a.feed(payload(false, true, 2, 1)));
  ASSERT_TRUE(a.take_frame(out));
  EXPECT_EQ(out, std::vector<std::uint8_t>(10, 1));
  EXPECT_EQ(a.counters().empty_payloads, 2u);
  EXPECT_EQ(a.counters().bad_payloads, 0u);
  EXPECT_EQ(a.counters().corrupt_frames, 0u);
}

TEST(FrameAssembler, CountsEveryKindOfBrokenFrame) {
  FrameAssembler a(10);
  // Short: EOF after 8 bytes.
  a.feed(payload(false, false, 4, 1));
  EXPECT_FALSE(a.feed(payload(false, true, 4, 1)));
  // Oversized: 12 bytes.
  a.feed(payload(true, false, 8, 1));
  EXPECT_FALSE(a.feed(payload(true, true, 4, 1)));
  // Error bit in the middle.
  a.feed(payload(false, false, 5, 1, true));
  EXPECT_FALSE(a.feed(payload(false, true, 5, 1)));
  // A garbage header in the middle.
  a.feed(payload(true, false, 5, 1));
  const std::vector<std::uint8_t> garbage = {0xff, 0, 0};
  a.feed(garbage);
  EXPECT_FALSE(a.feed(payload(true, true, 5, 1)));
  // FID toggles before EOF: the unfinished frame is short, the new one completes.
  a.feed(payload(false, false, 5, 1));
  a.feed(payload(true, false, 5, 2));
  EXPECT_TRUE(a.feed(payload(true, true, 5, 2)));
  const AssemblerCounters& c = a.counters();
  EXPECT_EQ(c.short_frames, 2u);
  EXPECT_EQ(c.oversized_frames, 1u);
  EXPECT_EQ(c.error_frames, 1u);
  EXPECT_EQ(c.corrupt_frames, 1u);
  EXPECT_EQ(c.bad_payloads, 1u);
  EXPECT_EQ(c.frames, 1u);
  std::vector<std::uint8_t> out(10);
  ASSERT_TRUE(a.take_frame(out));
  EXPECT_EQ(out, std::vector<std::uint8_t>(10, 2));
}

TEST(FrameAssembler, HandsOutBuffersWithoutAllocating) {
  FrameAssembler a(6);
  std::vector<std::uint8_t> out(6);
  const std::uint8_t* seen[4];
  for (int i = 0; i < 4; ++i) {
    a.feed(payload(i % 2, true, 6, static_cast<std::uint8_t>(i)));
    ASSERT_TRUE(a.take_frame(out));
    EXPECT_EQ(out[0], i);
    seen[i] = out.data();
  }
  // The assembler's two buffers and the caller's rotate: the fourth frame comes back in the
  // first one's memory.
  EXPECT_NE(seen[0], seen[1]);
  EXPECT_NE(seen[1], seen[2]);
  EXPECT_NE(seen[0], seen[2]);
  EXPECT_EQ(seen[0], seen[3]);
}

TEST(FrameMetadata, RoundTripsAndDetectsTornRows) {
  std::vector<std::uint8_t> row(1280, 0x55), above(1280, 0x33);
  FrameMetadata m;
  m.counter = 0xfffe;
  m.exposure_raw = 549;
  m.timer_raw = 0x89abcdef;
  write_frame_metadata(row, m);
  EXPECT_EQ(row[0], 0xff);  // big-endian
  EXPECT_EQ(row[1], 0xfe);
  const FrameMetadata got = parse_frame_metadata(row);
  EXPECT_EQ(got.counter, 0xfffe);
  EXPECT_EQ(got.exposure_raw, 549);
  EXPECT_NEAR(got.exposure_ms(), 4.996, 1e-3);
  EXPECT_EQ(got.timer_raw, 0x89abcdefu);
  EXPECT_FALSE(got.torn);
  m.torn = true;
  write_frame_metadata(row, m);
  EXPECT_TRUE(parse_frame_metadata(row).torn);
  row[70] = 0;  // only one of the two words non-zero: not torn
  row[71] = 0;
  row[68] = row[69] = 0;
  EXPECT_FALSE(parse_frame_metadata(row).torn);
  EXPECT_TRUE(parse_frame_metadata(std::span(row).first(20)).torn);
  mask_frame_metadata(row, above);
  EXPECT_TRUE(
      std::all_of(row.begin(), row.begin() + kMetadataBytes, [](auto v) { return v == 0x33; }));
  EXPECT_EQ(row[kMetadataBytes], 0x55);
}

TEST(CounterExtender, ExtendsAcrossWrapsAndClassifiesSteps) {
  using Step = CounterExtender::Step;
  CounterExtender e;
  EXPECT_EQ(e.next(65534).step, Step::kFirst);
  auto r = e.next(65535);
  EXPECT_EQ(r.step, Step::kNext);
  r = e.next(0);
  EXPECT_EQ(r.step, Step::kNext);
  EXPECT_EQ(r.extended, 65536u);
  r = e.next(4);
  EXPECT_EQ(r.step, Step::kGap);
  EXPECT_EQ(r.skipped, 3u);
  EXPECT_EQ(r.extended, 65540u);
  EXPECT_EQ(e.next(4).step, Step::kDuplicate);
  r = e.next(2);
  EXPECT_EQ(r.step, Step::kBackward);
  EXPECT_EQ(r.extended, 65540u);
  r = e.next(40000);  // far behind: the module restarted its counter
  EXPECT_EQ(r.step, Step::kRestart);
  EXPECT_GT(r.extended, 65540u);
  EXPECT_EQ(r.extended & 0xffff, 40000u);
  // IMU reports name frames just before or after the last one.
  EXPECT_EQ(e.place(39999), r.extended - 1);
  EXPECT_EQ(e.place(40001), r.extended + 1);
  const std::uint64_t before = e.last();
  e.resync();
  r = e.next(7);
  EXPECT_EQ(r.step, Step::kFirst);
  EXPECT_GT(r.extended, before);
  EXPECT_EQ(r.extended & 0xffff, 7u);
}

TEST(ImuReport, ParsesBigEndianFieldsAndScalesByRange) {
  ImuReport r;
  r.frame_counter = 0x1234;
  r.ticks = 160'000;  // 1 ms
  r.accel_raw = {2048, -2048, 1024};
  r.gyro_raw = {164, -328, 0};
  r.temperature_raw = 3268;
  const auto bytes = encode_imu_report(r);
  EXPECT_EQ(bytes[4], 0x12);
  EXPECT_EQ(bytes[5], 0x34);
  const auto got = parse_imu_report(bytes);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->frame_counter, 0x1234);
  EXPECT_EQ(got->ticks, 160'000u);
  EXPECT_EQ(got->accel_raw, r.accel_raw);
  EXPECT_EQ(got->gyro_raw, r.gyro_raw);
  const ImuSample s = to_sample(*got, ImuRanges{});
  EXPECT_FLOAT_EQ(s.accel_g[0], 1.0f);
  EXPECT_FLOAT_EQ(s.accel_g[1], -1.0f);
  EXPECT_FLOAT_EQ(s.accel_g[2], 0.5f);
  EXPECT_FLOAT_EQ(s.gyro_dps[0], 10.0f);
  EXPECT_FLOAT_EQ(s.gyro_dps[1], -20.0f);
  EXPECT_NEAR(s.temperature_c, 35.0f, 0.01f);
  ImuRanges fine{0, 0};
  EXPECT_FLOAT_EQ(to_sample(*got, fine).accel_g[0], 2048.0f / 16384.0f);
  EXPECT_FALSE(parse_imu_report(std::span(bytes).first(31)));
  std::vector<std::uint8_t> longer(bytes.begin(), bytes.end());
  longer.push_back(0);
  EXPECT_FALSE(parse_imu_report(longer));
}

TEST(XuTask, EncodesReadsAndRegisterWritesAndNeverFlashWrites) {
  const auto read = encode_xu_read(XuTarget::kFlash, 0x200100, 256);
  XuCommand c;
  ASSERT_TRUE(decode_xu_command(read, c));
  EXPECT_TRUE(c.read);
  EXPECT_EQ(c.target, 0xA1);
  EXPECT_EQ(c.address, 0x200100u);
  EXPECT_EQ(c.length, 256);
  EXPECT_EQ(read[0], 0x51);
  EXPECT_EQ(read[9], 0x91);  // 0x9000 | 256, big-endian
  EXPECT_EQ(read[10], 0x00);

  const auto write = encode_imu_register_write(0x19, 0);
  ASSERT_TRUE(decode_xu_command(write, c));
  EXPECT_FALSE(c.read);
  EXPECT_EQ(c.target, 0xA2);  // the bridge's register space, never 0xA1 (flash)
  EXPECT_EQ(c.address, kImuRegisterBase + 0x19);
  ASSERT_EQ(c.payload.size(), 1u);

  EXPECT_EQ(classify_xu_reply(std::vector<std::uint8_t>{0x56}), XuReply::kDone);
  EXPECT_EQ(classify_xu_reply(std::vector<std::uint8_t>{0x55}), XuReply::kBusy);
  EXPECT_EQ(classify_xu_reply(std::vector<std::uint8_t>{0x00}), XuReply::kInvalid);
  EXPECT_EQ(classify_xu_reply({}), XuReply::kInvalid);
  std::vector<std::uint8_t> broken = read;
  broken[3] = 2;
  EXPECT_FALSE(decode_xu_command(broken, c));
}

TEST(StreamControl, KnowsTheModesAndTheUsb2Limit) {
  std::string why;
  auto m = find_stream_mode(1280, 800, 100, 5000, why);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->frame_index, 1);
  EXPECT_EQ(m->frame_bytes(), 2'048'000u);
  EXPECT_EQ(m->interval_100ns(), 100'000u);
  m = find_stream_mode(640, 400, 200, 5000, why);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->frame_bytes(), 512'000u);
  EXPECT_FALSE(find_stream_mode(1280, 800, 200, 5000, why));
  EXPECT_NE(why.find("does not run at 200"), std::string::npos) << why;
  EXPECT_FALSE(find_stream_mode(640, 480, 50, 5000, why));
  EXPECT_NE(why.find("no 640x480 mode"), std::string::npos) << why;
  EXPECT_FALSE(find_stream_mode(640, 400, 50, 480, why));
  EXPECT_NE(why.find("USB 3"), std::string::npos) << why;
  EXPECT_TRUE(find_stream_mode(640, 400, 25, 480, why));
  EXPECT_EQ(default_stream_mode(480).fps, 25);
  EXPECT_EQ(default_stream_mode(5000).fps, 50);

  StreamControl c;
  c.frame_index = 2;
  c.frame_interval = 200'000;
  c.max_video_frame_size = 512'000;
  c.max_payload_transfer_size = 32768;
  c.clock_frequency = 150'000'000;
  const auto bytes = encode_stream_control(c);
  EXPECT_EQ(bytes[3], 2);
  EXPECT_EQ(bytes[4], 0x40);  // 200000 = 0x030d40, little-endian
  const auto back = decode_stream_control(bytes);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->frame_interval, 200'000u);
  EXPECT_EQ(back->max_payload_transfer_size, 32768u);
  EXPECT_EQ(back->clock_frequency, 150'000'000u);
  EXPECT_TRUE(decode_stream_control(std::span(bytes).first(kStreamControlBytesUvc10)));
  EXPECT_FALSE(decode_stream_control(std::span(bytes).first(25)));
}

TEST(StreamControl, AWidthOrHeightAloneNamesTheSize) {
  std::string why;
  auto m = find_stream_mode(1280, 0, 50, 5000, why);
  ASSERT_TRUE(m) << why;
  EXPECT_EQ(m->height, 800);
  m = find_stream_mode(0, 400, 200, 5000, why);
  ASSERT_TRUE(m) << why;
  EXPECT_EQ(m->width, 640);
  EXPECT_FALSE(find_stream_mode(1000, 0, 50, 5000, why));
  EXPECT_EQ(why.rfind("no mode 1000 wide (modes: 1280x800", 0), 0u) << why;
  EXPECT_FALSE(find_stream_mode(0, 480, 50, 5000, why));
  EXPECT_EQ(why.rfind("no mode 480 high", 0), 0u) << why;
  // The size is found before the rate and the link are checked.
  EXPECT_FALSE(find_stream_mode(0, 800, 200, 5000, why));
  EXPECT_EQ(why.rfind("1280x800 does not run at 200 fps", 0), 0u) << why;
}

}  // namespace
}  // namespace dco::indemind
