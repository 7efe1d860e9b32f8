#pragma once

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/gpu/densify_passes.hpp"
#include "dco/gpu/grid_transfers.hpp"
#include "dco/pipeline/densify/densifier.hpp"
#include "dco/pipeline/densify/multigrid.hpp"
#include "dco/pipeline/densify/system_solver.hpp"

namespace dco::gpu {

// The densifier's solver (dco::densify::SystemSolver) on a Grid: the data term and edge weights
// of the system the CPU built are uploaded once per frame (the diagonal is recomputed from them
// on the grid, as the CPU did), then the half-size aggregation, the multigrid hierarchy, the
// preconditioned conjugate gradients and the full-size sweeps all run as passes
// (densify_passes.hpp), the CPU solver's steps in its order; only the dot products come back
// (one double per row, added up on the host in row order, as densify::dot does). Same solution
// as the CPU solver, bit for bit.
template <class Grid>
class GridSystemSolver final : public densify::SystemSolver {
 public:
  // The CPU multigrid's settings.
  static constexpr int kCoarsestSize = densify::Multigrid::kCoarsestSize;
  static constexpr int kSmoothingSweeps = densify::Multigrid::kSmoothingSweeps;
  static constexpr int kCoarsestSweeps = densify::Multigrid::kCoarsestSweeps;

  template <class... GridArgs>
  explicit GridSystemSolver(const densify::DensifyParams& params, GridArgs&&... grid_args)
      : params_(params), grid_(std::forward<GridArgs>(grid_args)...) {}

  densify::SolverReport solve(const densify::GridSystem& a, ImageView<const float> b,
                              ImageView<float> x) override {
    const int w = a.width(), h = a.height();
    fine_.resize(w, h);
    upload_rows(grid_, a.data.cview(), upload_staging_[0], fine_.data);
    upload_rows(grid_, a.wx.cview(), upload_staging_[1], fine_.wx);
    upload_rows(grid_, a.wy.cview(), upload_staging_[2], fine_.wy);
    upload_rows(grid_, b, upload_staging_[3], fine_b_);
    upload_rows(grid_, ImageView<const float>(x), upload_staging_[4], fine_x_);
    // The diagonal and its inverse follow from the three images with the arithmetic the CPU
    // used (GridSystem::update_diagonal): computing them here moves two fifths less.
    grid_.launch(w, h, passes::Diagonal{fine_.view()});

    densify::SolverReport report;
    if (densify::solves_at_half(params_, w)) {
      const int cw = (w + 1) / 2, ch = (h + 1) / 2;
      coarse_.resize(cw, ch);
      grid_.launch(cw, ch,
                   passes::Coarsen{fine_.view(), coarse_.view(), densify::kHalfSizeEdgeScale});
      grid_.launch(cw, ch, passes::Diagonal{coarse_.view()});
      coarse_b_.resize(static_cast<std::size_t>(cw) * ch);
      coarse_x_.resize(static_cast<std::size_t>(cw) * ch);
      grid_.launch(cw, ch, passes::Restrict{fine_b_.data(), w, h, coarse_b_.data(), cw, false});
      grid_.launch(cw, ch, passes::Restrict{fine_x_.data(), w, h, coarse_x_.data(), cw, true});
      report =
          pcg(coarse_, coarse_b_.data(), coarse_x_.data(), params_.max_iterations, coarse_space_);
      grid_.launch(w, h, passes::Prolong{coarse_x_.data(), cw, fine_x_.data(), w, false});
      gauss_seidel(fine_.view(), fine_b_.data(), fine_x_.data(), params_.fine_sweeps, true);
      if (params_.fine_iterations > 0) {
        const densify::SolverReport refined =
            pcg(fine_, fine_b_.data(), fine_x_.data(), params_.fine_iterations, fine_space_);
        report.fine_iterations = refined.iterations;
        report.output_residual = refined.final_residual;
      } else if (params_.output_residual) {
        report.output_residual =
            relative_residual(fine_.view(), fine_b_.data(), fine_x_.data(), fine_space_);
      } else {
        report.output_residual = std::numeric_limits<double>::quiet_NaN();
      }
    } else {
      report = pcg(fine_, fine_b_.data(), fine_x_.data(), params_.max_iterations, fine_space_);
      report.output_residual = report.final_residual;
    }
    // The warm start's staging buffer is free again once the solve has synchronized.
    Staging<float>& solution = upload_staging_[4];
    download_values(grid_, static_cast<const float*>(fine_x_.data()),
                    static_cast<std::size_t>(w) * h, solution);
    grid_.synchronize();
    for (int y = 0; y < h; ++y)
      std::memcpy(x.row(y), solution.data() + static_cast<std::size_t>(y) * w, w * sizeof(float));
    return report;
  }

