#include <limits>

#include "dco/pipeline/densify/densifier.hpp"
#include "dco/pipeline/densify/multigrid.hpp"
#include "dco/pipeline/densify/system_solver.hpp"

namespace dco::densify {
namespace {

class CpuSystemSolver final : public SystemSolver {
 public:
  explicit CpuSystemSolver(const DensifyParams& params) : params_(params) {}

  // At half size with sweeps alone the full system is coarsened (data and weights) and swept
  // (SweepRows works each row's diagonal out as it loads it). The output's residual without a
  // sweep reads the system's rows as they are, diagonal included.
  bool needs_diagonal(int width) const override {
    if (!solves_at_half(params_, width) || params_.fine_iterations > 0) return true;
    return params_.output_residual && params_.fine_sweeps <= 0;
  }

  SolverReport solve(const GridSystem& a, ImageView<const float> b, ImageView<float> x) override {
    if (solves_at_half(params_, a.width())) return solve_at_half(a, b, x);
    if (params_.multigrid) multigrid_.build(a);
    SolverReport report = solve_pcg(a, b, x, params_.multigrid ? &multigrid_ : nullptr,
                                    params_.max_iterations, params_.tolerance, scratch_);
    report.output_residual = report.final_residual;
    return report;
  }

 private:
  SolverReport solve_at_half(const GridSystem& a, ImageView<const float> b, ImageView<float> x) {
    // The full system's memory traffic bounds every pass over it; the aggregated system has a
    // quarter of the pixels and stays in cache, and the Galerkin operator keeps the contour cuts.
    // The full-size iterations' hierarchy has that aggregate as its level 1: built first, it
    // saves a pass over the full system.
    const bool fine_multigrid = params_.fine_iterations > 0 && params_.multigrid;
    if (fine_multigrid) fine_multigrid_.build(a);
    if (fine_multigrid && fine_multigrid_.levels() > 1)
      scale_edges(fine_multigrid_.coarse_system(1), coarse_, kHalfSizeEdgeScale);
    else
      coarsen(a, coarse_, kHalfSizeEdgeScale);
    const int cw = coarse_.width();
    const int ch = coarse_.height();
    coarse_rhs_.resize(cw, ch);
    coarse_solution_.resize(cw, ch);
    restrict_sum(b, coarse_rhs_.view());
    restrict_mean(x, coarse_solution_.view());  // warm start
    if (params_.multigrid) multigrid_.build(coarse_);
    SolverReport report = solve_pcg(coarse_, coarse_rhs_.cview(), coarse_solution_.view(),
                                    params_.multigrid ? &multigrid_ : nullptr,
                                    params_.max_iterations, params_.tolerance, scratch_);
    // The sweeps and iterations at full size put the detail inside each 2x2 block back: a
    // contour through a block, an edge of the image guidance, a single sparse pixel.
    // One pass over the rows prolongs the half-size solution, does all the sweeps (red then
    // black each time) and the residual the iterations start from.
    if (params_.fine_iterations > 0) {
      const SolverReport fine =
          solve_pcg_after_sweeps(a, b, coarse_solution_.cview(), x, params_.fine_sweeps,
                                 params_.multigrid ? &fine_multigrid_ : nullptr,
                                 params_.fine_iterations, params_.tolerance, scratch_);
      report.fine_iterations = fine.iterations;
      report.output_residual = fine.final_residual;
    } else if (params_.output_residual) {
      report.output_residual = gauss_seidel_residual(a, b, x, params_.fine_sweeps, true, {},
                                                     scratch_.rows, coarse_solution_.cview())
                                   .relative();
    } else {
      gauss_seidel_from_coarse(a, b, x, params_.fine_sweeps, true, scratch_.rows,
                               coarse_solution_.cview());
      report.output_residual = std::numeric_limits<double>::quiet_NaN();
    }
    return report;
  }

  DensifyParams params_;
  Multigrid multigrid_;
  Multigrid fine_multigrid_;  // kept apart: rebuilding one hierarchy at two sizes reallocates
  CgScratch scratch_;
  GridSystem coarse_;
  Image<float> coarse_rhs_, coarse_solution_;
};

}  // namespace

bool solves_at_half(const DensifyParams& params, int width) {
  return params.solve_resolution == "half" || (params.solve_resolution == "auto" && width > 640);
}

std::unique_ptr<SystemSolver> make_cpu_system_solver(const DensifyParams& params) {
  return std::make_unique<CpuSystemSolver>(params);
}

std::unique_ptr<SystemSolver> make_system_solver(const SystemSolverFactory& factory,
                                                 const DensifyParams& params) {
  return factory ? factory(params) : make_cpu_system_solver(params);
}

}  // namespace dco::densify
