// The sparse stereo stage next to OpenCV's StereoSGBM (3-way) on the same 640x360 real stereo
// pair with 64 disparities, and the stage's corrections of the right camera next to OpenCV's
// ways of doing them, in one run; prints the time ratios at the end.

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dco/core/cv_interop.hpp"
#include "dco/core/image.hpp"
#include "dco/core/synthetic_scene.hpp"
#include "dco/kernels/stereo_kernels.hpp"
#include "dco/pipeline/stereo/exposure_balance.hpp"
#include "dco/pipeline/stereo/lens_falloff.hpp"
#include "dco/pipeline/stereo/stereo_matcher.hpp"
#include "dco/pipeline/stereo/vertical_alignment.hpp"
#include "ratio_reporter.hpp"

namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 360;
constexpr int kDisparities = 64;  // searched: 0 .. 63

struct Pair {
  cv::Mat left, right;  // BGR
  cv::Mat left_gray, right_gray;
  bool ok = false;
};

// A 640x360 window of the KITTI 2015 pair 000046 (a real car-mounted camera), whose disparities
// there stay below 64.
const Pair& test_pair() {
  static const Pair pair = [] {
    Pair p;
    const std::string root = std::string(DCO_DATA_DIR) + "/kitti2015/000046/";
    const cv::Mat l = cv::imread(root + "image_2/000046_10.png", cv::IMREAD_COLOR);
    const cv::Mat r = cv::imread(root + "image_3/000046_10.png", cv::IMREAD_COLOR);
    if (l.empty() || r.empty() || l.cols < 300 + kWidth || l.rows < 15 + kHeight) return p;
    const cv::Rect roi(300, 15, kWidth, kHeight);
    p.left = l(roi).clone();
    p.right = r(roi).clone();
    cv::cvtColor(p.left, p.left_gray, cv::COLOR_BGR2GRAY);
    cv::cvtColor(p.right, p.right_gray, cv::COLOR_BGR2GRAY);
    p.ok = true;
    return p;
  }();
  return pair;
}

// The pair, or nullptr after marking the benchmark skipped.
const Pair* pair_or_skip(benchmark::State& state) {
  const Pair& p = test_pair();
  if (p.ok) return &p;
  state.SkipWithError("stereo data not found under " DCO_DATA_DIR);
  return nullptr;
}

// The stage on the pair's disparities, as every dco benchmark here runs it: on one thread, as its
// peer SGBM (the default, row_threads 0, takes up to 4 on a machine of 4 CPUs or more).
std::unique_ptr<dco::stereo::StereoMatcher> bench_matcher() {
  dco::stereo::StereoParams params;
  params.max_disparity = kDisparities - 1;
  params.row_threads = 1;
  return dco::stereo::make_cpu_stereo_matcher(params);
}

void run_dco(benchmark::State& state, bool color) {
  const Pair* pair = pair_or_skip(state);
  if (pair == nullptr) return;
  const Pair& p = *pair;
  const auto matcher = bench_matcher();
  const cv::Mat& l = color ? p.left : p.left_gray;
  const cv::Mat& r = color ? p.right : p.right_gray;
  dco::Image<float> disparity;
  dco::stereo::StereoTimings sum;
  sum.searched_fraction = 0;
  for (auto _ : state) {
    matcher->compute(dco::as_view<std::uint8_t>(l), dco::as_view<std::uint8_t>(r), disparity);
    const auto& t = matcher->last_timings();
    sum.prepare_ms += t.prepare_ms;
    sum.arms_ms += t.arms_ms;
    sum.initial_ms += t.initial_ms;
    sum.refine_ms += t.refine_ms;
    sum.sparse_ms += t.sparse_ms;
    sum.boundary_ms += t.boundary_ms;
    sum.guide_ms += t.guide_ms;
    sum.searched_fraction += t.searched_fraction;
    benchmark::DoNotOptimize(disparity.data());
  }
  const double n = static_cast<double>(state.iterations());
  state.SetLabel(std::string("simd ") + dco::kernels::simd_target());
  state.counters["prepare_ms"] = sum.prepare_ms / n;
  state.counters["arms_ms"] = sum.arms_ms / n;
  state.counters["initial_ms"] = sum.initial_ms / n;
  state.counters["refine_ms"] = sum.refine_ms / n;
  state.counters["sparse_ms"] = sum.sparse_ms / n;
  state.counters["boundary_ms"] = sum.boundary_ms / n;
  state.counters["guide_ms"] = sum.guide_ms / n;
  state.counters["searched"] = sum.searched_fraction / n;
}