 private:
  template <class T>
  using Buffer = typename Grid::template Buffer<T>;
  template <class T>
  using Staging = typename Grid::template Staging<T>;

  struct System {
    Buffer<float> data, wx, wy, diag, inv_diag;
    int width = 0, height = 0;
    void resize(int w, int h) {
      width = w, height = h;
      const std::size_t n = static_cast<std::size_t>(w) * h;
      for (auto* b : {&data, &wx, &wy, &diag, &inv_diag}) b->resize(n);
    }
    passes::SystemView view() {
      return {data.data(), wx.data(), wy.data(), diag.data(), inv_diag.data(), width, height};
    }
  };
  struct Level {
    System system;
    Buffer<float> b, x, r;
  };
  struct Scratch {
    Buffer<float> r, z, p, ap;
    void resize(std::size_t n) {
      for (auto* v : {&r, &z, &p, &ap}) v->resize(n);
    }
  };
  // What one size's solve keeps between frames (device buffers are reallocated whenever their
  // size changes, so the half-size solve and the full-size refinement each have their own).
  struct Workspace {
    Scratch scratch;
    std::vector<std::unique_ptr<Level>> levels;
    std::size_t level_count = 0;
    System* finest = nullptr;
    Buffer<float> fine_residual;
  };

  // densify::dot: each row's dot_row, added up in row order.
  double dot(const float* a, const float* b, int w, int h) {
    // Sized for the tallest level seen: the half-size and full-size solves alternate within a
    // frame, and a resize would reallocate (and synchronize the device) at every switch.
    if (row_dots_.size() < static_cast<std::size_t>(h)) {
      row_dots_.resize(static_cast<std::size_t>(h));
      dots_staging_.resize(static_cast<std::size_t>(h));
    }
    grid_.launch(1, h, passes::RowDots{a, b, row_dots_.data(), w});
    grid_.download(dots_staging_.data(), row_dots_.data(), h * sizeof(double));
    grid_.synchronize();
    double s = 0;
    for (int y = 0; y < h; ++y) s += dots_staging_.data()[y];
    return s;
  }

  void gauss_seidel(passes::SystemView a, const float* b, float* x, int sweeps, bool red_first) {
    const int first = red_first ? 0 : 1;
    for (int s = 0; s < sweeps; ++s) {
      grid_.launch(a.width, a.height, passes::SmoothColour{a, b, x, first});
      grid_.launch(a.width, a.height, passes::SmoothColour{a, b, x, 1 - first});
    }
  }

  // r = b - A x.
  void residual(passes::SystemView a, const float* b, const float* x, float* r) {
    grid_.launch(a.width, a.height, passes::Apply{a, x, r});
    grid_.launch(a.width, a.height, passes::Residual{b, r, r, a.width});
  }

  double relative_residual(passes::SystemView a, const float* b, const float* x, Workspace& space) {
    const std::size_t n = static_cast<std::size_t>(a.width) * a.height;
    space.scratch.resize(n);
    float* r = space.scratch.r.data();
    residual(a, b, x, r);
    const double b_norm = std::sqrt(dot(b, b, a.width, a.height));
    return b_norm > 0 ? std::sqrt(dot(r, r, a.width, a.height)) / b_norm : 0.0;
  }

  // densify::Multigrid::build: Galerkin levels until the coarsest fits kCoarsestSize.
  void build_hierarchy(System& finest, Workspace& space) {
    std::size_t n = 0;
    System* previous = &finest;
    int w = finest.width, h = finest.height;
    while (std::max(w, h) > kCoarsestSize && std::min(w, h) > 2) {
      if (space.levels.size() <= n) space.levels.push_back(std::make_unique<Level>());
      Level& level = *space.levels[n];
      const int cw = (w + 1) / 2, ch = (h + 1) / 2;
      level.system.resize(cw, ch);
      grid_.launch(cw, ch, passes::Coarsen{previous->view(), level.system.view()});
      grid_.launch(cw, ch, passes::Diagonal{level.system.view()});
      const std::size_t size = static_cast<std::size_t>(cw) * ch;
      for (auto* v : {&level.b, &level.x, &level.r}) v->resize(size);
      previous = &level.system;
      w = cw, h = ch;
      ++n;
    }
    space.level_count = n;
    space.finest = &finest;
    space.fine_residual.resize(static_cast<std::size_t>(finest.width) * finest.height);
  }

  static System& system_at(Workspace& space, std::size_t level) {
    return level == 0 ? *space.finest : space.levels[level - 1]->system;
  }

