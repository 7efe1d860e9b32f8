#pragma once

// dco's view of the calibration an INDEMIND module stores in flash.

#include <string>

#include "dco/core/calibration.hpp"
#include "dco/indemind/calibration_blob.hpp"

namespace dco::indemind {

// The module's calibration as a StereoCalibration for images of width x height, as the driver
// delivers them:
//  - Cameras: Kannala-Brandt (equidistant) with D = k1..k4 and the camera matrix K; the blob's
//    separate fx, fy, cx, cy must agree with K (1e-6 relative).
//  - Rectification: has_rectification with the blob's R and P (is_rectified false); baseline =
//    (P_left[3] - P_right[3]) / f, which is -P_right[3] / f for the usual P_left[3] = 0.
//  - Extrinsics: right-in-left pose inverse(T_SC_right) * T_SC_left (metres); its length must
//    agree with the baseline from P within 10%, and it must put the right camera at +x.
//  - Left/right: for AR and MR modules (swaps_halves) the raw frame's second half is the left
//    camera. The driver delivers that half as the left image, and the blob names cameras by
//    sensor half, so the returned `left` is built from ModuleCalibration::right and `right`
//    from ModuleCalibration::left. For normal modules nothing is swapped. Either way `left` is
//    the camera with the smaller x (the other sits at +baseline on x).
//  - Size: the blob is calibrated for its cameras' width x height (1280x800). That size and half
//    of it are accepted; half scales K and P by 0.5 about pixel centres (c' = (c + 0.5) / 2 - 0.5).
// Throws dco::Error naming the problem for any other size or an inconsistent blob (K against
// fx/fy/cx/cy, P not a rectified pair, T_SC not rigid, right camera on the wrong side, and all
// that StereoCalibration::validate checks).
StereoCalibration to_stereo_calibration(const ModuleCalibration& m, int width, int height);

// One printable line for logs and status, e.g. "INDEMIND module M1 (firmware 1.0, hardware H2)";
// empty fields are left out.
std::string describe(const ModuleInfo& info);

}  // namespace dco::indemind
