// Seeds of the calibration file target: one small rig in each format dco reads -- Middlebury,
// KITTI, Karlsruhe and dco's TOML (raw pinhole, raw fisheye, rectified, with a rectification) --
// small enough that the rectifier's maps stay cheap.

#include <cstdint>
#include <string_view>
#include <vector>

#include "fuzz_target.hpp"

namespace dco::fuzz {
namespace {

constexpr std::string_view kMiddlebury = R"(cam0=[100.5 0 78.2; 0 100.5 61.1; 0 0 1]
cam1=[100.5 0 81.9; 0 100.5 61.1; 0 0 1]
doffs=3.7
baseline=193.001
width=160
height=120
ndisp=32
)";

constexpr std::string_view kKitti = R"(calib_time: 01-Jan-2024 12:00:00
S_02: 1.600000e+02 1.200000e+02
K_02: 1.000000e+02 0.000000e+00 8.000000e+01 0.000000e+00 1.000000e+02 6.000000e+01 0.000000e+00 0.000000e+00 1.000000e+00
D_02: -1.000000e-01 2.000000e-02 1.000000e-03 -6.000000e-04 0.000000e+00
R_02: 1.000000e+00 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00
T_02: 6.000000e-02 0.000000e+00 0.000000e+00
S_rect_02: 1.500000e+02 1.100000e+02
R_rect_02: 1.000000e+00 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00
P_rect_02: 9.500000e+01 0.000000e+00 7.500000e+01 5.700000e+00 0.000000e+00 9.500000e+01 5.500000e+01 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
S_03: 1.600000e+02 1.200000e+02
K_03: 1.010000e+02 0.000000e+00 8.100000e+01 0.000000e+00 1.010000e+02 6.000000e+01 0.000000e+00 0.000000e+00 1.000000e+00
D_03: -9.000000e-02 1.800000e-02 0.000000e+00 0.000000e+00 0.000000e+00
R_03: 1.000000e+00 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00
T_03: -4.800000e-01 0.000000e+00 0.000000e+00
S_rect_03: 1.500000e+02 1.100000e+02
R_rect_03: 1.000000e+00 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00
P_rect_03: 9.500000e+01 0.000000e+00 7.500000e+01 -3.990000e+01 0.000000e+00 9.500000e+01 5.500000e+01 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
)";

constexpr std::string_view kKarlsruhe = R"(calib_time: 09-Mar-2010 16:52:08
corner_dist: 1.000000e-01
roi: 4.000000e+00 1.530000e+02 6.000000e+00 1.150000e+02
K1: 1.000000e+02 0.000000e+00 8.000000e+01 0.000000e+00 1.000000e+02 6.000000e+01 0.000000e+00 0.000000e+00 1.000000e+00
D1: -3.695739e-01 1.726456e-01 -1.281525e-03 1.188796e-03 -4.284730e-02
R1: 9.999122e-01 7.482788e-04 -1.323067e-02 -9.196597e-04 9.999157e-01 -1.295197e-02 1.321986e-02 1.296300e-02 9.998286e-01
K2: 9.900000e+01 0.000000e+00 8.100000e+01 0.000000e+00 9.900000e+01 6.100000e+01 0.000000e+00 0.000000e+00 1.000000e+00
D2: -3.753454e-01 1.843265e-01 -1.307069e-03 2.190397e-03 -4.989103e-02
R2: 9.996560e-01 -1.479808e-02 -2.165190e-02 1.507742e-02 9.998045e-01 1.279563e-02 2.145832e-02 -1.311768e-02 9.996837e-01
R: 9.998381e-01 1.610234e-02 8.033237e-03 -1.588968e-02 9.995390e-01 -2.586908e-02 -8.446087e-03 2.573724e-02 9.996331e-01
T: -5.706425e-01 8.447320e-03 1.235975e-02
P1: 9.000000e+01 0.000000e+00 8.000000e+01 0.000000e+00 0.000000e+00 9.000000e+01 6.000000e+01 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
P1_roi: 9.000000e+01 0.000000e+00 7.600000e+01 0.000000e+00 0.000000e+00 9.000000e+01 5.400000e+01 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
P2: 9.000000e+01 0.000000e+00 8.000000e+01 -5.136000e+01 0.000000e+00 9.000000e+01 6.000000e+01 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
P2_roi: 9.000000e+01 0.000000e+00 7.600000e+01 -5.136000e+01 0.000000e+00 9.000000e+01 5.400000e+01 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
)";

constexpr std::string_view kTomlPinhole = R"(# raw pinhole rig
[left]
model = "pinhole"
width = 160
height = 120
fx = 100.0
fy = 100.0
cx = 79.5
cy = 59.5
distortion = [-0.12, 0.03, 0.0005, -0.0003, 0.0]

[right]
model = "pinhole"
width = 160
height = 120
fx = 100.4
fy = 100.3
cx = 80.5
cy = 60.0
distortion = [-0.11, 0.025, 0.0, 0.0, 0.0]

[extrinsics]
rotation = [0.9999, -0.0087, 0.0105,
            0.0088, 0.9999, -0.0052,
            -0.0104, 0.0053, 0.9999]
translation = [-0.064, 0.0002, 0.0011]
)";

constexpr std::string_view kTomlFisheye = R"([left]
model = "kannala_brandt"
width = 128
height = 96
fx = 60.0
fy = 60.0
cx = 64.0
cy = 48.0
distortion = [0.01, -0.002, 0.0003, -0.00001]

[right]
model = "kannala_brandt"
width = 128
height = 96
fx = 60.5
fy = 60.4
cx = 63.0
cy = 47.5
distortion = [0.012, -0.0025, 0.0002, 0.0]

[extrinsics]
rotation = [0.001, -0.002, 0.0005]
translation = [-0.12, 0.0, 0.0]
)";

constexpr std::string_view kTomlRectified = R"([rectified]
width = 148
height = 99
f = 199.8
cx_left = 58.8
cx_right = 65.4
cy = 50.6
baseline_m = 0.193001
)";

constexpr std::string_view kTomlRectification = R"([left]
model = "pinhole"
width = 160
height = 120
fx = 100.0
fy = 100.0
cx = 80.0
cy = 60.0

[right]
model = "pinhole"
width = 160
height = 120
fx = 101.0
fy = 101.0
cx = 81.0
cy = 60.0

[extrinsics]
rotation = [1, 0, 0, 0, 1, 0, 0, 0, 1]
translation = [-0.54, 0.0, 0.0]

[rectified]
width = 150
height = 110
f = 95.0
cx_left = 75.0
cx_right = 75.0
cy = 55.0
baseline_m = 0.54

[rectification]
rotation_left = [1, 0, 0, 0, 1, 0, 0, 0, 1]
rotation_right = [0.0, 0.0, 0.001]
)";

std::vector<std::uint8_t> bytes(std::string_view text) {
  return {text.begin(), text.end()};
}

}  // namespace

std::vector<std::vector<std::uint8_t>> seeds() {
  return {bytes(kMiddlebury),  bytes(kKitti),         bytes(kKarlsruhe),        bytes(kTomlPinhole),
          bytes(kTomlFisheye), bytes(kTomlRectified), bytes(kTomlRectification)};
}

}  // namespace dco::fuzz
