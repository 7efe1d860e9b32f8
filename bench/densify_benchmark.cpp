// The densify stage on a 1280x720 frame of the synthetic "hand" sequence (sparse map, contours
// and previous frame from the real pipeline), against Eigen's conjugate gradients (Jacobi
// preconditioner) solving the very same system to the same relative residual from the same
// warm start. Prints the time ratios at the end.

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>

#include <cstdio>
#include <vector>

#include <benchmark/benchmark.h>

#include "dco/core/synthetic_scene.hpp"
#include "dco/pipeline/densify/densifier.hpp"
#include "dco/pipeline/depth_pipeline.hpp"
#include "ratio_reporter.hpp"

namespace {

using dco::Image;
using dco::ImageView;
namespace densify = dco::densify;

// Frames 1 and 2 of the sequence as the densifier sees them in the pipeline.
struct Frames {
  dco::pipeline::DepthResult previous, current;
};

const Frames& frames() {
  static const Frames f = [] {
    dco::synthetic::SceneRenderer renderer(dco::synthetic::preset("hand", 1280, 720));
    dco::pipeline::PipelineParams params;
    params.stereo.max_disparity = 206;
    params.contour.lookahead = 0;
    params.densify.photometric.max_pixels = 1280 * 720;  // the results carry the right image
    dco::pipeline::DepthPipeline pipeline(params);
    dco::synthetic::StereoSample sample;
    Frames out;
    for (int i = 0; i < 3; ++i) {
      renderer.render(i, sample);
      pipeline.push(sample.left.cview(), sample.right.cview(), i == 2 ? out.current : out.previous);
    }
    return out;
  }();
  return f;
}

// One frame as the pipeline runs it: warm-started from, and stabilised towards, the previous
// frame's solution (computed outside the timed region). On one thread unless asked, as Eigen's
// solve runs.
void run_dco(benchmark::State& state, const char* solve_resolution, bool photometric = false,
             int row_threads = 1) {
  const Frames& f = frames();
  densify::DensifyParams params;
  params.solve_resolution = solve_resolution;
  params.row_threads = row_threads;
  // The photometric refinement is off at this size by default (densify.photometric_max_pixels):
  // this variant measures what it would cost.
  if (photometric) params.photometric.max_pixels = 1280 * 720;
  densify::Densifier densifier(params);
  Image<float> dense;
  for (auto _ : state) {
    state.PauseTiming();
    densifier.reset();
    densifier.compute(dco::pipeline::densify_inputs(f.previous, {}), dense);
    state.ResumeTiming();
    densifier.compute(dco::pipeline::densify_inputs(f.current, densifier.last_solution()), dense);
    benchmark::DoNotOptimize(dense.view().row(0));
  }
  state.counters["iterations"] = densifier.last_report().iterations;
  state.counters["fine_iterations"] = densifier.last_report().fine_iterations;
  state.counters["final_residual"] = densifier.last_report().final_residual;
  state.counters["build_ms"] = densifier.last_timings().build_ms;
  state.counters["median_ms"] = densifier.last_timings().median_ms;
  state.counters["refine_ms"] = densifier.last_timings().refine_ms;
}

void BM_DcoDensify_Full(benchmark::State& state) {
  run_dco(state, "full");
}
// The default at this size ("auto"): half size, then iterations at full size.
void BM_DcoDensify_Half(benchmark::State& state) {
  run_dco(state, "half");
}
void BM_DcoDensify_HalfPhotometric(benchmark::State& state) {
  run_dco(state, "half", true);
}
// The same with the stage's row-wise steps, the refinement's passes among them, on one, two and
// four threads (densify.row_threads; 0, the pipeline's default, takes one on a machine of fewer
// than 4 CPUs and half of them, at most 4, elsewhere).
void BM_DcoDensify_HalfPhotometricOneThread(benchmark::State& state) {
  run_dco(state, "half", true, 1);
}
void BM_DcoDensify_HalfPhotometricTwoThreads(benchmark::State& state) {
  run_dco(state, "half", true, 2);
}
void BM_DcoDensify_HalfPhotometricFourThreads(benchmark::State& state) {
  run_dco(state, "half", true, 4);
}

// Eigen CG on the system the full solve builds, from the same warm start, to the same
// relative residual ||b - A x|| / ||b||.
void BM_EigenCg_Jacobi(benchmark::State& state) {
  const Frames& f = frames();
  densify::DensifyParams params;
  params.solve_resolution = "full";
  densify::Densifier densifier(params);
  Image<float> dense;
  densifier.compute(dco::pipeline::densify_inputs(f.previous, {}), dense);
  const Image<float> warm = dense;
  densifier.compute(dco::pipeline::densify_inputs(f.current, warm.cview()), dense);
  const densify::GridSystem& a = densifier.last_system();
  const int w = a.width(), h = a.height();
  const auto index = [w](int x, int y) { return static_cast<Eigen::Index>(y) * w + x; };
  std::vector<Eigen::Triplet<float>> entries;
  entries.reserve(static_cast<std::size_t>(w) * h * 5);
  Eigen::VectorXf b(static_cast<Eigen::Index>(w) * h), guess(b.size());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Eigen::Index p = index(x, y);
      entries.emplace_back(p, p, a.diag.cview().row(y)[x]);
      if (x + 1 < w) {
        entries.emplace_back(p, index(x + 1, y), -a.wx.cview().row(y)[x]);
        entries.emplace_back(index(x + 1, y), p, -a.wx.cview().row(y)[x]);
      }
      if (y + 1 < h) {
        entries.emplace_back(p, index(x, y + 1), -a.wy.cview().row(y)[x]);
        entries.emplace_back(index(x, y + 1), p, -a.wy.cview().row(y)[x]);
      }
      b[p] = densifier.last_rhs().row(y)[x];
      guess[p] = warm.cview().row(y)[x];
    }
  Eigen::SparseMatrix<float> matrix(b.size(), b.size());
  matrix.setFromTriplets(entries.begin(), entries.end());
  Eigen::ConjugateGradient<Eigen::SparseMatrix<float>, Eigen::Lower | Eigen::Upper> cg;
  cg.setTolerance(static_cast<float>(params.tolerance));
  cg.setMaxIterations(5000);
  cg.compute(matrix);
  Eigen::VectorXf x;
  for (auto _ : state) {
    x = cg.solveWithGuess(b, guess);
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["iterations"] = static_cast<double>(cg.iterations());
  state.counters["residual"] = static_cast<double>(cg.error());
}

BENCHMARK(BM_DcoDensify_Full)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DcoDensify_Half)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DcoDensify_HalfPhotometric)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DcoDensify_HalfPhotometricOneThread)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DcoDensify_HalfPhotometricTwoThreads)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DcoDensify_HalfPhotometricFourThreads)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_EigenCg_Jacobi)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  return dco::bench::run_with_ratios(
      argc, argv,
      {{"BM_DcoDensify_Full", "BM_EigenCg_Jacobi"},
       {"BM_DcoDensify_Half", "BM_EigenCg_Jacobi"},
       {"BM_DcoDensify_HalfPhotometric", "BM_EigenCg_Jacobi"},
       {"BM_DcoDensify_HalfPhotometricTwoThreads", "BM_EigenCg_Jacobi"}});
}
