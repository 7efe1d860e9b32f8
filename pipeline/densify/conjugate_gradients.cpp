#include "dco/pipeline/densify/conjugate_gradients.hpp"

#include <cmath>

namespace dco::densify {
namespace {

// y += alpha * x
void axpy(float alpha, ImageView<const float> x, ImageView<float> y) {
  for (int r = 0; r < y.height; ++r) {
    const float* xr = x.row(r);
    float* yr = y.row(r);
    for (int c = 0; c < y.width; ++c) yr[c] += alpha * xr[c];
  }
}

// p = z + beta * p
void update_direction(ImageView<const float> z, float beta, ImageView<float> p) {
  for (int r = 0; r < p.height; ++r) {
    const float* zr = z.row(r);
    float* pr = p.row(r);
    for (int c = 0; c < p.width; ++c) pr[c] = zr[c] + beta * pr[c];
  }
}

void precondition(Multigrid* mg, ImageView<const float> r, ImageView<float> z) {
  if (mg != nullptr) {
    mg->cycle(r, z);
    return;
  }
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x) z.row(y)[x] = r.row(y)[x];
}

}  // namespace

void CgScratch::resize(int width, int height) {
  r.resize(width, height);
  z.resize(width, height);
  p.resize(width, height);
  ap.resize(width, height);
}

double relative_residual(const GridSystem& a, ImageView<const float> b, ImageView<const float> x,
                         CgScratch& s) {
  s.resize(a.width(), a.height());
  apply(a, x, s.ap.view());
  for (int y = 0; y < x.height; ++y)
    for (int c = 0; c < x.width; ++c) s.r.row(y)[c] = b.row(y)[c] - s.ap.row(y)[c];
  const double b_norm = std::sqrt(dot(b, b));
  return b_norm > 0 ? std::sqrt(dot(s.r.cview(), s.r.cview())) / b_norm : 0.0;
}

SolverReport solve_pcg(const GridSystem& a, ImageView<const float> b, ImageView<float> x,
                       Multigrid* mg, int max_iterations, double tolerance, CgScratch& s) {
  SolverReport report;
  s.resize(a.width(), a.height());
  const double b_norm = std::sqrt(dot(b, b));
  if (b_norm == 0) {
    for (int y = 0; y < x.height; ++y)
      for (int c = 0; c < x.width; ++c) x.row(y)[c] = 0.0f;
    report.converged = true;
    return report;
  }
  // r = b - A x
  apply(a, x, s.r.view());
  for (int y = 0; y < x.height; ++y)
    for (int c = 0; c < x.width; ++c) s.r.row(y)[c] = b.row(y)[c] - s.r.row(y)[c];
  double r_norm = std::sqrt(dot(s.r.cview(), s.r.cview()));
  report.initial_residual = r_norm / b_norm;
  report.final_residual = report.initial_residual;
  if (report.initial_residual <= tolerance) {
    report.converged = true;
    return report;
  }
  precondition(mg, s.r.cview(), s.z.view());
  s.p.copy_from(s.z.cview());
  double rz = dot(s.r.cview(), s.z.cview());
  for (int it = 1; it <= max_iterations; ++it) {
    apply(a, s.p.cview(), s.ap.view());
    const double pap = dot(s.p.cview(), s.ap.cview());
    if (!(pap > 0)) break;  // breakdown: A is not positive definite on p
    const auto alpha = static_cast<float>(rz / pap);
    axpy(alpha, s.p.cview(), x);
    axpy(-alpha, s.ap.cview(), s.r.view());
    r_norm = std::sqrt(dot(s.r.cview(), s.r.cview()));
    report.iterations = it;
    report.final_residual = r_norm / b_norm;
    if (report.final_residual <= tolerance) {
      // The recursive residual drifts from the true one in single precision: check the true
      // residual and, if it is still too large, restart from it (residual replacement).
      apply(a, x, s.ap.view());
      for (int y = 0; y < x.height; ++y)
        for (int c = 0; c < x.width; ++c) s.r.row(y)[c] = b.row(y)[c] - s.ap.row(y)[c];
      report.final_residual = std::sqrt(dot(s.r.cview(), s.r.cview())) / b_norm;
      if (report.final_residual <= tolerance) {
        report.converged = true;
        return report;
      }
      precondition(mg, s.r.cview(), s.z.view());
      s.p.copy_from(s.z.cview());
      rz = dot(s.r.cview(), s.z.cview());
      continue;
    }
    precondition(mg, s.r.cview(), s.z.view());
    const double rz_next = dot(s.r.cview(), s.z.cview());
    update_direction(s.z.cview(), static_cast<float>(rz_next / rz), s.p.view());
    rz = rz_next;
  }
  // Report the true residual: the recursive one drifts from it in single precision.
  apply(a, x, s.ap.view());
  for (int y = 0; y < x.height; ++y)
    for (int c = 0; c < x.width; ++c) s.r.row(y)[c] = b.row(y)[c] - s.ap.row(y)[c];
  report.final_residual = std::sqrt(dot(s.r.cview(), s.r.cview())) / b_norm;
  report.converged = report.final_residual <= tolerance;
  return report;
}

}  // namespace dco::densify
