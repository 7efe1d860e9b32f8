#pragma once

#include <cstdint>

// Row kernels of the densify solver: the 5-point system of dco::densify::GridSystem. Every
// function in dco::kernels dispatches at run time to the best SIMD target (see
// stereo_kernels.hpp); the functions of the same name in dco::kernels::scalar are the plain
// references. The vector versions do the same float operations in the same order (no fused
// multiply-add), so their results are bit-identical to the references.

namespace dco::kernels {

// One row y of a system (A x)(p) = diag(p) x(p) - Σ_{q ∈ N4(p)} w(p,q) x(q).
struct GridRow {
  int width = 0;
  const float* diag = nullptr;      // used by grid_apply_row
  const float* inv_diag = nullptr;  // 1 / diag, 0 where diag is 0; used by the smoothing
  const float* wx = nullptr;        // wx[c] couples (c, y) and (c + 1, y)
  // The row below and its couplings wy[c] of (c, y) with (c, y + 1); both null on the last row.
  const float* wy = nullptr;
  const float* x_below = nullptr;
  // The row above and the couplings of (c, y - 1) with (c, y); both null on the first row.
  const float* wy_above = nullptr;
  const float* x_above = nullptr;
};

// out = (A x) of row y; x is row y of the same vector as row.x_above and row.x_below.
void grid_apply_row(const GridRow& row, const float* x, float* out);

// One colour of row y of a system whose rows are stored split by column parity: pixel i of
// parity p is column 2 i + p, so the pixels of one colour of a row are the pixels of one parity.
// Their left and right neighbours are pixels i + p - 1 and i + p of the other parity. Every
// pointer is to the row's pixels of `parity` unless it says "other".
struct SplitSmoothRow {
  int width = 0;   // of the whole row
  int parity = 0;  // 0: columns 0, 2, 4, ...; 1: columns 1, 3, ...
  const float* b = nullptr;
  const float* inv_diag = nullptr;
  const float* wx = nullptr;        // couples the pixel with its right neighbour
  const float* wx_other = nullptr;  // wx of the other parity: [i + p - 1] is the left edge
  const float* x_other = nullptr;   // x of the other parity: the neighbours in the row
  const float* wy = nullptr;        // as in GridRow, both null on the last row
  const float* x_below = nullptr;
  const float* wy_above = nullptr;  // as in GridRow, both null on the first row
  const float* x_above = nullptr;
};

// Pixels of parity p in a row of `width`.
constexpr int parity_count(int width, int parity) {
  return (width + 1 - parity) / 2;
}

// The Gauss-Seidel update of one colour of a row in the split layout (scalar::grid_smooth_row
// in the plain one): x[i] = (b[i] + Σ w x(neighbour)) * inv_diag[i] for the
// parity_count(width, parity) pixels of the row's parity; the same operations in the same order
// as scalar::grid_smooth_row, so the same bits. Every operand is a contiguous run of floats.
void grid_smooth_split_row(const SplitSmoothRow& row, float* x);

// One colour of row y of the residual b - A x in the split layout: `row` as for the smoothing
// (its inv_diag unused), and the colour's own pixels of x and of the diagonal.
struct SplitResidualRow {
  SplitSmoothRow row;
  const float* diag = nullptr;
  const float* x = nullptr;
};

// out[i] = (b - A x) at the parity_count(width, parity) pixels of the row's colour: the same
// operations in the same order as grid_apply_row followed by b minus its result, so the same
// bits as the residual of the plain layout.
void split_residual_row(const SplitResidualRow& row, float* out);

// inv[i] = 1 / diag[i], 0 where diag[i] <= 0 (GridSystem::inv_diag's rule), for n values.
void inverse_diagonal_row(const float* diag, int n, float* inv);

// even[i] = in[2 i], odd[i] = in[2 i + 1]: a row into the split layout.
void split_row(const float* in, int width, float* even, float* odd);
// The inverse of split_row.
void merge_row(const float* even, const float* odd, int width, float* out);

// Σ a[i] b[i] over n values: sixteen float partial sums (lane i % 16), plus the last n % 16
// products in double, all added up in double.
double dot_row(const float* a, const float* b, int n);

// The sums of the densifier's match planes (dco/pipeline/densify/match_planes.hpp), one pass per
// window row or column offset so that each loaded value updates every sum at once. Each sum
// adds products in offset order (a product, then a sum: no fused multiply-add), so every target
// gives the scalar reference's bits.
//
// Row sums of a grid row of n pixels: sums = six arrays of n floats (Σ1, Σu, Σu², Σd, Σud, Σd²
// over the matches within `radius` columns, u the column offset k), from the row's match flags
// (1 or 0), offset disparities and their squares. sums[j][x] = Σ_k f_j(k) in_j[x + k] for the
// k in -radius..radius with x + k inside the row, added in that order from 0.
void match_plane_row_sums(const float* match, const float* d, const float* dd, int n, int radius,
                          float* sums);
// The ten window sums (Σ1, Σu, Σv, Σu², Σuv, Σv², Σd, Σud, Σvd, Σd², each n floats) from the six
// row sums of the window's rows at offsets v = -radius..radius (rows[v + radius]; nullptr for a
// row outside the image), each sum added up from 0 in that order.
void match_plane_window_sums(const float* const* rows, int radius, int n, float* sums);
// The same ten sums for the window one row further down, from those of the window above it
// (`sums`, updated in place) and the rows of the new window (rows[v + radius] as above) plus the
// row that left it (`left`, nullptr for none). The sums whose row sums are whole numbers (Σ1,
// Σu, Σu²: match counts and column offsets, exact in any order) are moved by the rows that
// left and entered; the four with disparities are added up afresh as match_plane_window_sums
// does. So the result has match_plane_window_sums' bits whenever the first three row sums of
// every row are whole numbers and every sum and product the move forms stays below 2^24 in
// magnitude (in the densifier's windows, at most 31 x 31 pixels, all stay below 2^17).
void match_plane_window_slide(const float* const* rows, const float* left, int radius, int n,
                              float* sums);

// The densifier's match planes (dco/pipeline/densify/match_planes.hpp): from the ten window sums
// of each of n grid pixels (`sums`: Σ1, Σu, Σv, Σu², Σuv, Σv², Σd, Σud, Σvd, Σd², each n floats,
// one array after the other; d offset by rule.offset) and the pixel's own value, plane[i] =
// pixel::match_plane(...): the plane's value at the pixel, or NaN where no plane is kept.
struct MatchPlaneRule {
  float offset = 0;      // added back to the plane's offset disparity
  float min_count = 0;   // matches the window must hold
  float max_square = 0;  // largest mean squared distance of the matches to their plane
};
void match_plane_row(const float* sums, const float* own, int n, const MatchPlaneRule& rule,
                     float* plane);
// The planes back at the input resolution with half-size matching: for an input row whose grid
// row (every second pixel) holds `own` and `plane` ((width + 1) / 2 values each), out[x] =
// plane[x / 2] where sparse[x] equals own[x / 2] and a plane was kept (not NaN), else sparse[x].
void match_plane_select_half_row(const float* sparse, const float* own, const float* plane,
                                 int width, float* out);

// The pixels at both ends of a run of smoothness edges: edge i joins pixel i of the "a" rows with
// pixel i of the "b" rows (for the edges within a row, b is a one column further on).
struct EdgeEnds {
  const std::uint8_t* barrier_a = nullptr;  // 1 on a depth contour (closed), else 0
  const std::uint8_t* barrier_b = nullptr;
  const float* strength_a = nullptr;  // s_p = M_fuse * M_I of Eq. 17
  const float* strength_b = nullptr;
  const std::uint8_t* grey_a = nullptr;  // image guidance; unused without a colour table
  const std::uint8_t* grey_b = nullptr;
};

struct EdgeRule {
  float scale = 0.0f;             // 2 λ_s: each undirected edge appears twice in Eq. 20
  float floor = 0.0f;             // least weight, so the system stays connected
  const float* colour = nullptr;  // 256 weights by grey-level difference; null = no guidance
  // Every colour weight from this difference on is below `floor` (colour_floor_from gives it;
  // 256: none), so every such edge gets the floor. The vector kernel then reads the weights of the
  // smaller differences from registers; for that, strengths must be >= 0 (the densifier's are
  // products of two maps in [0, 1]).
  int colour_floor_from = 256;
};

// The least k such that colour[j] < floor for every j in k .. 255 (256 when colour[255] is not).
inline int colour_floor_from(const float* colour, float floor) {
  int k = 256;
  while (k > 0 && colour[k - 1] < floor) --k;
  return k;
}

// out[i] = scale * floor where exactly one end is on a barrier (Eq. 16, first case), else
// scale * max((1 - min(s_a, s_b)) * colour[|g_a - g_b|], floor), for i < n.
void edge_weights_row(const EdgeEnds& ends, const EdgeRule& rule, int n, float* out);

// The data terms of one row of Eq. 20 (data, Eq. 13–14; the hole hint; stability, Eq. 18–19).
// A value is known when finite and positive. Pixel x gets
//   data[x] = regulariser + w + w2,  b[x] = 0 + w * v + w2 * v2, where
//   w, v = lambda_d, sparse[x] where sparse is known, else hint_weight, hint[x] where hint[x] > 0,
//          else 0, 0;
//   w2, v2 = lambda_s2, previous[x] where previous (nullable) is known, else 0, 0;
// *low / *high become the least / largest of themselves and the known values read.
struct DataTermRule {
  float regulariser = 0.0f;
  float lambda_d = 0.0f;
  float hint_weight = 0.0f;  // >= 0
  float lambda_s2 = 0.0f;
};
void data_terms_row(const float* sparse, const float* hint, const float* previous, int width,
                    const DataTermRule& rule, float* data, float* b, float* low, float* high);
// diag[x] = data[x] + the weights of the edges of pixel x that exist (kernels::pixel::diagonal;
// wy and wy_above null on the last and first row) and inv_diag[x] = 1 / diag[x] (0 where 0).
void diagonal_row(const float* data, const float* wx, const float* wy, const float* wy_above,
                  int width, float* diag, float* inv_diag);

// The hint of each hole of one row (Densifier): the nearest known sparse values to its left and
// right (0 where there is none); a known pixel's entry is not written (its hint is its own
// value, which the readers take from the sparse row). A hole takes the farther (the
// smaller) of the two, unless the path to exactly one of them crosses a weak smoothness edge,
// wx[j] < crossing for an edge j between the hole and that value, in which case the hole takes
// the other one (it lies on the other side's surface). wx[j] joins pixels j and j + 1;
// wx[width - 1] is not read.
void hole_hint_row(const float* sparse, const float* wx, int width, float crossing, float* hint);

// Where a near surface hides a far one from the right camera, the left image shows the far
// surface in a strip just left of the near surface's edge, as wide as the disparity jump between
// the two; the stereo stage leaves it without matches. The weak hole hint lets the smoothness
// term ramp such a strip towards the near side, so a virtual plane between the two surfaces
// would cut the ramp anywhere in the strip rather than at the near surface's edge.
// For one row: every hole run with a known value on either side, the smaller (farther) one on
// its left, whose width fits the jump between them, gets data[x] += rule.weight and
// b[x] += rule.weight * far for each pixel x of its strip (pixel::occlusion_strip: the run's first
// pixels, as many as the jump; far: the value left of the run). A run that holds no strip alone
// is tried together with the previous run, when that holds none and at most 4 matches lie
// between them (pixel::fill_occlusion_run); those matches are then pulled too. Two kinds of
// holes drop the hole hint data_terms_row gave them (data[x] -= rule.hint_weight,
// b[x] -= rule.hint_weight * hint[x] where hint[x] > 0; so call it after data_terms_row on the
// same row): the near surface's rim past a strip, beyond pixel::kRimHintPixels, and the holes
// of a run without a strip whose left neighbour is the nearer by pixel::kMinOcclusionJump or
// more (right of a near surface no occlusion lies). rule.weight 0: no strips, only the latter.
// Runs that touch the row's ends are left alone. Returns the pixels pulled.
struct OcclusionRule {
  float weight;       // of the pull of a strip towards the far value
  float hint_weight;  // data_terms_row's rule.hint_weight
};
int occlusion_fill_row(const float* sparse, const float* hint, int width, const OcclusionRule& rule,
                       float* data, float* b);

namespace scalar {
// Gauss-Seidel update of the pixels of one colour of row y, columns start, start + 2, ...
// (start 0 or 1): x[c] = (b[c] + Σ w x(neighbour)) * inv_diag[c]. The pixels of the other
// colour, which the updates read, are left as they are. The reference of the solver's updates:
// the sweeps run grid_smooth_split_row, and the GPU passes the same per-pixel math.
void grid_smooth_row(const GridRow& row, int start, const float* b, float* x);
void hole_hint_row(const float* sparse, const float* wx, int width, float crossing, float* hint);
int occlusion_fill_row(const float* sparse, const float* hint, int width, const OcclusionRule& rule,
                       float* data, float* b);
void data_terms_row(const float* sparse, const float* hint, const float* previous, int width,
                    const DataTermRule& rule, float* data, float* b, float* low, float* high);
void diagonal_row(const float* data, const float* wx, const float* wy, const float* wy_above,
                  int width, float* diag, float* inv_diag);
void edge_weights_row(const EdgeEnds& ends, const EdgeRule& rule, int n, float* out);
void grid_apply_row(const GridRow& row, const float* x, float* out);
void grid_smooth_split_row(const SplitSmoothRow& row, float* x);
void split_residual_row(const SplitResidualRow& row, float* out);
void inverse_diagonal_row(const float* diag, int n, float* inv);
void split_row(const float* in, int width, float* even, float* odd);
void merge_row(const float* even, const float* odd, int width, float* out);
double dot_row(const float* a, const float* b, int n);
void match_plane_row_sums(const float* match, const float* d, const float* dd, int n, int radius,
                          float* sums);
void match_plane_window_sums(const float* const* rows, int radius, int n, float* sums);
void match_plane_window_slide(const float* const* rows, const float* left, int radius, int n,
                              float* sums);
void match_plane_row(const float* sums, const float* own, int n, const MatchPlaneRule& rule,
                     float* plane);
void match_plane_select_half_row(const float* sparse, const float* own, const float* plane,
                                 int width, float* out);
}  // namespace scalar

}  // namespace dco::kernels