void run_sgbm(benchmark::State& state, bool color, int threads) {
  const Pair* pair = pair_or_skip(state);
  if (pair == nullptr) return;
  const Pair& p = *pair;
  const int previous_threads = cv::getNumThreads();
  cv::setNumThreads(threads);
  const int cn = color ? 3 : 1;
  const auto sgbm = cv::StereoSGBM::create(0, kDisparities, 5, 8 * cn * 25, 32 * cn * 25, 1, 63, 10,
                                           100, 2, cv::StereoSGBM::MODE_SGBM_3WAY);
  const cv::Mat& l = color ? p.left : p.left_gray;
  const cv::Mat& r = color ? p.right : p.right_gray;
  cv::Mat disparity;
  for (auto _ : state) {
    sgbm->compute(l, r, disparity);
    benchmark::DoNotOptimize(disparity.data);
  }
  cv::setNumThreads(previous_threads);
}

// The exposure balance's work per frame (stereo.exposure_balance) on the same grey pair: the fit
// to the stage's sparse map, and the right image through a table that changes its levels.
void BM_DcoExposureBalance_Gray(benchmark::State& state) {
  const Pair* p = pair_or_skip(state);
  if (p == nullptr) return;
  const auto left = dco::as_view<std::uint8_t>(p->left_gray);
  const auto right = dco::as_view<std::uint8_t>(p->right_gray);
  dco::Image<float> disparity;
  bench_matcher()->compute(left, right, disparity);
  dco::stereo::ExposureMap map;
  dco::stereo::ExposureTable table;
  dco::Image<std::uint8_t> balanced;
  for (auto _ : state) {
    const bool fitted = dco::stereo::fit_exposure(left, right, disparity.cview(), map);
    map.channels[0].offset += 3;  // a map that moves levels, as a pair that differs gets
    table.build(map);
    table.apply(right, balanced);
    benchmark::DoNotOptimize(fitted);
    benchmark::DoNotOptimize(balanced.data());
  }
}

// The right image as the camera alignment corrects it on every frame when the cameras differ,
// at the headset's 1280x720 in colour (the KITTI window scaled up): moved by 0.4 row, then
// through a table per channel; and the same two passes by OpenCV (warpAffine, LUT).
const cv::Mat& headset_right() {
  static const cv::Mat right = [] {
    const Pair& p = test_pair();
    cv::Mat r;
    if (p.ok) cv::resize(p.right, r, cv::Size(1280, 720), 0, 0, cv::INTER_LINEAR);
    return r;
  }();
  return right;
}

dco::stereo::ExposureMap brighter_map() {
  dco::stereo::ExposureMap map;
  map.count = 3;
  map.channels = {{{0.97, 2.0}, {0.98, 1.0}, {0.96, 3.0}}};
  return map;
}

// The right image brought onto the left's rows and through the exposure tables, as the stage does
// before it matches: a row shift without a roll, cv::warpAffine with one (align_rows).
void run_right_correction(benchmark::State& state, const dco::stereo::RowAlignment& rows) {
  if (pair_or_skip(state) == nullptr) return;
  const auto right = dco::as_view<std::uint8_t>(headset_right());
  dco::stereo::ExposureTable table;
  table.build(brighter_map());
  dco::Image<std::uint8_t> moved, balanced;
  for (auto _ : state) {
    dco::stereo::align_rows(right, rows, moved);
    table.apply(moved.cview(), balanced);
    benchmark::DoNotOptimize(balanced.data());
  }
}

void BM_DcoRightCorrection_Color_1280x720(benchmark::State& state) {
  run_right_correction(state, {0.4, 0.0});
}

void BM_DcoRightCorrectionTurned_Color_1280x720(benchmark::State& state) {
  run_right_correction(state, {0.4, 0.002});
}

