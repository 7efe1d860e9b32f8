#pragma once

#include <cmath>
#include <vector>

#include "dco/core/image.hpp"
#include "dco/pipeline/densify/grid_system.hpp"
#include "dco/pipeline/densify/sweep_rows.hpp"

namespace dco::densify {

// Symmetric multigrid V-cycle for a GridSystem, used as the preconditioner of conjugate
// gradients. Coarse levels are Galerkin operators of piecewise-constant 2x2 aggregation
// (P^T A P), which keep the 5-point form: data terms add up, and the edges between two
// aggregates add up, so a contour that cuts the fine grid (w = 0) still cuts the coarse grids.
// Smoothing is red-black Gauss-Seidel, red then black before the coarse correction and black
// then red after it, so the cycle is a symmetric operator.
class Multigrid {
 public:
  // Defaults, shared with the GPU solver (gpu/grid_system_solver.hpp), which must follow the
  // same steps. Three sweeps each side: on the 1280x720 hand the half-size solve then reaches
  // the tolerance in two iterations instead of three with two sweeps, 0.6-1 ms sooner
  // (bench/RESULTS.md).
  static constexpr int kCoarsestSize = 24;
  static constexpr int kSmoothingSweeps = 3;
  static constexpr int kCoarsestSweeps = 40;

  // Builds the hierarchy for `fine` (kept by reference: it must outlive the next cycle).
  // Levels are added until the coarsest is at most `coarsest_size` pixels on its longer side.
  void build(const GridSystem& fine, int coarsest_size = kCoarsestSize);

  // z ≈ A^{-1} r with one V-cycle from z = 0.
  void cycle(ImageView<const float> r, ImageView<float> z);
  // The same cycle, returning dot(r, z) (as densify::dot computes it) without a pass of its own.
  double cycle_dot(ImageView<const float> r, ImageView<float> z);

  int levels() const { return static_cast<int>(levels_.size()) + 1; }
  // The system of level 1 .. levels() - 1 (coarsen of the level above it).
  const GridSystem& coarse_system(int level) const { return system_at(level); }

  int smoothing_sweeps = kSmoothingSweeps;
  int coarsest_sweeps = kCoarsestSweeps;

 private:
  struct Level {
    GridSystem system;
    Image<float> b, x;
  };
  // With `dot`, adds dot(b, x) of the result to *dot.
  void cycle_at(int level, ImageView<const float> b, ImageView<float> x, double* dot);
  const GridSystem& system_at(int level) const {
    return level == 0 ? *fine_ : levels_[static_cast<std::size_t>(level - 1)].system;
  }

  const GridSystem* fine_ = nullptr;
  std::vector<Level> levels_;  // coarse levels 1..n
  std::vector<float> residual_row_;
  SweepRows rows_;
};

// Red-black Gauss-Seidel sweeps on A x = b; `red_first` picks the colour order. `rows` is working
// memory, kept across calls.
void gauss_seidel(const GridSystem& a, ImageView<const float> b, ImageView<float> x, int sweeps,
                  bool red_first, SweepRows& rows);

// gauss_seidel with x starting as prolong(coarse_start), a row at a time in the same pass.
void gauss_seidel_from_coarse(const GridSystem& a, ImageView<const float> b, ImageView<float> x,
                              int sweeps, bool red_first, SweepRows& rows,
                              ImageView<const float> coarse_start);

// dot(r, r) and dot(b, b) of a residual r = b - A x.
struct ResidualNorms {
  double rr = 0, bb = 0;
  // ||r|| / ||b||, 0 when b is 0.
  double relative() const { return bb > 0 ? std::sqrt(rr) / std::sqrt(bb) : 0.0; }
};

// gauss_seidel, then r = b - A x, in the same pass over the rows (each residual row as soon as
// its rows are final); returns dot(r, r) and dot(b, b). An empty `r`: only the norms, each
// residual row in a row of `rows` instead of an image. With `coarse_start`, x starts as
// prolong(coarse_start), also a row at a time in that pass.
ResidualNorms gauss_seidel_residual(const GridSystem& a, ImageView<const float> b,
                                    ImageView<float> x, int sweeps, bool red_first,
                                    ImageView<float> r, SweepRows& rows,
                                    ImageView<const float> coarse_start = {});

// The Galerkin coarse system of 2x2 piecewise-constant aggregation; coarse size is
// ceil(w/2) x ceil(h/2). The coarse edge weights are multiplied by `edge_scale` (see
// kHalfSizeEdgeScale).
void coarsen(const GridSystem& fine, GridSystem& coarse, float edge_scale = 1.0f);

// `scaled` = `system` with its edge weights multiplied by `edge_scale`: what coarsen with that
// scale gives when `system` is coarsen's result with scale 1.
void scale_edges(const GridSystem& system, GridSystem& scaled, float edge_scale);

// The Galerkin operator is exact for fields constant on each aggregate, but for a smooth field
// it doubles the smoothness energy: each coarse edge sums two fine edges while a coarse step
// spans two fine steps, and the aggregates' inner edges carry half of the gradient too. Halving
// the coarse edges makes the aggregated system the same energy at half size (exact for linear
// fields), which is what a solve at half size wants; a preconditioner wants the plain operator.
inline constexpr float kHalfSizeEdgeScale = 0.5f;

// The transfers that go with `coarsen` (P: piecewise constant over each 2x2 aggregate):
// coarse = P^T fine (sum of the children), coarse = mean of the children, fine = P coarse.
void restrict_sum(ImageView<const float> fine, ImageView<float> coarse);
void restrict_mean(ImageView<const float> fine, ImageView<float> coarse);
void prolong(ImageView<const float> coarse, ImageView<float> fine);

}  // namespace dco::densify
