// Field-by-field little-endian codec of the INDEMIND calibration blob. The field lists below are
// shared by the reader and the writer, so the layout is spelled out once; bytes are assembled by
// shifts, never by casting the buffer, so host byte order and alignment do not matter.
#include "dco/indemind/calibration_blob.hpp"

#include <bit>
#include <cassert>
#include <charconv>
#include <cmath>
#include <limits>
#include <string_view>

#include "dco/core/error.hpp"

namespace dco::indemind {
namespace {

static_assert(std::numeric_limits<double>::is_iec559, "the blob holds IEEE-754 doubles");

constexpr std::size_t kLeftOffset = 0;
constexpr std::size_t kRightOffset = 440;
constexpr std::size_t kImuOffset = 880;
constexpr std::size_t kInfoOffset = 1312;
constexpr std::size_t kSlamOffset = 1568;
constexpr std::size_t kV1Offset = 1608;
constexpr std::size_t kModuleTypeOffset = 1624;
constexpr std::size_t kInfoFieldSize = 32;
constexpr std::int32_t kMaxImageSide = 8192;

[[noreturn]] void fail(const std::string& msg) {
  throw Error("INDEMIND calibration: " + msg);
}

std::string number(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, res.ptr);
}

std::string known_sizes() {
  return std::to_string(kCalibrationBlobSizeV0) + " (v0), " +
         std::to_string(kCalibrationBlobSizeV1) + " (v1) or " +
         std::to_string(kCalibrationBlobSizeV2) + " (v2)";
}

std::uint64_t load_le(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

void store_le(std::uint8_t* p, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

std::int32_t load_i32(const std::uint8_t* p) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(load_le(p, 4)));
}

void store_i32(std::uint8_t* p, std::int32_t v) {
  store_le(p, static_cast<std::uint32_t>(v), 4);
}

// What a char[32] field shows when printed (see ModuleInfo).
std::string printable(std::string_view raw) {
  raw = raw.substr(0, raw.find('\0'));
  while (!raw.empty() &&
         (raw.back() == ' ' || raw.back() == '\t' || raw.back() == '\r' || raw.back() == '\n'))
    raw.remove_suffix(1);
  std::string out(raw);
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e) c = '?';
  return out;
}

// The blob's field order. `Camera`, `Imu` and `Info` may be const (writing) or not (reading).
template <typename Camera, typename Visit>
void camera_fields(Camera& c, Visit&& v) {
  v("T_SC", c.t_sc);
  v("width", c.width);
  v("height", c.height);
  v("fx", c.fx);
  v("fy", c.fy);
  v("cx", c.cx);
  v("cy", c.cy);
  v("R", c.r);
  v("P", c.p);
  v("K", c.k);
  v("D", c.d);
}

template <typename Imu, typename Visit>
void imu_fields(Imu& m, Visit&& v) {
  v("a_max", m.a_max);
  v("g_max", m.g_max);
  v("sigma_g_c", m.sigma_g_c);
  v("sigma_a_c", m.sigma_a_c);
  v("sigma_bg", m.sigma_bg);
  v("sigma_ba", m.sigma_ba);
  v("sigma_gw_c", m.sigma_gw_c);
  v("sigma_aw_c", m.sigma_aw_c);
  v("tau", m.tau);
  v("g", m.g);
  v("a0", m.a0);
  v("T_BS", m.t_bs);
  v("Acc", m.acc);
  v("Gyr", m.gyr);
}

template <typename Info, typename Visit>
void info_fields(Info& i, Visit&& v) {
  v("id", i.id);
  v("designer", i.designer);
  v("firmware_version", i.firmware_version);
  v("hardware_version", i.hardware_version);
  v("lens", i.lens);
  v("imu", i.imu);
  v("viewing_angle", i.viewing_angle);
  v("baseline", i.baseline);
}

// Reads consecutive fields from `offset`; `what` ("left camera", "IMU") prefixes messages.
class Reader {
 public:
  Reader(std::span<const std::uint8_t> blob, std::size_t offset, const char* what)
      : blob_(blob), pos_(offset), what_(what) {}

  std::size_t position() const { return pos_; }

  void operator()(const char* name, double& v) { v = next_double(name, -1); }
  template <std::size_t N>
  void operator()(const char* name, std::array<double, N>& a) {
    for (std::size_t i = 0; i < N; ++i) a[i] = next_double(name, static_cast<int>(i));
  }
  void operator()(const char*, std::int32_t& v) {
    v = load_i32(blob_.data() + pos_);
    pos_ += 4;
  }
  void operator()(const char*, std::string& s) {
    const auto* p = reinterpret_cast<const char*>(blob_.data() + pos_);
    s = printable(std::string_view(p, kInfoFieldSize));
    pos_ += kInfoFieldSize;
  }

 private:
  double next_double(const char* name, int index) {
    const double v = std::bit_cast<double>(load_le(blob_.data() + pos_, 8));
    if (!std::isfinite(v)) {
      std::string field = std::string(what_) + " " + name;
      if (index >= 0) field += "[" + std::to_string(index) + "]";
      fail(field + " is not finite (" + number(v) + ")");
    }
    pos_ += 8;
    return v;
  }

  std::span<const std::uint8_t> blob_;
  std::size_t pos_;
  const char* what_;
};

class Writer {
 public:
  Writer(std::vector<std::uint8_t>& blob, std::size_t offset) : blob_(blob), pos_(offset) {}

  std::size_t position() const { return pos_; }