// The same two passes by OpenCV, on one thread: warpAffine with the alignment's map (linear,
// borders repeated, as align_rows), then a table per channel.
void run_opencv_right_correction(benchmark::State& state, const dco::stereo::RowAlignment& rows) {
  if (pair_or_skip(state) == nullptr) return;
  const cv::Mat& right = headset_right();
  const dco::stereo::ExposureMap map = brighter_map();
  cv::Mat lut(1, 256, CV_8UC3);
  for (int v = 0; v < 256; ++v)
    for (int c = 0; c < 3; ++c)
      lut.at<cv::Vec3b>(0, v)[c] =
          cv::saturate_cast<std::uint8_t>(map.channels[static_cast<std::size_t>(c)].gain * v +
                                          map.channels[static_cast<std::size_t>(c)].offset);
  const double c = std::cos(rows.roll), s = std::sin(rows.roll);
  const double xc = 0.5 * (right.cols - 1), yc = 0.5 * (right.rows - 1);
  const cv::Matx23d to_src(c, -s, xc - c * xc + s * yc, s, c, yc - s * xc - c * yc + rows.offset);
  cv::Mat moved, balanced;
  // On one thread, as dco's passes and OpenCV's loops in the stage run.
  const int previous_threads = cv::getNumThreads();
  cv::setNumThreads(1);
  for (auto _ : state) {
    cv::warpAffine(right, moved, to_src, right.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                   cv::BORDER_REPLICATE);
    cv::LUT(moved, lut, balanced);
    benchmark::DoNotOptimize(balanced.data);
  }
  cv::setNumThreads(previous_threads);
}

void BM_OpenCVRightCorrection_Color_1280x720(benchmark::State& state) {
  run_opencv_right_correction(state, {0.4, 0.0});
}

void BM_OpenCVRightCorrectionTurned_Color_1280x720(benchmark::State& state) {
  run_opencv_right_correction(state, {0.4, 0.002});
}

// One view through a lens fall-off correction (k 0.3), as the stage does to both before it matches
// once it has found one: OpenCV's multiply by a float map of gains (no peer: it is OpenCV's own).
void BM_DcoLensFalloff_Color_1280x720(benchmark::State& state) {
  if (pair_or_skip(state) == nullptr) return;
  const auto right = dco::as_view<std::uint8_t>(headset_right());
  dco::stereo::FalloffCorrection correction;
  correction.build({0.3}, right.width, right.height, right.channels);
  dco::Image<std::uint8_t> out;
  for (auto _ : state) {
    correction.apply(right, out);
    benchmark::DoNotOptimize(out.data());
  }
}

// The synthetic hand at the headset's 1280x720 with its right camera turned 0.2 degrees and its
// scene 0.5 rows lower: a known answer for both ways of finding the rows.
constexpr double kTurnDeg = 0.2, kTurnRows = 0.5;
const dco::synthetic::StereoSample& turned_hand() {
  static const dco::synthetic::StereoSample sample = [] {
    dco::synthetic::SceneConfig config = dco::synthetic::preset("hand", 1280, 720);
    config.right_roll_deg = kTurnDeg;
    config.right_rows = kTurnRows;
    dco::synthetic::StereoSample s;
    dco::synthetic::SceneRenderer(config).render(3, s);
    return s;
  }();
  return sample;
}

void report_rows(benchmark::State& state, double offset, double roll_deg) {
  state.counters["offset_err_rows"] = std::abs(offset - kTurnRows);
  state.counters["roll_err_deg"] = std::abs(roll_deg - kTurnDeg);
}

// The stage's search for the rows of a sequence's first frame, from the pair's matches (here the
// ground truth's disparities: the search's own cost, not the matcher's).
void BM_DcoRowAlignmentSearch_1280x720(benchmark::State& state) {
  const dco::synthetic::StereoSample& s = turned_hand();
  dco::stereo::RowAlignment found;
  for (auto _ : state) {
    found = {};
    dco::stereo::fit_row_alignment(s.left.cview(), s.right.cview(), s.disparity.cview(), {}, true,
                                   found);
    benchmark::DoNotOptimize(found);
  }
  report_rows(state, found.offset, found.roll * 180.0 / std::numbers::pi);
}

