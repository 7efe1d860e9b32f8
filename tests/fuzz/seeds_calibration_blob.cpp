// Seeds of the calibration blob target: plausible 1280x800 modules of each blob version, and
// flash headers (announcing each version, erased).

#include <cstdint>
#include <utility>
#include <vector>

#include "dco/indemind/calibration_blob.hpp"
#include "fuzz_target.hpp"

namespace dco::fuzz {
namespace {

using namespace dco::indemind;

CameraParameter camera(double cx, double tx, double imu_x) {
  CameraParameter c;
  c.t_sc = {-1, 0, 0, imu_x, 0, -1, 0, 0.002, 0, 0, 1, -0.001, 0, 0, 0, 1};
  c.width = 1280;
  c.height = 800;
  c.fx = c.fy = 697.0;
  c.cx = cx;
  c.cy = 400.0;
  c.r = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  c.p = {690.0, 0, 640.0, tx, 0, 690.0, 400.0, 0, 0, 0, 1, 0};
  c.k = {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
  c.d = {-0.012, 0.004, -0.0016, 0.0002};
  return c;
}

std::vector<std::uint8_t> blob(int version, ModuleType type) {
  ModuleCalibration m;
  m.version = version;
  m.left = camera(641.5, 0, 0.06);
  m.right = camera(637.5, -690.0 * 0.12, -0.06);
  if (type != ModuleType::kNormal) std::swap(m.left, m.right);
  m.imu.g = 9.8019967;
  m.imu.t_bs = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  m.info = {"M1", "INDEMIND", "1.0", "H2", "2.1mm", "ICM-20602", "130", "120mm"};
  if (version >= 1) {
    m.img_frequency = 50;
    m.img_resolution = 1280;
    m.imu_frequency = 1000;
  }
  m.module_type = type;
  return encode_calibration_blob(m);
}

std::vector<std::uint8_t> header(std::uint32_t length) {
  std::vector<std::uint8_t> h(kFlashHeaderSize, 0);
  for (int i = 0; i < 4; ++i) h[i] = static_cast<std::uint8_t>(length >> (8 * i));
  return h;
}

}  // namespace

std::vector<std::vector<std::uint8_t>> seeds() {
  return {blob(0, ModuleType::kNormal),
          blob(1, ModuleType::kNormal),
          blob(2, ModuleType::kNormal),
          blob(2, ModuleType::kAr),
          header(static_cast<std::uint32_t>(kCalibrationBlobSizeV2)),
          header(static_cast<std::uint32_t>(kCalibrationBlobSizeV0)),
          std::vector<std::uint8_t>(kFlashHeaderSize, 0xFF)};
}

}  // namespace dco::fuzz