  void operator()(const char*, double v) {
    store_le(blob_.data() + pos_, std::bit_cast<std::uint64_t>(v), 8);
    pos_ += 8;
  }
  template <std::size_t N>
  void operator()(const char* name, const std::array<double, N>& a) {
    for (double v : a) (*this)(name, v);
  }
  void operator()(const char*, std::int32_t v) {
    store_i32(blob_.data() + pos_, v);
    pos_ += 4;
  }
  void operator()(const char* name, const std::string& s) {
    if (s.size() > kInfoFieldSize)
      fail(std::string("module info ") + name + " is " + std::to_string(s.size()) +
           " bytes; the blob holds at most 32");
    if (printable(s) != s)
      fail(std::string("module info ") + name +
           " has bytes the parser would change (NUL, control, non-ASCII or trailing blanks)");
    for (std::size_t i = 0; i < s.size(); ++i) blob_[pos_ + i] = static_cast<std::uint8_t>(s[i]);
    pos_ += kInfoFieldSize;  // the rest stays NUL
  }

 private:
  std::vector<std::uint8_t>& blob_;
  std::size_t pos_;
};

CameraParameter read_camera(std::span<const std::uint8_t> blob, std::size_t offset,
                            const char* what) {
  CameraParameter c;
  Reader r(blob, offset, what);
  camera_fields(c, r);
  for (const auto& [name, side] : {std::pair{"width", c.width}, std::pair{"height", c.height}})
    if (side <= 0 || side > kMaxImageSide)
      fail(std::string(what) + " " + name + " " + std::to_string(side) + " is not in 1.." +
           std::to_string(kMaxImageSide));
  if (c.fx <= 0 || c.fy <= 0)
    fail(std::string(what) + " focal length must be positive (fx " + number(c.fx) + ", fy " +
         number(c.fy) + ")");
  return c;
}

int version_of(std::size_t size) {
  if (size == kCalibrationBlobSizeV0) return 0;
  if (size == kCalibrationBlobSizeV1) return 1;
  if (size == kCalibrationBlobSizeV2) return 2;
  return -1;
}

}  // namespace

std::size_t calibration_blob_size(int version) {
  switch (version) {
    case 0:
      return kCalibrationBlobSizeV0;
    case 1:
      return kCalibrationBlobSizeV1;
    case 2:
      return kCalibrationBlobSizeV2;
    default:
      fail("unknown blob version " + std::to_string(version) + " (known: 0, 1, 2)");
  }
}

std::size_t parse_flash_header(std::span<const std::uint8_t> header) {
  if (header.size() < 4)
    fail("flash header is " + std::to_string(header.size()) +
         " bytes; it needs at least 4 (the blob length)");
  const auto length = static_cast<std::uint32_t>(load_le(header.data(), 4));
  if (length == 0xFFFFFFFFu) fail("no calibration in flash (erased; header length 0xFFFFFFFF)");
  if (version_of(length) < 0)
    fail("flash header gives a blob length of " + std::to_string(length) +
         " bytes; known: " + known_sizes());
  return length;
}

ModuleCalibration parse_calibration_blob(std::span<const std::uint8_t> blob) {
  ModuleCalibration m;
  m.version = version_of(blob.size());
  if (m.version < 0)
    fail("blob is " + std::to_string(blob.size()) + " bytes; known: " + known_sizes());
  m.left = read_camera(blob, kLeftOffset, "left camera");
  m.right = read_camera(blob, kRightOffset, "right camera");
  Reader imu(blob, kImuOffset, "IMU");
  imu_fields(m.imu, imu);
  Reader info(blob, kInfoOffset, "module info");
  info_fields(m.info, info);
  if (m.version >= 1) {
    m.img_frequency = load_i32(blob.data() + kV1Offset);
    m.img_resolution = load_i32(blob.data() + kV1Offset + 4);
    m.imu_frequency = load_i32(blob.data() + kV1Offset + 8);
  }
  if (m.version >= 2) {
    const std::int32_t type = load_i32(blob.data() + kModuleTypeOffset);
    if (type < 0 || type > 2)
      fail("module type " + std::to_string(type) + " is not 0 (normal), 1 (AR) or 2 (MR)");
    m.module_type = static_cast<ModuleType>(type);
  }
  return m;
}

std::vector<std::uint8_t> encode_calibration_blob(const ModuleCalibration& m) {
  const std::size_t size = calibration_blob_size(m.version);
  const bool has_v1 = m.img_frequency || m.img_resolution || m.imu_frequency;
  if (m.version >= 1 && !(m.img_frequency && m.img_resolution && m.imu_frequency))
    fail("a v" + std::to_string(m.version) +
         " blob needs img_frequency, img_resolution and imu_frequency");
  if (m.version == 0 && has_v1)
    fail("a v0 blob has no img_frequency, img_resolution, imu_frequency");
  if (m.version < 2 && m.module_type != ModuleType::kNormal)
    fail("a v" + std::to_string(m.version) + " blob has no module type (needs v2)");

  std::vector<std::uint8_t> blob(size, 0);
  Writer left(blob, kLeftOffset);
  camera_fields(m.left, left);
  Writer right(blob, kRightOffset);
  camera_fields(m.right, right);
  Writer imu(blob, kImuOffset);
  imu_fields(m.imu, imu);
  Writer info(blob, kInfoOffset);
  info_fields(m.info, info);
  // The field lists must fill each struct exactly up to the next documented offset.
  assert(left.position() == kRightOffset && right.position() == kImuOffset &&
         imu.position() == kInfoOffset && info.position() == kSlamOffset);
  if (m.version >= 1) {
    store_i32(blob.data() + kV1Offset, *m.img_frequency);
    store_i32(blob.data() + kV1Offset + 4, *m.img_resolution);
    store_i32(blob.data() + kV1Offset + 8, *m.imu_frequency);
  }
  if (m.version >= 2)
    store_i32(blob.data() + kModuleTypeOffset, static_cast<std::int32_t>(m.module_type));
  return blob;
}

}  // namespace dco::indemind
