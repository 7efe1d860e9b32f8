#include "dco/pipeline/densify/multigrid.hpp"

#include <algorithm>
#include <cassert>

namespace dco::densify {
namespace {

// coarse_row[x / 2] += fine_row[x] in the order of x: one fine row's share of restrict_sum.
// kFirst for a coarse row's first fine row: its sums start from 0.0f (the same bits as adding to
// a row filled with zeros first, without the pass that fills it). Written per parent, so the
// compiler vectorises it.
template <bool kFirst>
void add_to_parents(const float* fine_row, int width, float* coarse_row) {
  const int pairs = width / 2;
  for (int c = 0; c < pairs; ++c) {
    float sum = kFirst ? 0.0f : coarse_row[c];
    sum += fine_row[2 * c];
    sum += fine_row[2 * c + 1];
    coarse_row[c] = sum;
  }
  if (width % 2 != 0) coarse_row[pairs] = (kFirst ? 0.0f : coarse_row[pairs]) + fine_row[width - 1];
}

// add_to_parents<true> for even fine rows, <false> for odd ones.
void add_row_to_parents(const float* fine_row, int y, int width, float* coarse_row) {
  if (y % 2 == 0)
    add_to_parents<true>(fine_row, width, coarse_row);
  else
    add_to_parents<false>(fine_row, width, coarse_row);
}

// coarse_row[c] += fine_row[2 c + 1] for c < count: the edges from each aggregate's right
// column to the next aggregate (restrict pointers: the compiler vectorises it). kFirst as
// above, and the coarse row's other columns [count, coarse_width) set to 0.
template <bool kFirst>
void add_odd_columns(const float* __restrict fine_row, int count, int coarse_width,
                     float* __restrict coarse_row) {
  for (int c = 0; c < count; ++c)
    coarse_row[c] = (kFirst ? 0.0f : coarse_row[c]) + fine_row[2 * c + 1];
  if (kFirst) std::fill(coarse_row + count, coarse_row + coarse_width, 0.0f);
}

// fine_row[x] (+)= coarse_row[x / 2].
template <bool kAdd>
void from_parents(const float* coarse_row, int width, float* fine_row) {
  const int pairs = width / 2;
  for (int c = 0; c < pairs; ++c) {
    const float v = coarse_row[c];
    fine_row[2 * c] = kAdd ? fine_row[2 * c] + v : v;
    fine_row[2 * c + 1] = kAdd ? fine_row[2 * c + 1] + v : v;
  }
  if (width % 2 != 0)
    fine_row[width - 1] = kAdd ? fine_row[width - 1] + coarse_row[pairs] : coarse_row[pairs];
}

}  // namespace

void restrict_sum(ImageView<const float> fine, ImageView<float> coarse) {
  for (int y = 0; y < fine.height; ++y)
    add_row_to_parents(fine.row(y), y, fine.width, coarse.row(y / 2));
}

void restrict_mean(ImageView<const float> fine, ImageView<float> coarse) {
  restrict_sum(fine, coarse);
  // Aggregates on an odd last row or column have fewer than four children.
  for (int y = 0; y < coarse.height; ++y) {
    const int rows = std::min(2, fine.height - 2 * y);
    float* c = coarse.row(y);
    for (int x = 0; x < coarse.width; ++x)
      c[x] /= static_cast<float>(rows * std::min(2, fine.width - 2 * x));
  }
}

void prolong(ImageView<const float> coarse, ImageView<float> fine) {
  for (int y = 0; y < fine.height; ++y)
    from_parents<false>(coarse.row(y / 2), fine.width, fine.row(y));
}

void coarsen(const GridSystem& fine, GridSystem& coarse, float edge_scale) {
  const int w = fine.width();
  const int h = fine.height();
  const int cw = (w + 1) / 2;
  const int ch = (h + 1) / 2;
  coarse.resize(cw, ch);
  for (int y = 0; y < h; ++y) {
    const float* d = fine.data.row(y);
    const float* ex = fine.wx.row(y);
    const float* ey = fine.wy.row(y);
    float* cd = coarse.data.row(y / 2);
    float* cex = coarse.wx.row(y / 2);
    float* cey = coarse.wy.row(y / 2);
    add_row_to_parents(d, y, w, cd);
    // Only edges that leave the aggregate survive: odd column -> next aggregate, odd row -> next.
    if (y % 2 == 0)
      add_odd_columns<true>(ex, (w - 1) / 2, cw, cex);
    else
      add_odd_columns<false>(ex, (w - 1) / 2, cw, cex);
    if (y % 2 == 1 && y + 1 < h) add_to_parents<true>(ey, w, cey);
  }
  // The last coarse row has no odd fine row with a row below it: no edges leave it downwards.
  std::fill(coarse.wy.row(ch - 1), coarse.wy.row(ch - 1) + cw, 0.0f);
  if (edge_scale != 1.0f) {
    for (int y = 0; y < ch; ++y) {
      float* cex = coarse.wx.row(y);
      float* cey = coarse.wy.row(y);
      for (int x = 0; x < cw; ++x) cex[x] *= edge_scale, cey[x] *= edge_scale;
    }
  }
  coarse.update_diagonal();
}

void scale_edges(const GridSystem& system, GridSystem& scaled, float edge_scale) {
  const int w = system.width();
  const int h = system.height();
  scaled.resize(w, h);
  scaled.data.copy_from(system.data.cview());
  for (int y = 0; y < h; ++y) {
    const float* ex = system.wx.row(y);
    const float* ey = system.wy.row(y);
    float* sx = scaled.wx.row(y);
    float* sy = scaled.wy.row(y);
    for (int x = 0; x < w; ++x) sx[x] = ex[x] * edge_scale, sy[x] = ey[x] * edge_scale;
  }
  scaled.update_diagonal();
}

namespace {

// gauss_seidel, with prepare(row) called once for every row, in order, before any update reads it,
// and finish(row) once for every row, in order, as soon as neither it nor a row next to it will
// change again.
template <class Prepare, class Finish>
void gauss_seidel_rows(const GridSystem& a, ImageView<const float> b, ImageView<float> x,
                       int sweeps, bool red_first, SweepRows& rows, Prepare&& prepare,
                       Finish&& finish) {
  const int h = a.height();
  if (h == 0) return;
  // At step r the rows from r - 2 sweeps - 1 (above the row `finish` gets, which may read the
  // rows next to it from the slots) to r + 1 are in use.
  rows.start(a.width(), h, 2 * std::max(sweeps, 0) + 3);
  if (sweeps <= 0) {
    prepare(0);
    for (int r = 0; r < h; ++r) {
      if (r + 1 < h) prepare(r + 1);
      finish(r);
    }
    return;
  }
  // The updates work on split copies of the rows: a row is copied in after prepare and back out
  // right after its last update, before finish reads it.
  const auto load = [&](int r) {
    prepare(r);
    rows.load(a, b, x, r);
  };
  const auto smooth = [&](int r, int colour) { rows.smooth(r, (r + colour) % 2); };
  const int first = red_first ? 0 : 1;
  // One pass over the rows does every colour of every sweep (this keeps the few rows involved in
  // cache). Sweep s updates the first colour of row r - 2s and then the second colour of the row
  // above it: by then the values each update reads (its row and the rows next to it) are exactly
  // those the plain order, colour by colour and sweep by sweep, would give it, so the result is
  // identical. Row r - 2 sweeps + 1 has just had its last update, and the rows next to row
  // r - 2 sweeps theirs.
  load(0);
  for (int r = 0; r < h + 2 * sweeps; ++r) {
    if (r + 1 < h) load(r + 1);  // row r's first update reads row r + 1
    for (int s = 0; s < sweeps; ++s) {
      const int row = r - 2 * s;
      if (row >= 0 && row < h) smooth(row, first);
      if (row >= 1 && row <= h) smooth(row - 1, 1 - first);
    }
    const int done = r - 2 * sweeps + 1;
    if (done >= 0 && done < h) rows.store(done, x);
    if (r >= 2 * sweeps) finish(r - 2 * sweeps);
  }
}

void no_row_work(int) {}

// The prepare(row) of gauss_seidel_rows that starts each row of x as prolong(coarse_start)
// (nothing when coarse_start is empty).
auto prolonged_start(ImageView<const float> coarse_start, ImageView<float> x) {
  return [coarse_start, x](int y) {
    if (!coarse_start.empty()) from_parents<false>(coarse_start.row(y / 2), x.width, x.row(y));
  };
}

}  // namespace

void gauss_seidel(const GridSystem& a, ImageView<const float> b, ImageView<float> x, int sweeps,
                  bool red_first, SweepRows& rows) {
  gauss_seidel_rows(a, b, x, sweeps, red_first, rows, no_row_work, no_row_work);
}

void gauss_seidel_from_coarse(const GridSystem& a, ImageView<const float> b, ImageView<float> x,
                              int sweeps, bool red_first, SweepRows& rows,
                              ImageView<const float> coarse_start) {
  gauss_seidel_rows(a, b, x, sweeps, red_first, rows, prolonged_start(coarse_start, x),
                    no_row_work);
}

ResidualNorms gauss_seidel_residual(const GridSystem& a, ImageView<const float> b,
                                    ImageView<float> x, int sweeps, bool red_first,
                                    ImageView<float> r, SweepRows& rows,
                                    ImageView<const float> coarse_start) {
  const int w = a.width();
  ResidualNorms n;
  const auto residual_row_norms = [&](int y) {
    float* out = r.empty() ? rows.spare_row() : r.row(y);
    // After sweeps the rows are still in the slots: no second read of the system's rows.
    if (sweeps > 0)
      rows.residual(y, out);
    else
      residual_row(a, b, x, y, out);
    n.rr += kernels::dot_row(out, out, w);
    n.bb += kernels::dot_row(b.row(y), b.row(y), w);
  };
  gauss_seidel_rows(a, b, x, sweeps, red_first, rows, prolonged_start(coarse_start, x),
                    residual_row_norms);
  return n;
}

void Multigrid::build(const GridSystem& fine, int coarsest_size) {
  fine_ = &fine;
  residual_row_.resize(static_cast<std::size_t>(fine.width()));  // the widest level
  std::size_t n = 0;
  int w = fine.width(), h = fine.height();
  levels_.reserve(32);  // `previous` points into levels_: it must not reallocate
  const GridSystem* previous = &fine;
  while (std::max(w, h) > coarsest_size && std::min(w, h) > 2) {
    if (levels_.size() <= n) levels_.emplace_back();
    Level& level = levels_[n];
    coarsen(*previous, level.system);
    w = level.system.width();
    h = level.system.height();
    level.b.resize(w, h);
    level.x.resize(w, h);
    previous = &level.system;
    ++n;
  }
  levels_.resize(n);
}

void Multigrid::cycle(ImageView<const float> r, ImageView<float> z) {
  cycle_at(0, r, z, nullptr);
}

double Multigrid::cycle_dot(ImageView<const float> r, ImageView<float> z) {
  double dot = 0;
  cycle_at(0, r, z, &dot);
  return dot;
}

void Multigrid::cycle_at(int level, ImageView<const float> b, ImageView<float> x, double* dot) {
  const GridSystem& a = system_at(level);
  const int w = a.width();
  // The passes over a level's system bound the cycle's time, so the work that needs its rows
  // rides in the smoothing passes: the zero start, the restriction of the residual and the dot
  // product with b are done a row at a time, each as soon as its rows are ready.
  const auto zero_row = [&](int y) { std::fill(x.row(y), x.row(y) + w, 0.0f); };
  const auto add_dot = [&](int y) {
    if (dot != nullptr) *dot += kernels::dot_row(b.row(y), x.row(y), w);
  };
  if (level + 1 == levels()) {
    gauss_seidel_rows(a, b, x, coarsest_sweeps, true, rows_, zero_row, no_row_work);
    gauss_seidel_rows(a, b, x, coarsest_sweeps, false, rows_, no_row_work, add_dot);
    return;
  }
  // coarse b = restrict_sum(b - A x) after the pre-smoothing; the fine residual is never stored.
  Level& next = levels_[static_cast<std::size_t>(level)];
  const auto restrict_row = [&](int y) {  // rows in order: each coarse row's even row first
    if (smoothing_sweeps > 0)
      rows_.residual(y, residual_row_.data());
    else
      residual_row(a, b, x, y, residual_row_.data());
    add_row_to_parents(residual_row_.data(), y, w, next.b.row(y / 2));
  };
  gauss_seidel_rows(a, b, x, smoothing_sweeps, /*red_first=*/true, rows_, zero_row, restrict_row);
  cycle_at(level + 1, next.b.view(), next.x.view(), nullptr);
  // x += P x_coarse, a row at a time just before the smoother first reads it.
  const ImageView<const float> coarse = next.x.cview();
  const auto prolong_row = [&](int y) { from_parents<true>(coarse.row(y / 2), w, x.row(y)); };
  gauss_seidel_rows(a, b, x, smoothing_sweeps, /*red_first=*/false, rows_, prolong_row, add_dot);
}

}  // namespace dco::densify
