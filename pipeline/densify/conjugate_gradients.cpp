#include "dco/pipeline/densify/conjugate_gradients.hpp"

#include <algorithm>
#include <cmath>

namespace dco::densify {
namespace {

// x += alpha p and r += (-alpha) A p in one sweep; returns dot(r, r).
double step(float alpha, ImageView<const float> p, ImageView<const float> ap, ImageView<float> x,
            ImageView<float> r) {
  const int w = x.width;
  double s = 0;
  for (int y = 0; y < x.height; ++y) {
    const float* pr = p.row(y);
    const float* apr = ap.row(y);
    float* xr = x.row(y);
    float* rr = r.row(y);
    for (int c = 0; c < w; ++c) xr[c] += alpha * pr[c];
    for (int c = 0; c < w; ++c) rr[c] += -alpha * apr[c];
    s += kernels::dot_row(rr, rr, w);
  }
  return s;
}

// p = z + beta p, ap = A p; returns dot(p, ap). Row y of A p reads rows y - 1 .. y + 1 of the
// new p, so the update runs one row ahead.
double update_apply_dot(const GridSystem& a, ImageView<const float> z, float beta,
                        ImageView<float> p, ImageView<float> ap) {
  const int w = p.width;
  const int h = p.height;
  const auto update = [&](int y) {
    const float* zr = z.row(y);
    float* pr = p.row(y);
    for (int c = 0; c < w; ++c) pr[c] = zr[c] + beta * pr[c];
  };
  double s = 0;
  update(0);
  for (int y = 0; y < h; ++y) {
    if (y + 1 < h) update(y + 1);
    apply_row(a, p, y, ap.row(y));
    s += kernels::dot_row(p.row(y), ap.row(y), w);
  }
  return s;
}

// z = M^-1 r; returns dot(r, z).
double precondition(Multigrid* mg, ImageView<const float> r, ImageView<float> z) {
  if (mg != nullptr) return mg->cycle_dot(r, z);
  double s = 0;
  for (int y = 0; y < r.height; ++y) {
    std::copy(r.row(y), r.row(y) + r.width, z.row(y));
    s += kernels::dot_row(r.row(y), z.row(y), r.width);
  }
  return s;
}

}  // namespace

void CgScratch::resize(int width, int height) {
  r.resize(width, height);
  z.resize(width, height);
  p.resize(width, height);
  ap.resize(width, height);
}

SolverReport solve_pcg(const GridSystem& a, ImageView<const float> b, ImageView<float> x,
                       Multigrid* mg, int max_iterations, double tolerance, CgScratch& s) {
  return solve_pcg_after_sweeps(a, b, {}, x, 0, mg, max_iterations, tolerance, s);
}

SolverReport solve_pcg_after_sweeps(const GridSystem& a, ImageView<const float> b,
                                    ImageView<const float> coarse_start, ImageView<float> x,
                                    int sweeps, Multigrid* mg, int max_iterations, double tolerance,
                                    CgScratch& s) {
  SolverReport report;
  s.resize(a.width(), a.height());
  const ResidualNorms start =
      gauss_seidel_residual(a, b, x, sweeps, true, s.r.view(), s.rows, coarse_start);
  const double b_norm = std::sqrt(start.bb);
  if (b_norm == 0) {
    for (int y = 0; y < x.height; ++y)
      for (int c = 0; c < x.width; ++c) x.row(y)[c] = 0.0f;
    report.converged = true;
    return report;
  }
  double r_norm = std::sqrt(start.rr);
  report.initial_residual = r_norm / b_norm;
  report.final_residual = report.initial_residual;
  if (report.initial_residual <= tolerance) {
    report.converged = true;
    return report;
  }
  double rz = precondition(mg, s.r.cview(), s.z.view());
  bool restart = true;  // the next direction is z itself, else z + beta p
  float beta = 0.0f;
  for (int it = 1; it <= max_iterations; ++it) {
    double pap = 0;
    if (restart) {
      s.p.swap(s.z);  // p = z; z is written again before it is read
      pap = apply_dot(a, s.p.cview(), s.ap.view());
    } else {
      pap = update_apply_dot(a, s.z.cview(), beta, s.p.view(), s.ap.view());
    }
    restart = false;
    if (!(pap > 0)) break;  // breakdown: A is not positive definite on p
    const auto alpha = static_cast<float>(rz / pap);
    report.iterations = it;
    if (it == max_iterations) {
      // The last step ends with the true residual whatever the recursive one says (residual
      // replacement below, or the report after the loop): it is computed in the step's pass.
      // Stopping here also spares the V-cycle of a direction that would go unused.
      r_norm = std::sqrt(step_residual_dot(a, b, alpha, s.p.cview(), x, s.r.view()));
      report.final_residual = r_norm / b_norm;
      report.converged = report.final_residual <= tolerance;
      return report;
    }
    r_norm = std::sqrt(step(alpha, s.p.cview(), s.ap.cview(), x, s.r.view()));
    report.final_residual = r_norm / b_norm;
    if (report.final_residual <= tolerance) {
      // The recursive residual drifts from the true one in single precision: check the true
      // residual and, if it is still too large, restart from it (residual replacement).
      report.final_residual = std::sqrt(residual_dot(a, b, x, s.r.view())) / b_norm;
      if (report.final_residual <= tolerance) {
        report.converged = true;
        return report;
      }
      rz = precondition(mg, s.r.cview(), s.z.view());
      restart = true;
      continue;
    }
    const double rz_next = precondition(mg, s.r.cview(), s.z.view());
    beta = static_cast<float>(rz_next / rz);
    rz = rz_next;
  }
  // Report the true residual: the recursive one drifts from it in single precision.
  report.final_residual = std::sqrt(residual_dot(a, b, x, s.r.view())) / b_norm;
  report.converged = report.final_residual <= tolerance;
  return report;
}

}  // namespace dco::densify
