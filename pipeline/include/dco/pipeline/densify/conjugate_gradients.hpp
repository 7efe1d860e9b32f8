#pragma once

#include "dco/core/image.hpp"
#include "dco/pipeline/densify/grid_system.hpp"
#include "dco/pipeline/densify/multigrid.hpp"

namespace dco::densify {

struct SolverReport {
  int iterations = 0;
  double initial_residual = 0;  // ||b - A x0|| / ||b||
  double final_residual = 0;    // ||b - A x|| / ||b||
  bool converged = false;
  // ||b - A x|| / ||b|| of the full-resolution system for the map that is output; equals
  // final_residual unless the system was solved at a coarser resolution. NaN after a coarser
  // solve's sweeps without DensifyParams::output_residual.
  double output_residual = 0;
  // Conjugate-gradient iterations on the full-resolution system after a coarser solve.
  int fine_iterations = 0;
};

struct CgScratch {
  Image<float> r, z, p, ap;
  SweepRows rows;
  void resize(int width, int height);
};

// Preconditioned conjugate gradients on A x = b from the initial guess in x (warm start), with
// one multigrid V-cycle as the preconditioner (or none when `mg` is null). Stops when the
// relative residual falls to `tolerance` or after `max_iterations`. solve_pcg_after_sweeps with
// no start and no sweeps.
SolverReport solve_pcg(const GridSystem& a, ImageView<const float> b, ImageView<float> x,
                       Multigrid* mg, int max_iterations, double tolerance, CgScratch& scratch);

// x = prolong(coarse_start), `sweeps` red-black Gauss-Seidel sweeps (red first), then solve_pcg:
// the same result, with the start, the sweeps and the first residual in one pass over the rows.
SolverReport solve_pcg_after_sweeps(const GridSystem& a, ImageView<const float> b,
                                    ImageView<const float> coarse_start, ImageView<float> x,
                                    int sweeps, Multigrid* mg, int max_iterations, double tolerance,
                                    CgScratch& scratch);

}  // namespace dco::densify
