#pragma once

#include <functional>
#include <memory>

#include "dco/core/image.hpp"
#include "dco/pipeline/densify/conjugate_gradients.hpp"
#include "dco/pipeline/densify/grid_system.hpp"

namespace dco::densify {

struct DensifyParams;

// Solves the densifier's system A x = b the way DensifyParams say: at full or half resolution
// (the latter then refined by Gauss-Seidel sweeps and CG iterations at full size),
// multigrid-preconditioned or plain conjugate gradients, up to max_iterations or the tolerance. x
// holds the warm start on entry and the solution on return.
class SystemSolver {
 public:
  virtual ~SystemSolver() = default;
  virtual SolverReport solve(const GridSystem& a, ImageView<const float> b, ImageView<float> x) = 0;
  // Whether solve reads the diagonal images of a system `width` pixels wide (GridSystem::diag,
  // inv_diag); when not, the caller may leave them out (has_diagonal false).
  virtual bool needs_diagonal(int /*width*/) const { return true; }
};

// Makes the solver of a backend (CPU, CUDA); an empty factory means the CPU one.
using SystemSolverFactory = std::function<std::unique_ptr<SystemSolver>(const DensifyParams&)>;
std::unique_ptr<SystemSolver> make_cpu_system_solver(const DensifyParams& params);
std::unique_ptr<SystemSolver> make_system_solver(const SystemSolverFactory& factory,
                                                 const DensifyParams& params);

// Whether a frame `width` pixels wide is solved at half resolution under `params`.
bool solves_at_half(const DensifyParams& params, int width);

}  // namespace dco::densify