  // densify::Multigrid::cycle_at: one V-cycle from x = 0.
  void cycle_at(Workspace& space, std::size_t level, const float* b, float* x) {
    const passes::SystemView a = system_at(space, level).view();
    grid_.launch(a.width, a.height, passes::FillZero{x, a.width});
    if (level == space.level_count) {
      // 160 half-sweeps of a few hundred points: two launches instead of 160 where the level
      // fits one launch_steps block.
      if (a.width * a.height <= Grid::kMaxStepPoints) {
        grid_.launch_steps(a.width, a.height, 2 * kCoarsestSweeps,
                           passes::SmoothColours{a, b, x, 0});
        grid_.launch_steps(a.width, a.height, 2 * kCoarsestSweeps,
                           passes::SmoothColours{a, b, x, 1});
      } else {
        gauss_seidel(a, b, x, kCoarsestSweeps, true);
        gauss_seidel(a, b, x, kCoarsestSweeps, false);
      }
      return;
    }
    gauss_seidel(a, b, x, kSmoothingSweeps, true);
    float* r = level == 0 ? space.fine_residual.data() : space.levels[level - 1]->r.data();
    residual(a, b, x, r);
    Level& next = *space.levels[level];
    const passes::SystemView c = next.system.view();
    grid_.launch(c.width, c.height,
                 passes::Restrict{r, a.width, a.height, next.b.data(), c.width, false});
    cycle_at(space, level + 1, next.b.data(), next.x.data());
    grid_.launch(a.width, a.height, passes::Prolong{next.x.data(), c.width, x, a.width, true});
    gauss_seidel(a, b, x, kSmoothingSweeps, false);
  }

  void precondition(Workspace& space, const float* r, float* z, int w, int h) {
    if (params_.multigrid)
      cycle_at(space, 0, r, z);
    else
      grid_.launch(w, h, passes::Copy{r, z, w});
  }

  // densify::solve_pcg, step for step.
  densify::SolverReport pcg(System& system, const float* b, float* x, int max_iterations,
                            Workspace& space) {
    const passes::SystemView a = system.view();
    const int w = a.width, h = a.height;
    densify::SolverReport report;
    space.scratch.resize(static_cast<std::size_t>(w) * h);
    float* r = space.scratch.r.data();
    float* z = space.scratch.z.data();
    float* p = space.scratch.p.data();
    float* ap = space.scratch.ap.data();
    if (params_.multigrid) build_hierarchy(system, space);
    const double b_norm = std::sqrt(dot(b, b, w, h));
    if (b_norm == 0) {
      grid_.launch(w, h, passes::FillZero{x, w});
      report.converged = true;
      return report;
    }
    residual(a, b, x, r);
    double r_norm = std::sqrt(dot(r, r, w, h));
    report.initial_residual = r_norm / b_norm;
    report.final_residual = report.initial_residual;
    if (report.initial_residual <= params_.tolerance) {
      report.converged = true;
      return report;
    }
    precondition(space, r, z, w, h);
    grid_.launch(w, h, passes::Copy{z, p, w});
    double rz = dot(r, z, w, h);
    for (int it = 1; it <= max_iterations; ++it) {
      grid_.launch(w, h, passes::Apply{a, p, ap});
      const double pap = dot(p, ap, w, h);
      if (!(pap > 0)) break;  // breakdown: A is not positive definite on p
      const auto alpha = static_cast<float>(rz / pap);
      grid_.launch(w, h, passes::Axpy{alpha, p, x, w});
      grid_.launch(w, h, passes::Axpy{-alpha, ap, r, w});
      r_norm = std::sqrt(dot(r, r, w, h));
      report.iterations = it;
      report.final_residual = r_norm / b_norm;
      if (report.final_residual <= params_.tolerance) {
        // Residual replacement, as the CPU solver does.
        residual(a, b, x, r);
        report.final_residual = std::sqrt(dot(r, r, w, h)) / b_norm;
        if (report.final_residual <= params_.tolerance) {
          report.converged = true;
          return report;
        }
        if (it == max_iterations) break;
        precondition(space, r, z, w, h);
        grid_.launch(w, h, passes::Copy{z, p, w});
        rz = dot(r, z, w, h);
        continue;
      }
      if (it == max_iterations) break;  // the next direction would go unused
      precondition(space, r, z, w, h);
      const double rz_next = dot(r, z, w, h);
      grid_.launch(w, h, passes::UpdateDirection{z, static_cast<float>(rz_next / rz), p, w});
      rz = rz_next;
    }
    residual(a, b, x, r);
    report.final_residual = std::sqrt(dot(r, r, w, h)) / b_norm;
    report.converged = report.final_residual <= params_.tolerance;
    return report;
  }

  densify::DensifyParams params_;
  Grid grid_;
  System fine_, coarse_;
  Buffer<float> fine_b_, fine_x_, coarse_b_, coarse_x_;
  Buffer<double> row_dots_;
  Staging<double> dots_staging_;
  Staging<float> upload_staging_[5];  // data, wx, wy, b and the warm start
  Workspace coarse_space_, fine_space_;
};

}  // namespace dco::gpu