// The way one would find them with OpenCV: SIFT features of both views, their nearest
// neighbours with Lowe's ratio test, and a least-squares line through the matches' row
// differences across the columns, refitted without those 0.5 rows off it.
void BM_OpenCVSiftRowAlignment_1280x720(benchmark::State& state) {
  const dco::synthetic::StereoSample& s = turned_hand();
  const cv::Mat left = dco::as_mat(s.left.cview()), right = dco::as_mat(s.right.cview());
  const auto sift = cv::SIFT::create(4000);
  const cv::BFMatcher matcher(cv::NORM_L2);
  const double xc = 0.5 * (left.cols - 1);
  double offset = 0, slope = 0;
  for (auto _ : state) {
    std::vector<cv::KeyPoint> kl, kr;
    cv::Mat dl, dr;
    sift->detectAndCompute(left, cv::noArray(), kl, dl);
    sift->detectAndCompute(right, cv::noArray(), kr, dr);
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(dl, dr, knn, 2);
    std::vector<cv::Point2d> rows;  // (u, row difference)
    for (const auto& k : knn) {
      if (k.size() < 2 || k[0].distance > 0.7f * k[1].distance) continue;
      const cv::Point2f a = kl[static_cast<std::size_t>(k[0].queryIdx)].pt;
      const cv::Point2f b = kr[static_cast<std::size_t>(k[0].trainIdx)].pt;
      if (std::abs(b.y - a.y) <= 4 && a.x >= b.x) rows.emplace_back((a.x - xc) / xc, b.y - a.y);
    }
    for (int round = 0; round < 3; ++round) {
      double n = 0, su = 0, sv = 0, suu = 0, suv = 0;
      for (const cv::Point2d& r : rows) {
        if (round > 0 && std::abs(r.y - (offset + slope * r.x)) > 0.5) continue;
        n += 1, su += r.x, sv += r.y, suu += r.x * r.x, suv += r.x * r.y;
      }
      slope = (suv * n - su * sv) / (suu * n - su * su);
      offset = (sv - slope * su) / n;
    }
    benchmark::DoNotOptimize(offset);
  }
  report_rows(state, offset, std::atan(slope / xc) * 180.0 / std::numbers::pi);
}

void BM_DcoSparseStereo_Gray(benchmark::State& s) {
  run_dco(s, false);
}
void BM_DcoSparseStereo_Color(benchmark::State& s) {
  run_dco(s, true);
}
void BM_SGBM3Way_Gray_1Thread(benchmark::State& s) {
  run_sgbm(s, false, 1);
}
void BM_SGBM3Way_Color_1Thread(benchmark::State& s) {
  run_sgbm(s, true, 1);
}
void BM_SGBM3Way_Gray_2Threads(benchmark::State& s) {
  run_sgbm(s, false, 2);
}

BENCHMARK(BM_DcoSparseStereo_Gray)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DcoSparseStereo_Color)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DcoExposureBalance_Gray)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DcoRightCorrection_Color_1280x720)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_OpenCVRightCorrection_Color_1280x720)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DcoRightCorrectionTurned_Color_1280x720)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_OpenCVRightCorrectionTurned_Color_1280x720)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_DcoLensFalloff_Color_1280x720)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DcoRowAlignmentSearch_1280x720)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_OpenCVSiftRowAlignment_1280x720)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SGBM3Way_Gray_1Thread)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SGBM3Way_Color_1Thread)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SGBM3Way_Gray_2Threads)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  return dco::bench::run_with_ratios(
      argc, argv,
      {{"BM_DcoSparseStereo_Gray", "BM_SGBM3Way_Gray_1Thread"},
       {"BM_DcoSparseStereo_Color", "BM_SGBM3Way_Color_1Thread"},
       {"BM_DcoSparseStereo_Gray", "BM_SGBM3Way_Gray_2Threads"},
       {"BM_DcoRightCorrection_Color_1280x720", "BM_OpenCVRightCorrection_Color_1280x720"},
       {"BM_DcoRightCorrectionTurned_Color_1280x720",
        "BM_OpenCVRightCorrectionTurned_Color_1280x720"},
       {"BM_DcoRowAlignmentSearch_1280x720", "BM_OpenCVSiftRowAlignment_1280x720"}});
}
